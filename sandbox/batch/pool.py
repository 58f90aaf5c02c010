"""Workers on Ray: one :class:`~sandbox.batch.worker.DrapeWorker` actor per slot.

Local by default: ``ray.init`` starts a Ray instance on this machine with its cores, and
shuts it down at the end (nothing to start by hand). With an address (``--address
HOST:PORT`` or ``RAY_ADDRESS``), the batch joins that cluster and uses its CPUs; every node
needs this package installed (``pip install -e .``), and no shared file system: the
workers send their files back to the driver.

The scheduler (:mod:`sandbox.batch.run`) sees a pool through four calls: :meth:`submit`
a task to a free slot, :meth:`wait` for finished ones, :meth:`kill` a slot's worker (it is
replaced by a fresh one) and :meth:`close`.
"""

from __future__ import annotations

import logging
import os
import time
from dataclasses import dataclass

from sandbox.batch.worker import DrapeWorker, worker_env
from sandbox.errors import SandboxError

log = logging.getLogger(__name__)

START_TIMEOUT_S = 300.0
"""Longest wait [s] for the first workers to start (import the package, start Taichi)."""


@dataclass
class Finished:
    """A slot whose task ended: the worker's answer, or why the worker died."""

    slot: int
    task: object
    result: dict | None
    """What :meth:`DrapeWorker.run` returned; None when the worker died."""
    died: str | None = None
    """Why the worker died (crashed, killed, out of memory); None when it answered."""


def ray_address(address: str | None) -> str | None:
    """The cluster to join: ``address``, else ``RAY_ADDRESS``, else None (a local Ray)."""
    return address or os.environ.get("RAY_ADDRESS") or None


def check_reachable(address: str, timeout_s: float = 5.0) -> None:
    """Refuse a cluster address where nothing answers (``ray.init`` would retry for ever):
    a TCP connection to its ``HOST:PORT`` within ``timeout_s`` [s]. ``auto`` (the cluster
    started on this machine by ``ray start``) is left to Ray."""
    import socket

    if address == "auto":
        return
    where = address.removeprefix("ray://")
    host, _, port = where.rpartition(":")
    if not host or not port.isdigit():
        raise SandboxError(f"--address {address}: give HOST:PORT (or auto)")
    try:
        socket.create_connection((host, int(port)), timeout=timeout_s).close()
    except OSError as exc:
        raise SandboxError(
            f"--address {address}: nothing answers there ({exc.strerror or exc})"
        ) from None


def local_workers(threads: int) -> int:
    """Workers a local batch starts by default: this machine's cores / ``threads``."""
    return max(1, (os.cpu_count() or 1) // threads)


class RayPool:
    """``workers`` long-lived drape workers as Ray actors, each on ``threads`` CPUs."""

    def __init__(self, workers: int | None, *, threads: int = 1, float64: bool = True,
                 address: str | None = None):  # fmt: skip
        self.threads, self.float64 = threads, float64
        self.address = ray_address(address)
        self.requested = workers
        self.started_ray = False
        self.actors: list = []
        self.running: dict = {}  # ObjectRef -> (slot, task)

    # ------------------------------------------------------------------ life cycle
    def start(self) -> int:
        """Start (or join) Ray and the workers; returns how many."""
        import ray

        if not ray.is_initialized():
            kwargs = dict(include_dashboard=False, log_to_driver=False,
                          logging_level=logging.WARNING)  # fmt: skip
            if self.address:
                check_reachable(self.address)
                try:
                    ray.init(address=self.address, **kwargs)
                except (ConnectionError, RuntimeError, ValueError, TimeoutError) as exc:
                    first = " ".join(str(exc).split())[:300]
                    raise SandboxError(
                        f"--address {self.address}: cannot join the Ray cluster "
                        f"({type(exc).__name__}: {first})"
                    ) from None
            else:
                n = self.requested or local_workers(self.threads)
                ray.init(num_cpus=n * self.threads, **kwargs)
                self.started_ray = True
        cpus = int(ray.cluster_resources().get("CPU", 1))
        n = self.requested or max(1, cpus // self.threads)
        self.actors = [self._new_actor() for _ in range(n)]
        self._check_started()
        return n

    def _new_actor(self):
        import ray

        cls = ray.remote(DrapeWorker)
        return cls.options(num_cpus=self.threads, max_restarts=0, max_concurrency=1,
                           runtime_env={"env_vars": worker_env(self.threads)}).remote(
            threads=self.threads, float64=self.float64)  # fmt: skip

    def _check_started(self) -> None:
        """Wait until every worker answers; a SandboxError if none can start (e.g. the
        package is missing on the cluster's nodes)."""
        import ray

        refs = [a.info.remote() for a in self.actors]
        try:
            ray.get(refs, timeout=START_TIMEOUT_S)
        except ray.exceptions.GetTimeoutError:
            raise SandboxError(
                f"ray: the workers did not start within {START_TIMEOUT_S:g} s "
                "(not enough free CPUs in the cluster?)"
            ) from None
        except ray.exceptions.RayError as exc:
            first = str(exc).strip().splitlines()[-1][:300] if str(exc).strip() else repr(exc)
            raise SandboxError(f"ray: a worker could not start: {first}") from None

    def close(self) -> None:
        import ray

        for a in self.actors:
            try:
                ray.kill(a)
            except Exception:  # already gone
                pass
        self.actors, self.running = [], {}
        if self.started_ray and ray.is_initialized():
            ray.shutdown()

    # ------------------------------------------------------------------ tasks
    @property
    def size(self) -> int:
        return len(self.actors)

    def submit(self, slot: int, task) -> None:
        ref = self.actors[slot].run.remote(task)
        self.running[ref] = (slot, task)

    def wait(self, timeout_s: float) -> list[Finished]:
        """The tasks that ended within ``timeout_s`` [s] (possibly none)."""
        import ray

        if not self.running:
            time.sleep(min(timeout_s, 0.1))
            return []
        ready, _ = ray.wait(list(self.running), num_returns=1, timeout=timeout_s)
        if ready:  # collect whatever else is done too
            ready, _ = ray.wait(list(self.running), num_returns=len(self.running), timeout=0)
        out = []
        for ref in ready:
            slot, task = self.running.pop(ref)
            try:
                out.append(Finished(slot, task, ray.get(ref)))
            except ray.exceptions.RayError as exc:
                self._replace(slot)
                out.append(Finished(slot, task, None, _death_reason(exc)))
        return out

    def kill(self, slot: int) -> None:
        """Kill the slot's worker (its task is dropped) and start a fresh one."""
        import ray

        for ref, (s, _) in list(self.running.items()):
            if s == slot:
                del self.running[ref]
        try:
            ray.kill(self.actors[slot])
        except Exception:  # already gone
            pass
        self._replace(slot)

    def _replace(self, slot: int) -> None:
        self.actors[slot] = self._new_actor()


def _death_reason(exc) -> str:
    """One line saying why a Ray call failed (the worker crashed, was killed, ran out of
    memory)."""
    text = " ".join(str(exc).split())
    kind = type(exc).__name__
    for marker in ("The actor died", "Worker exit", "SIGKILL", "out of memory", "OOM"):
        i = text.find(marker)
        if i >= 0:
            return f"{kind}: {text[i : i + 200]}"
    return f"{kind}: {text[:200]}"
