"""The batch folder on disk: task folders written whole or not at all, the plan, the lock.

::

    OUT/
      spec.toml            the spec the batch was last run with (a copy)
      plan.jsonl           every task of the spec, its inputs, one JSON object a line
      tasks/<task_id>/     a finished task: metrics.json (with its "batch" block),
                           positions.npy, and garment.obj/.ply, render*.png as asked
      tasks/.tmp-*/        a task being written (removed when the batch starts again)
      manifest.parquet     every task: inputs, status, gates, metrics, timings
      manifest.jsonl       the same rows as JSON lines
      summary.json         the last run: counts, wall time, drapes per hour

A task is written into ``tasks/.tmp-<task_id>-...`` and renamed to ``tasks/<task_id>``
only when every file is in it and synced; so a task is done exactly when its folder exists
and its ``metrics.json`` is complete (:func:`is_done`), whenever the batch was killed.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import shutil
import uuid
from collections.abc import Iterator
from pathlib import Path

from sandbox.errors import SandboxError

TASKS = "tasks"
PLAN = "plan.jsonl"
SPEC_COPY = "spec.toml"
SUMMARY = "summary.json"
LOCK = ".lock"
TEMP_PREFIXES = (".tmp-", ".old-")
STATUSES = ("accepted", "rejected", "failed", "missing")
"""A task's status in the manifest; ``missing``: not run yet (or interrupted)."""


def jsonable(obj):
    """``obj`` with numpy scalars as Python numbers and NaN/inf as None (strict JSON)."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [jsonable(v) for v in obj]
    if hasattr(obj, "item") and not isinstance(obj, str | bytes):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def task_dir(root, task_id: str) -> Path:
    return Path(root) / TASKS / task_id


def read_task(folder) -> dict | None:
    """The metrics.json of a finished task folder, or None when it is missing or
    incomplete (unreadable, not JSON, no complete ``batch`` block)."""
    path = Path(folder) / "metrics.json"
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return None
    batch = data.get("batch") if isinstance(data, dict) else None
    if not isinstance(batch, dict) or batch.get("complete") is not True:
        return None
    if batch.get("task_id") != Path(folder).name:
        return None
    return data


def is_done(root, task_id: str) -> bool:
    """Whether the task's final folder exists with a complete metrics.json."""
    return read_task(task_dir(root, task_id)) is not None


def _fsync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_task(root, task_id: str, metrics: dict, files: dict[str, bytes]) -> Path:
    """Write a finished task: ``files`` (name -> bytes) and ``metrics.json`` (last) into a
    temporary folder, sync them, then rename it to ``tasks/<task_id>`` (replacing an
    earlier folder of the task, e.g. a failed one run again). Returns the final folder."""
    tasks = Path(root) / TASKS
    tasks.mkdir(parents=True, exist_ok=True)
    stamp = f"{os.getpid()}-{uuid.uuid4().hex[:8]}"
    tmp = tasks / f".tmp-{task_id}-{stamp}"
    final = tasks / task_id
    old = None
    try:
        tmp.mkdir()
        for name, data in files.items():
            if "/" in name or name.startswith(".") or name == "metrics.json":
                raise SandboxError(f"{task_id}: bad output file name {name!r}")
            (tmp / name).write_bytes(data)
            _fsync(tmp / name)
        text = json.dumps(jsonable(metrics), indent=2) + "\n"
        (tmp / "metrics.json").write_text(text, encoding="utf-8")
        _fsync(tmp / "metrics.json")
        _fsync(tmp)
        if final.exists():
            old = tasks / f".old-{task_id}-{stamp}"
            os.rename(final, old)
        os.rename(tmp, final)
        _fsync(tasks)
    except OSError as exc:
        raise SandboxError(f"{final}: cannot write the task ({exc.strerror or exc})") from None
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)
    return final


def clean_temporary(root) -> list[Path]:
    """Remove the temporary folders an interrupted batch left in ``tasks/``; returns them."""
    tasks = Path(root) / TASKS
    if not tasks.is_dir():
        return []
    gone = [p for p in tasks.iterdir() if p.name.startswith(TEMP_PREFIXES)]
    for p in gone:
        shutil.rmtree(p, ignore_errors=True) if p.is_dir() else p.unlink(missing_ok=True)
    return gone


@contextlib.contextmanager
def locked(root) -> Iterator[None]:
    """Hold ``OUT/.lock`` (an exclusive ``flock``; the system drops it when the process
    dies): a second batch in the same folder is refused instead of mixing its writes."""
    import fcntl

    path = Path(root) / LOCK
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise SandboxError(f"{root}: another batch is running in this folder") from None
        yield
    finally:
        os.close(fd)


def write_plan(root, tasks, spec_path) -> None:
    """``plan.jsonl`` (every task's inputs, in order) and ``spec.toml`` (a copy of the spec)."""
    from sandbox.atomic import write_text

    lines = [json.dumps(jsonable(t.inputs()), sort_keys=True) for t in tasks]
    write_text(Path(root) / PLAN, "\n".join(lines) + "\n")
    write_text(Path(root) / SPEC_COPY, Path(spec_path).read_text(encoding="utf-8"))


def read_plan(root) -> list[dict]:
    """The task inputs of ``plan.jsonl``; SandboxError when the folder holds no batch."""
    path = Path(root) / PLAN
    if not path.is_file():
        raise SandboxError(f"{root}: not a batch folder (no {PLAN})")
    try:
        return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines()
                if line.strip()]  # fmt: skip
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise SandboxError(f"{path}: cannot read the plan ({exc})") from None


def strays(root, task_ids) -> list[str]:
    """Task folders in ``tasks/`` that are not tasks of the plan (an earlier spec's)."""
    tasks = Path(root) / TASKS
    if not tasks.is_dir():
        return []
    known = set(task_ids)
    return sorted(p.name for p in tasks.iterdir()
                  if p.is_dir() and not p.name.startswith(".") and p.name not in known)  # fmt: skip
