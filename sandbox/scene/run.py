"""Run a scene headless: frames of simulated time until the stop rule or a limit.

The same loop serves the CLI, the drapes and the validation runs: a caller may pass
``on_frame`` to look at each frame.
"""

from __future__ import annotations

import logging
import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from tqdm import tqdm

from sandbox.errors import SandboxError
from sandbox.scene.build import Scene
from sandbox.sim.guard import GuardConfig, GuardStop, StepGuard
from sandbox.sim.stop import DisplacementMonitor, StopRule

log = logging.getLogger(__name__)


class SimulationDiverged(SandboxError):
    """A run produced a non-finite position."""


@dataclass
class RunResult:
    """What a run did and how it ended; ``metrics`` is what goes into metrics.json."""

    converged: bool
    reason: str
    metrics: dict = field(default_factory=dict)
    positions: np.ndarray | None = None


def run_scene(
    scene: Scene,
    *,
    progress: bool | None = None,
    on_frame: Callable[[Scene, int], None] | None = None,
    guard: GuardConfig | bool | None = None,
) -> RunResult:
    """Simulate until the stop rule holds or a time limit is reached.

    Every frame runs through the guard (:mod:`sandbox.sim.guard`): an unstable frame (NaN,
    energy growth, hugely stretched or turned-over triangles) is rolled back and re-run
    with half the step. ``guard=False`` switches the rollback off (NaN is still caught);
    a :class:`GuardConfig` sets its thresholds. The ``guard_*`` metrics say whether it fired.

    Raises SimulationDiverged (naming the step and the vertex) if a position becomes NaN
    or infinite and the guard cannot recover; nothing is written in that case.
    """
    spec, model, solver = scene.spec, scene.model, scene.solver
    stop = spec.stop
    frame_s = scene.steps_per_frame * scene.dt_s
    rule = StopRule(stop.max_displacement_m, stop.mean_displacement_m, stop.frames)
    monitor = DisplacementMonitor(model)
    solver.reset_watch()
    if guard is None or guard is True:
        guard = GuardConfig()
    elif guard is False:
        guard = GuardConfig(enabled=False)
    watch = StepGuard(scene, guard)
    dt_note = dt_warning(scene)
    if dt_note:
        log.warning("%s", dt_note)

    t0 = time.perf_counter()
    solver.warm_up(scene.state, scene.control)  # compiles every kernel; changes nothing
    monitor.reset(scene.state)
    monitor.measure(scene.state)
    compile_s = time.perf_counter() - t0

    frames_total = math.ceil(stop.time_limit_s / frame_s - 1e-9)
    show = sys.stderr.isatty() if progress is None else progress
    bar = tqdm(total=frames_total, disable=not show, unit="frame", desc=spec.name, leave=False)
    steps = frame = 0
    checks = []  # residual checks of the frames where the displacement rule held
    max_d = mean_d = math.inf
    converged, reason = False, "time limit"
    t_start = time.perf_counter()
    try:
        while frame < frames_total:
            try:
                steps += watch.advance_frame(frame)
            except GuardStop as exc:
                raise SimulationDiverged(str(exc)) from exc
            frame += 1
            max_d, mean_d = monitor.measure(scene.state)
            bar.update(1)
            if on_frame is not None:
                on_frame(scene, frame)
            if rule.update(max_d, mean_d) and frame * frame_s >= stop.min_time_s:
                rest = True if stop.residual_mean is None else _at_rest(
                    scene, stop.residual_mean, checks)  # fmt: skip
                if rest:
                    converged, reason = True, "stop rule"
                    break
                if rest is None:
                    converged, reason = True, "stop rule, residual no longer falling"
                    break
            if time.perf_counter() - t_start > stop.wall_limit_s:
                reason = "wall-clock limit"
                break
    finally:
        bar.close()
    wall = time.perf_counter() - t_start
    metrics = {
        "scene": spec.name,
        "vertex_count": model.particle_count,
        "triangle_count": model.tri_count,
        "hinge_count": model.hinge_count,
        "steps": steps,
        "dt_s": scene.dt_s,
        "dt_stability_estimate_s": scene.dt_limit_s,
        "frames": frame,
        "sim_time_s": frame * frame_s,
        "wall_time_s": wall,
        "compile_time_s": compile_s,
        "converged": converged,
        "stop_reason": reason,
        "max_displacement_m": max_d,
        "mean_displacement_m": mean_d,
        "stop_max_displacement_m": stop.max_displacement_m,
        "stop_mean_displacement_m": stop.mean_displacement_m,
        "vertex_steps_per_s": model.particle_count * steps / wall if wall > 0 else None,
        "dt_above_stable_limit": bool(dt_note),
        "dt_warning": dt_note,
        "dt_policy": "guard-adaptive" if guard.enabled else "fixed",
        "stop_residual_mean": stop.residual_mean,
        "residual_checks": len(checks),
        **watch.metrics(),
    }
    metrics.update(state_metrics(scene))
    log.info("%s: %s after %d steps (%.2f s simulated, %.2f s wall)", spec.name, reason,
             steps, frame * frame_s, wall)  # fmt: skip
    return RunResult(converged, reason, metrics, scene.state.positions())


RESIDUAL_PLATEAU_CHECKS = 6
"""After this many residual checks (frames that met the displacement rule), a residual whose
last half fell by less than 10 % below the best of the earlier ones is not waited for
(measured: the long-sleeve shirt at 1 cm rests with a mean residual of 3.5 weights, its
sleeves lying on its sides)."""


def _at_rest(scene: Scene, limit: float, checks: list) -> bool | None:
    """Whether the mean equilibrium residual over weight
    (:func:`~sandbox.sim.residual.scene_residual`) is below ``limit``: a displacement rule
    met only because damping slowed the cloth down does not stop the run. None when it is
    not, but has stopped falling (:data:`RESIDUAL_PLATEAU_CHECKS`): what is left is support
    the residual does not model (cloth resting on cloth), and the run stops on the
    displacement rule alone, its metrics saying so."""
    from sandbox.sim.residual import scene_residual

    r = scene_residual(scene)["residual_mean_over_weight"]
    checks.append(r)
    if r < limit:
        return True
    n = RESIDUAL_PLATEAU_CHECKS
    if len(checks) >= n and min(checks[-n // 2 :]) > 0.9 * min(checks[: -n // 2]):
        return None
    return False


def state_metrics(scene: Scene) -> dict:
    """What the run's final state and its solver report: Newton's totals (``newton``, implicit
    Euler only: since the solver was made or its stats reset, so a drape's include the
    sewing), the equilibrium residual (:func:`~sandbox.sim.residual.scene_residual`), the
    seam gap and the contact measures (:func:`contact_metrics`)."""
    from sandbox.sim.residual import scene_residual

    model = scene.model
    out = {}
    s = scene.solver.stats()
    if s:
        out["newton"] = {key: int(s[key]) for key in (
            "steps", "newton_iterations", "unconverged_steps", "line_search_halvings",
            "factorisations")}  # fmt: skip
        out["newton"]["max_residual_force_over_weight"] = float(s["max_residual_force_over_weight"])
    x_final = scene.state.positions()
    out.update(scene_residual(scene))
    if model.seam_count:
        out["seam_count"] = model.seam_count
        out["seam_gap_max_m"] = seam_gap_max(model, x_final)
    out.update(contact_metrics(model, x_final))
    if model.self_collider is not None:
        out["self_collision_counts"] = model.self_collider.collision_counts()
    return out


def contact_metrics(model, x: np.ndarray) -> dict:
    """Contact measures independent of the solver's own detection, for ``metrics.json``.

    ``penetration_max_m`` and ``vertices_inside_body`` over the closed colliders (None
    without one), ``body_through_cloth_vertices`` and ``body_through_cloth_max_m``: body
    surface showing through the cloth where the cloth covers it
    (:func:`~sandbox.collision.body_probe.body_through_cloth`; None without a closed
    collider), and ``intersecting_triangle_pairs`` of the cloth by an exact
    triangle-triangle test: pairs sharing a vertex or a seam-joined point are excluded
    (:func:`~sandbox.collision.metrics.seam_joined_pairs`: sewn pairs and, at a junction of
    three panels, partners' partners). ``x``: (n, 3) cloth positions [m].
    """
    from sandbox.collision.body_probe import (
        body_inside_check,
        body_through_cloth,
        penetration_metrics,
    )
    from sandbox.collision.metrics import count_intersecting_pairs, seam_joined_pairs

    out = {"penetration_max_m": None, "vertices_inside_body": None,
           "body_through_cloth_vertices": None, "body_through_cloth_max_m": None}  # fmt: skip
    closed = [c for c in model.colliders if c.closed]
    if closed:
        depth, inside, through, through_depth = 0.0, 0, 0, 0.0
        for c in closed:
            body_x = c.body_x.to_numpy().astype(np.float64)
            probe = body_inside_check(body_x, c.triangles_np, name=c.name)
            m = penetration_metrics(x, probe)
            depth = max(depth, m["penetration_max_m"])
            inside += m["vertices_inside_body"]
            shows = body_through_cloth(x, model.tri_indices_np, body_x, c.triangles_np)
            through += shows["body_through_cloth_vertices"]
            through_depth = max(through_depth, shows["body_through_cloth_max_m"])
        out.update(penetration_max_m=depth, vertices_inside_body=inside,
                   body_through_cloth_vertices=through,
                   body_through_cloth_max_m=through_depth)  # fmt: skip
    joined = seam_joined_pairs(model.seam_pairs_np, model.particle_count)
    out["intersecting_triangle_pairs"] = count_intersecting_pairs(
        x, model.tri_indices_np, exclude_vertex_pairs=joined
    )
    return out


def seam_gap_max(model, x: np.ndarray) -> float:
    """Largest distance between a seam's two sides [m] (0 when all seams are closed): at
    each point of the shorter line, to the point of equal parameter on the other
    (:func:`sandbox.sim.seams.seam_openings`)."""
    from sandbox.sim.seams import seam_openings

    gap = seam_openings(model.seam_pairs_np, model.seam_rest_np, x)
    return float(max(0.0, gap.max()))


def dt_warning(scene: Scene) -> str | None:
    """A warning naming the stable limit if the explicit step is above it (else None).

    Symplectic Euler is stable for dt·ω_max < 2; ``scene.dt_limit_s`` is the builder's
    estimate of that limit (``sandbox.scene.build.stable_dt_estimate``). The implicit
    integrator has no such limit.
    """
    if scene.spec.simulation.integrator != "symplectic_euler":
        return None
    if not scene.dt_s > scene.dt_limit_s:
        return None
    return (
        f"{scene.spec.source}: dt_s = {scene.dt_s:.3g} s is above the stable limit of "
        f"symplectic Euler for this cloth, about {scene.dt_limit_s:.3g} s "
        f"(stable_dt_estimate); the guard will halve dt where the run becomes unstable "
        f'(adaptive dt). Use dt_s = "auto" or integrator = "implicit_euler" to avoid it.'
    )


def _diverged_message(scene: Scene, step: int, vertex: int) -> str:
    piece = next(
        (p for p in scene.model.pieces
         if p.particle_start <= vertex < p.particle_start + p.particle_count),
        None,
    )  # fmt: skip
    where = f"vertex {vertex}"
    if piece is not None:
        where += f" (vertex {vertex - piece.particle_start} of cloth {piece.name!r})"
    return (
        f"{scene.spec.source}: the simulation diverged at step {step} "
        f"(t = {step * scene.dt_s:.4f} s): {where} became NaN or infinite. "
        f"dt = {scene.dt_s:.3g} s; the stability estimate is {scene.dt_limit_s:.3g} s: "
        'try a smaller dt_s, more damping or dt_s = "auto". No mesh was written.'
    )
