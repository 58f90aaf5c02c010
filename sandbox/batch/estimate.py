"""How long a batch will take (``batch --dry-run``): a simple model, calibrated when it can.

The model, per task: ``OVERHEAD_S + seconds_per_sim_s × simulated seconds``, where
``seconds_per_sim_s`` is the scene-size budget's prediction
(:func:`sandbox.scene.budget.pattern_size`: vertices of the meshed panels, the explicit
step of the fabric at that edge, or implicit Euler's step) and the simulated time is the
sewing and drape time limits, at most :data:`TYPICAL_SIM_S` (most drapes meet the stop
rule by then). ``coarse_to_fine`` at an edge finer than its coarse level adds the coarse
level and :data:`FINE_SIM_S` of the fine one. The pattern is drafted for the first body
only (sizes change a garment's vertex count by a few per cent). The batch's wall time is
the tasks' sum over the workers (at least the longest task). Measured on a shared 2-core
CPU with one thread per worker, it is within a factor of 2 for explicit drapes at 3-4 cm;
implicit drapes vary more.

Calibration: when the output folder already holds finished tasks, the median ratio of their
measured wall time to the model's scales the estimate of the rest.
"""

from __future__ import annotations

import logging
import statistics
from dataclasses import dataclass

from sandbox.batch.spec import BatchSpec, Task

log = logging.getLogger(__name__)

OVERHEAD_S = 8.0
"""Per task [s]: drafting, meshing, placing, building the scene and measuring the result."""
TYPICAL_SIM_S = 3.0
"""Simulated seconds [s] of a typical drape, sewing included (at most the time limits)."""
FINE_SIM_S = 0.3
"""Simulated seconds [s] of ``coarse_to_fine``'s fine level (it starts next to rest)."""
STARTUP_S = 15.0
"""Starting Ray and the workers and the first kernel compilation [s]."""


@dataclass(frozen=True)
class Estimate:
    """A batch's predicted wall time."""

    tasks: int
    todo: int
    workers: int
    per_task_s: dict
    """Task id -> predicted wall time [s] (the model times ``scale``)."""
    scale: float
    """Calibration: measured / modelled wall time of the finished tasks (1: none yet)."""
    calibrated_on: int
    wall_s: float
    """Predicted wall time of the remaining tasks [s]."""

    def lines(self) -> list[str]:
        calib = "model only, not calibrated (docs/batch.md)"
        if self.calibrated_on:
            calib = f"calibrated on {self.calibrated_on} finished task(s): x{self.scale:.2f}"
        hours = self.wall_s / 3600.0
        rate = 3600.0 * self.todo / self.wall_s if self.wall_s > 0 else 0.0
        return [
            f"{self.tasks} tasks, {self.todo} to run ({self.tasks - self.todo} done), "
            f"{self.workers} workers",
            f"estimated wall time {self.wall_s:.0f} s ({hours:.2f} h), about {rate:.0f} "
            f"drapes/hour; {calib}",
        ]


def _model_s(task: Task, pattern, material) -> float:
    """Predicted wall time [s] of one task by the model (docs above)."""
    from sandbox.scene.budget import pattern_size

    config = task.config
    sim = min(TYPICAL_SIM_S, config.sewing.time_limit_s + config.time_limit_s)
    coarse = config.method == "coarse_to_fine" and task.edge_m < 0.75 * config.coarse_edge_m
    if coarse:
        rate = pattern_size(pattern, config.coarse_edge_m, material, config).seconds_per_sim_s
        fine = pattern_size(pattern, task.edge_m, material, config).seconds_per_sim_s
        return 2.0 * OVERHEAD_S + rate * sim + fine * FINE_SIM_S
    rate = pattern_size(pattern, task.edge_m, material, config).seconds_per_sim_s
    return OVERHEAD_S + rate * sim


def drafted_patterns(spec: BatchSpec) -> dict:
    """Garment label -> its pattern, drafted for the first body (files: as read)."""
    import json

    from sandbox.garment import make_mannequin, resolve_pattern
    from sandbox.pattern.spec import load_pattern

    body = spec.bodies[0]
    mannequin = make_mannequin(body.size, body.measurements())
    patterns = {}
    for g in spec.garments:
        if g.pattern is not None:
            patterns[g.label] = load_pattern(json.loads(g.pattern), where=g.path)
        else:
            patterns[g.label] = resolve_pattern(g.label, mannequin)
    return patterns


def check_sizes(spec: BatchSpec, tasks: list[Task], patterns: dict | None = None) -> None:
    """Refuse, before anything starts, a batch whose drapes exceed ``[drape.limits]``
    (vertices, memory; :func:`sandbox.garment.build.check_drape_size`), each garment
    drafted for the first body: a SandboxError naming the spec, the garment and the edge."""
    from sandbox.errors import SandboxError
    from sandbox.garment.build import check_drape_size
    from sandbox.garment.inputs import material_for

    patterns = patterns or drafted_patterns(spec)
    seen = set()
    for t in tasks:
        key = (t.garment.label, t.fabric, t.edge_m, t.integrator)
        if key in seen:
            continue
        seen.add(key)
        pattern = patterns[t.garment.label]
        try:
            check_drape_size(pattern, t.edge_m, material_for(pattern, t.fabric), t.config,
                             say=False)  # fmt: skip
        except SandboxError as exc:
            raise SandboxError(f"{spec.path}: drape.limits: {t.garment.label} at "
                               f"{t.edge_m * 100:g} cm: {exc}") from None  # fmt: skip


def model_times(spec: BatchSpec, tasks: list[Task], patterns: dict | None = None) -> dict:
    """Task id -> modelled wall time [s]; each garment drafted once, for the first body."""
    from sandbox.garment.inputs import material_for

    patterns = patterns or drafted_patterns(spec)
    out = {}
    for t in tasks:
        pattern = patterns[t.garment.label]
        out[t.task_id] = _model_s(t, pattern, material_for(pattern, t.fabric))
    return out


def estimate(spec: BatchSpec, tasks: list[Task], *, workers: int, done: dict[str, float],
             patterns: dict | None = None) -> Estimate:  # fmt: skip
    """The predicted wall time of the tasks not in ``done`` (task id -> measured wall time
    [s] of finished tasks) on ``workers`` workers."""
    model = model_times(spec, tasks, patterns)
    ratios = [done[t] / model[t] for t in done if t in model and model[t] > 0 and done[t] > 0]
    scale = statistics.median(ratios) if ratios else 1.0
    todo = [t.task_id for t in tasks if t.task_id not in done]
    per_task = {t: model[t] * scale for t in todo}
    spread = sum(per_task.values()) / max(1, workers)
    wall = max([spread, *per_task.values()]) + (STARTUP_S if todo else 0.0)
    return Estimate(len(tasks), len(todo), workers, per_task, scale, len(ratios), wall)
