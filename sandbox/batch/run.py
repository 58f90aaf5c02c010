"""Run a batch: the tasks not done yet, on a pool of workers, each written as it finishes.

:func:`run_batch` checks the output folder, takes its lock, removes what an interrupted
run left half-written, writes the plan, runs every task whose folder is missing (and, with
``retry_failed``, the failed ones again) on a :class:`~sandbox.batch.pool.RayPool`, then
rebuilds the manifest from the folders and writes ``summary.json``.

Failures: a task whose drape raises (bad input, a diverged run) is written as failed with
the message and not run again (it would fail the same way); a task whose worker dies
(crash, out of memory, killed) is run again on a fresh worker up to ``retries`` times, then
written as failed with the reason; a task past ``kill_after_s`` has its worker killed and is
written as failed by the ``time_limit`` gate. The batch goes on after each.
"""

from __future__ import annotations

import collections
import logging
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from sandbox.batch import manifest, store
from sandbox.batch.gates import GATES, failed_gates
from sandbox.batch.spec import BatchSpec, Task, expand_tasks

log = logging.getLogger(__name__)

POLL_S = 1.0
"""How often [s] the driver looks at running tasks' wall clocks."""


@dataclass
class BatchSummary:
    """What a run of a batch did, and where the batch stands."""

    name: str
    tasks: int
    done_before: int
    ran: int
    workers: int
    wall_s: float
    """Wall time of this run [s], start to manifest."""
    status: dict = field(default_factory=dict)
    """Tasks of the batch per status (accepted, rejected, failed, missing)."""
    gates: dict = field(default_factory=dict)
    """Tasks of the batch that fail each gate (a task may fail several)."""

    @property
    def drapes_per_hour(self) -> float:
        return 3600.0 * self.ran / self.wall_s if self.wall_s > 0 and self.ran else 0.0

    def as_dict(self) -> dict:
        return {"name": self.name, "tasks": self.tasks, "done_before": self.done_before,
                "ran": self.ran, "workers": self.workers, "wall_s": self.wall_s,
                "drapes_per_hour": self.drapes_per_hour, "status": self.status,
                "gates": self.gates}  # fmt: skip

    def lines(self) -> list[str]:
        s = self.status
        gates = ", ".join(f"{g} {n}" for g, n in self.gates.items() if n) or "none"
        workers = f", {self.workers} workers" if self.ran else ""
        return [
            f"batch {self.name}: {self.tasks} tasks, {self.ran} run now "
            f"({self.done_before} done before){workers}",
            f"accepted {s.get('accepted', 0)}, rejected {s.get('rejected', 0)}, failed "
            f"{s.get('failed', 0)}, missing {s.get('missing', 0)}",
            f"per gate: {gates}",
            f"wall {self.wall_s:.0f} s, {self.drapes_per_hour:.0f} drapes/hour",
        ]


def summarize(name: str, rows: list[dict], *, done_before: int, ran: int, workers: int,
              wall_s: float) -> BatchSummary:  # fmt: skip
    """Counts per status and per gate over the manifest's rows."""
    status = {k: sum(r["status"] == k for r in rows) for k in store.STATUSES}
    gates = {g: sum(g in (r["gates_failed"] or []) for r in rows) for g in GATES}
    return BatchSummary(name, len(rows), done_before, ran, workers, wall_s, status, gates)


def _task_status(out: Path, task: Task) -> str | None:
    data = store.read_task(store.task_dir(out, task.task_id))
    return None if data is None else data["batch"].get("status")


def run_batch(spec: BatchSpec, out_dir, *, workers: int | None = None,
              address: str | None = None, retry_failed: bool = False,
              progress: bool = True, pool=None) -> BatchSummary:  # fmt: skip
    """Run the tasks of ``spec`` that ``out_dir`` lacks; returns the summary.

    ``workers``: how many (default: one per core of this machine, or per CPU of the
    cluster, divided by ``spec.threads_per_worker``); ``address``: a Ray cluster to join
    (default ``RAY_ADDRESS``, else a local Ray); ``pool``: a pool object to use instead of
    Ray (tests).
    """
    from sandbox import preflight
    from sandbox.atomic import make_dir, write_json
    from sandbox.batch.pool import RayPool, check_reachable, ray_address

    t0 = time.perf_counter()
    out = preflight.check_output_dir(out_dir, "--out")
    if pool is None and ray_address(address):
        check_reachable(ray_address(address))  # before anything is written
    make_dir(out)
    tasks = expand_tasks(spec)
    with store.locked(out):
        for p in store.clean_temporary(out):
            log.warning("%s: removed what an interrupted run left half-written", p)
        manifest.remove(out)  # rebuilt at the end; until then load() reads the folders
        store.write_plan(out, tasks, spec.path)
        stray = store.strays(out, [t.task_id for t in tasks])
        if stray:
            log.warning("%s: %d task folder(s) of another spec are left alone (e.g. %s)",
                        out / store.TASKS, len(stray), stray[0])  # fmt: skip
        status = {t.task_id: _task_status(out, t) for t in tasks}
        todo = [t for t in tasks if status[t.task_id] is None
                or (retry_failed and status[t.task_id] == "failed")]  # fmt: skip
        done_before = len(tasks) - len(todo)
        n = 0
        if todo:
            pool = pool or RayPool(workers, threads=spec.threads_per_worker,
                                   float64=spec.float64, address=address)  # fmt: skip
            try:
                n = pool.start()
                _Scheduler(pool, spec, out, len(tasks), done_before, progress).run(todo)
            finally:
                pool.close()
        rows = manifest.build_rows(out)
        manifest.write_manifest(out, rows)
        summary = summarize(spec.name, rows, done_before=done_before, ran=len(todo), workers=n,
                            wall_s=time.perf_counter() - t0)  # fmt: skip
        write_json(out / store.SUMMARY, store.jsonable(summary.as_dict()))
    return summary


class _Scheduler:
    """Hands tasks to free slots, writes each finished one, retries, enforces hard limits."""

    def __init__(self, pool, spec: BatchSpec, out: Path, total: int, done_before: int,
                 progress: bool):  # fmt: skip
        from tqdm import tqdm

        self.pool, self.spec, self.out = pool, spec, out
        self.attempts: collections.Counter = collections.Counter()
        self.counts: collections.Counter = collections.Counter()
        self.bar = tqdm(total=total, initial=done_before, unit="drape", disable=not progress,
                        file=sys.stderr, dynamic_ncols=True, smoothing=0.2)  # fmt: skip

    def run(self, todo: list[Task]) -> None:
        queue = collections.deque(todo)
        free = list(range(self.pool.size))
        running: dict[int, tuple[Task, float, float]] = {}  # slot -> task, clock, Unix time
        try:
            while queue or running:
                while free and queue:
                    slot, task = free.pop(0), queue.popleft()
                    self.attempts[task.task_id] += 1
                    self.pool.submit(slot, task)
                    running[slot] = (task, time.perf_counter(), time.time())
                for f in self.pool.wait(POLL_S):
                    task, clock, started_at = running.pop(f.slot)
                    free.append(f.slot)
                    tries = self.attempts[task.task_id]
                    if f.died is not None and tries <= self.spec.retries:
                        self._say(f"{task.task_id}: worker died ({f.died}); running it again "
                                  f"({tries} of {self.spec.retries})")  # fmt: skip
                        queue.appendleft(task)
                        continue
                    error = None if f.died is None else (
                        f"worker died {tries} time(s), last: {f.died}")  # fmt: skip
                    self._write(task, f.result, clock, started_at, error=error)
                now = time.perf_counter()
                for slot, (task, clock, started_at) in list(running.items()):
                    if now - clock > task.kill_after_s:
                        self.pool.kill(slot)
                        del running[slot]
                        free.append(slot)
                        self._write(task, None, clock, started_at, killed=True,
                                    error=f"time limit: worker killed after "
                                    f"{now - clock:.0f} s (kill_after_s = "
                                    f"{task.kill_after_s:g})")  # fmt: skip
        finally:
            self.bar.close()

    def _write(self, task: Task, result: dict | None, clock: float, started_at: float, *,
               error: str | None = None, killed: bool = False) -> None:  # fmt: skip
        """Write the task's folder (whole, then renamed) and advance the progress bar."""
        elapsed = time.perf_counter() - clock
        result = result or {}
        batch = {
            "task_id": task.task_id,
            "complete": True,
            "inputs": task.inputs(),
            "attempts": self.attempts[task.task_id],
            "worker": result.get("worker"),
            "timings": {
                "task_wall_s": result.get("wall_s", elapsed),
                "driver_wall_s": elapsed,
                "started_at": started_at,
                "finished_at": time.time(),
            },  # fmt: skip
            "error": None,
            "positions_sha256": None,
        }
        files: dict[str, bytes] = {}
        if result.get("status") == "ok" and error is None:
            metrics = dict(result["metrics"])
            gates = failed_gates(metrics, task.gates)
            batch.update(status="rejected" if gates else "accepted", gates_failed=gates,
                         positions_sha256=result["positions_sha256"])  # fmt: skip
            files = result["files"]
        else:
            metrics = {}
            batch.update(status="failed", gates_failed=["time_limit"] if killed else [],
                         error=error or result.get("error") or "no result")  # fmt: skip
        metrics["batch"] = batch
        store.write_task(self.out, task.task_id, metrics, files)
        self.counts[batch["status"]] += 1
        self.bar.set_postfix(ok=self.counts["accepted"], rejected=self.counts["rejected"],
                             failed=self.counts["failed"], refresh=False)  # fmt: skip
        self.bar.update(1)
        if batch["status"] == "failed":
            self._say(f"{task.task_id}: failed: {batch['error']}")

    def _say(self, text: str) -> None:
        """A warning line that does not break the progress bar."""
        if self.bar.disable:
            log.warning("%s", text)
        else:
            self.bar.write(f"warning: {text}", file=sys.stderr)
