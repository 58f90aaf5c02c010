"""The batch manifest: one row per task (inputs, status, gates, metrics, timings).

It is rebuilt from ``plan.jsonl`` and the task folders (:func:`build_rows`) at the end of
every run and by ``--report``, so it never disagrees with them, and written as
``manifest.parquet`` (pyarrow, typed columns below) and ``manifest.jsonl``.
:func:`load` returns it as a pandas DataFrame.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from sandbox.batch import store
from sandbox.batch.gates import GATES
from sandbox.errors import SandboxError

PARQUET = "manifest.parquet"
JSONL = "manifest.jsonl"

MEASUREMENT_KEYS = ("bust_girth", "waist_girth", "hip_girth", "shoulder_width", "back_width",
                    "shoulder_length", "back_length")  # fmt: skip
"""The body's seven measurements [cm], one column each (``<key>_cm``)."""

METRIC_COLUMNS = {
    "vertex_count": "int64",
    "fabric_used": "string",
    "converged": "bool",
    "stop_reason": "string",
    "sim_time_s": "float64",
    "sew_sim_time_s": "float64",
    "dt_s": "float64",
    "seam_gap_max_m": "float64",
    "penetration_max_m": "float64",
    "vertices_inside_body": "int64",
    "body_through_cloth_max_m": "float64",
    "intersecting_triangle_pairs": "int64",
    "hangs_from": "string",
    "top_below_anchor_m": "float64",
    "folded_area_pct": "float64",
    "fluted_area_pct": "float64",
    "nan_positions": "int64",
    "ease_bust_cm": "float64",
    "ease_waist_cm": "float64",
    "ease_hip_cm": "float64",
    "meets_acceptance": "bool",
}
"""Columns copied from a drape's metrics.json (``fabric_used``: its ``fabric``)."""

COLUMNS = {
    "task_id": "string",
    "index": "int64",
    "garment": "string",
    "pattern_file": "string",
    "body": "string",
    "body_kind": "string",
    "size": "int64",
    **{f"{k}_cm": "float64" for k in MEASUREMENT_KEYS},
    "fabric": "string",
    "edge_m": "float64",
    "integrator": "string",
    "method": "string",
    "wall_limit_s": "float64",
    "status": "string",
    "accepted": "bool",
    "gates_failed": "list",
    **{f"gate_{g}": "bool" for g in GATES},
    "error": "string",
    **METRIC_COLUMNS,
    "task_wall_s": "float64",
    "drape_wall_s": "float64",
    "build_time_s": "float64",
    "started_at": "float64",
    "finished_at": "float64",
    "attempts": "int64",
    "worker_host": "string",
    "worker_pid": "int64",
    "positions_sha256": "string",
    "folder": "string",
}
"""Every column of the manifest and its type (``list``: a list of gate names). Times are
seconds; ``started_at``/``finished_at`` are Unix times [s]; lengths metres, girths cm."""


def _size_measurements(size) -> dict | None:
    from sandbox.mannequin.measurements import size_entry

    try:
        return size_entry(int(size)).measurements.to_dict()
    except (SandboxError, TypeError, ValueError):
        return None


def row(inputs: dict, data: dict | None) -> dict:
    """One manifest row from a task's inputs (plan.jsonl) and its metrics.json (None: not
    done)."""
    r = {k: None for k in COLUMNS}
    for k in ("task_id", "index", "garment", "pattern_file", "body", "body_kind", "size",
              "fabric", "edge_m", "integrator", "method", "wall_limit_s"):  # fmt: skip
        r[k] = inputs.get(k)
    meas = inputs.get("measurements_cm") or _size_measurements(inputs.get("size")) or {}
    for k in MEASUREMENT_KEYS:
        r[f"{k}_cm"] = meas.get(k)
    r["folder"] = f"{store.TASKS}/{inputs['task_id']}"
    if data is None:
        r["status"] = "missing"
        return r
    b = data["batch"]
    r["status"] = b.get("status")
    r["accepted"] = b.get("status") == "accepted"
    failed = list(b.get("gates_failed") or [])
    r["gates_failed"] = failed
    for g in GATES:
        r[f"gate_{g}"] = None if b.get("status") == "failed" and not failed else g in failed
    r["error"] = b.get("error")
    for k in METRIC_COLUMNS:
        r[k] = data.get("fabric" if k == "fabric_used" else k)
    t = b.get("timings") or {}
    r["task_wall_s"] = t.get("task_wall_s")
    r["started_at"] = t.get("started_at")
    r["finished_at"] = t.get("finished_at")
    r["drape_wall_s"] = data.get("total_wall_time_s")
    r["build_time_s"] = data.get("build_time_s")
    r["attempts"] = b.get("attempts")
    w = b.get("worker") or {}
    r["worker_host"] = w.get("host")
    r["worker_pid"] = w.get("pid")
    r["positions_sha256"] = b.get("positions_sha256")
    return r


def build_rows(root) -> list[dict]:
    """Every task of the plan, in order, read from its folder."""
    return [row(inputs, store.read_task(store.task_dir(root, inputs["task_id"])))
            for inputs in store.read_plan(root)]  # fmt: skip


def _arrow_schema():
    import pyarrow as pa

    types = {"string": pa.string(), "int64": pa.int64(), "float64": pa.float64(),
             "bool": pa.bool_(), "list": pa.list_(pa.string())}  # fmt: skip
    return pa.schema([(name, types[kind]) for name, kind in COLUMNS.items()])


def _clean(value, kind: str):
    if value is None:
        return None
    if kind == "float64":
        return float(value)
    if kind == "int64":
        return None if isinstance(value, float) and not math.isfinite(value) else int(value)
    if kind == "bool":
        return bool(value)
    if kind == "string":
        return str(value)
    return [str(v) for v in value]


def to_table(rows: list[dict]):
    """The rows as a pyarrow Table with the manifest's schema."""
    import pyarrow as pa

    data = {name: [_clean(r.get(name), kind) for r in rows] for name, kind in COLUMNS.items()}
    return pa.Table.from_pydict(data, schema=_arrow_schema())


def write_manifest(root, rows: list[dict] | None = None) -> list[Path]:
    """Rebuild the manifest from the folders (or write ``rows``): ``manifest.parquet`` and
    ``manifest.jsonl``, each written to a temporary name and renamed. Returns the paths."""
    import pyarrow.parquet as pq

    from sandbox.atomic import atomic_path, write_text

    rows = build_rows(root) if rows is None else rows
    root = Path(root)
    with atomic_path(root / PARQUET) as tmp:
        pq.write_table(to_table(rows), tmp)
    lines = [json.dumps(store.jsonable({k: r.get(k) for k in COLUMNS})) for r in rows]
    jsonl = write_text(root / JSONL, "\n".join(lines) + "\n" if lines else "\n")
    return [root / PARQUET, jsonl]


def remove(root) -> None:
    """Remove the manifest files (a run does so when it starts: while it runs, or after it
    was killed, :func:`load` rebuilds the manifest from the folders instead of reading an
    earlier run's)."""
    for name in (PARQUET, JSONL):
        (Path(root) / name).unlink(missing_ok=True)


def load(root, *, rebuild: bool = False):
    """The manifest of the batch folder ``root`` as a pandas DataFrame (one row per task,
    columns :data:`COLUMNS`).

    Reads ``manifest.parquet``, written at the end of every run; with ``rebuild=True``, or
    when there is none (a batch running, or killed before its end: a run removes the
    manifest when it starts), rebuilds it from ``plan.jsonl`` and the task folders without
    writing anything.
    """
    import pyarrow.parquet as pq

    root = Path(root)
    path = root / PARQUET
    if rebuild or not path.is_file():
        return to_table(build_rows(root)).to_pandas()
    try:
        return pq.read_table(path).to_pandas()
    except (OSError, ValueError) as exc:
        raise SandboxError(f"{path}: cannot read the manifest ({exc})") from None
