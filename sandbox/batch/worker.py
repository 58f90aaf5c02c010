"""A batch worker: one long-lived process that keeps its Taichi runtime and drapes tasks.

:class:`DrapeWorker` is a plain class (tests call it directly); :mod:`sandbox.batch.pool`
runs one per core as a Ray actor. Its Taichi runtime starts once, so every kernel compiles
once per worker (and comes from Taichi's offline cache on later workers of the machine),
not once per task; :func:`sandbox.runtime.recycle` starts a fresh runtime only when the
field trees of past drapes near Taichi's limit.

A task drapes with the same function as ``python -m sandbox drape``
(:func:`sandbox.garment.drape`) into a temporary folder of the worker's machine, and the
worker returns the files' bytes with the metrics: the driver writes every output, so the
workers need no file system shared with it.

Determinism: a worker runs Taichi's CPU kernels on ``threads`` threads (default 1) and
numpy's BLAS on one. On one thread every parallel loop and atomic sum runs in the same
order each time, so a task's final positions are bit-identical whatever the number of
workers and the order of the tasks; on more, atomic float sums may add in another order
and the last bits differ.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import socket
import tempfile
import time
import traceback
from pathlib import Path

THREAD_VARIABLES = ("TI_CPU_MAX_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                    "MKL_NUM_THREADS")  # fmt: skip
"""Environment variables that set a worker's thread counts (Taichi's CPU pool, BLAS)."""

BODY_CACHE = 8
"""Mannequins a worker keeps built (a body is reused by every garment draped on it)."""
BODY_FILES = ("body.obj", "garment.glb")
"""A drape's files that hold the body (the glTF holds garment and body): kept only with
``body_mesh``."""


def worker_env(threads: int) -> dict[str, str]:
    """The environment variables of a worker process running on ``threads`` threads."""
    return {name: str(threads) for name in THREAD_VARIABLES}


def positions_hash(x) -> str:
    """SHA-256 of the final positions (n, 3) [m] as little-endian bytes of their dtype."""
    import numpy as np

    a = np.ascontiguousarray(x)
    a = a.astype(a.dtype.newbyteorder("<"), copy=False)
    return hashlib.sha256(str(a.dtype).encode() + str(a.shape).encode() + a.tobytes()).hexdigest()


class DrapeWorker:
    """Drapes batch tasks one after another in this process, on one Taichi runtime."""

    def __init__(self, threads: int = 1, float64: bool = True, arch: str = "cpu"):
        os.environ.update(worker_env(threads))  # read by ti.init below
        from sandbox import runtime

        self.threads = threads
        self.float64 = float64
        self.arch = arch
        runtime.init(arch, float64=float64)
        self._bodies: dict = {}
        self.tasks_run = 0

    def info(self) -> dict:
        """Where this worker runs: host, process id, threads, tasks run so far."""
        return {"host": socket.gethostname(), "pid": os.getpid(), "threads": self.threads,
                "tasks_run": self.tasks_run}  # fmt: skip

    def _mannequin(self, body):
        from sandbox.garment import make_mannequin

        key = (body.size, body.measurements_cm)
        if key not in self._bodies:
            if len(self._bodies) >= BODY_CACHE:
                self._bodies.pop(next(iter(self._bodies)))
            self._bodies[key] = make_mannequin(body.size, body.measurements())
        return self._bodies[key]

    def run(self, task) -> dict:
        """Drape one :class:`~sandbox.batch.spec.Task`.

        Returns ``{"status": "ok", "metrics": dict, "files": {name: bytes},
        "positions_sha256": str, "wall_s": float, "worker": dict}``, or ``{"status":
        "failed", "error": one line, ...}`` when the drape raised (bad input, a diverged
        run: not retried, it would fail again). ``files`` holds what the drape wrote
        (renders, meshes as the task asks) and ``positions.npy``, the final positions
        (n, 3) [m] exactly.
        """
        from sandbox import runtime
        from sandbox.errors import SandboxError

        t0 = time.perf_counter()
        started = time.time()
        out = {"worker": self.info(), "started_at": started}
        try:
            runtime.recycle()  # the tasks before are written out: free Taichi's field trees
            mannequin = self._mannequin(task.body)
            out.update(self._drape(task, mannequin))
        except SandboxError as exc:  # includes SimulationDiverged
            out.update(status="failed", error=str(exc).splitlines()[0][:500])
        except Exception as exc:  # a bug: keep its last frame, the batch goes on
            where = traceback.extract_tb(exc.__traceback__)[-1]
            out.update(status="failed", error=f"{type(exc).__name__}: {exc} "
                       f"({Path(where.filename).name}:{where.lineno})"[:500])  # fmt: skip
        self.tasks_run += 1
        out["wall_s"] = time.perf_counter() - t0
        return out

    def _drape(self, task, mannequin) -> dict:
        import numpy as np

        from sandbox.garment import drape

        garment = task.garment.label
        if task.garment.pattern is not None:
            from sandbox.pattern.spec import load_pattern

            garment = load_pattern(json.loads(task.garment.pattern), where=task.garment.path)
        with tempfile.TemporaryDirectory(prefix="sandbox-batch-") as tmp:
            res = drape(garment, mannequin=mannequin, fabric=task.fabric, out_dir=tmp,
                        edge_length_m=task.edge_m, config=task.config, render=task.render,
                        meshes=task.meshes, progress=False)  # fmt: skip
            files = {}
            for path in sorted(Path(tmp).iterdir()):
                if path.is_file() and (task.body_mesh or path.name not in BODY_FILES):
                    files[path.name] = path.read_bytes()
        metrics = json.loads(files.pop("metrics.json"))
        outputs = metrics.setdefault("outputs", {})
        if not task.body_mesh:
            outputs.pop("body_obj", None)
            outputs.pop("garment_glb", None)
        outputs["positions"] = "positions.npy"
        x = np.asarray(res.run.positions)
        buf = io.BytesIO()
        np.save(buf, x)
        files["positions.npy"] = buf.getvalue()
        return {"status": "ok", "metrics": metrics, "files": files,
                "positions_sha256": positions_hash(x)}  # fmt: skip
