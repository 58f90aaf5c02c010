"""Repairing crossings: a garment whose cloth passed through itself is untangled and settled.

Self-collision keeps cloth from crossing but never undoes a crossing it is handed (a panel
beside a closing seam can slip through its neighbour in the seam zone, which self-collision
leaves free so that the seam can close). :func:`untangle_state` smooths crossing triangle
pairs away in place; :func:`settle_repaired` runs a drape that ended tangled on, untangled,
to the stop rule again.
"""

from __future__ import annotations

import dataclasses
import logging
import time

import numpy as np

from sandbox.garment.config import RepairConfig

log = logging.getLogger(__name__)


def untangle_state(scene, when: str = "", config: RepairConfig | None = None) -> dict:
    """Smooth away the garment's crossing triangle pairs in place
    (:func:`~sandbox.collision.untangle.untangle_positions`; seam pairs are not crossings, and
    sewn vertices move together). The moved vertices stop (velocity 0) and are pushed out to
    :attr:`RepairConfig.clearance_m` from the body. Returns ``{"when", "pairs_before",
    "pairs_after", "vertices_moved", "largest_move_m", "wall_time_s"}``.
    """
    from sandbox.collision.untangle import untangle_positions

    config = config or RepairConfig()
    t0 = time.perf_counter()
    model, state = scene.model, scene.state
    x, v = state.positions(), state.velocities()
    body = scene.garment.placement_body if scene.garment is not None else None

    def push_out(y, mask):
        y = y.copy()
        y[mask], _ = body.push_out(y[mask], config.clearance_m)
        return y

    new, before, after, moved = untangle_positions(
        x, model.tri_indices_np, model.rest_uv_np, push_out if body is not None else None,
        seam_pairs=model.seam_pairs_np)  # fmt: skip
    largest = 0.0
    if after < before:
        v = v.copy()
        v[moved] = 0.0
        state.set(new, v)
        largest = float(np.max(np.linalg.norm(new - x, axis=1)))
    else:
        after, moved = before, np.zeros(len(x), bool)
    out = {"when": when, "pairs_before": int(before), "pairs_after": int(after),
           "vertices_moved": int(moved.sum()), "largest_move_m": largest,
           "wall_time_s": time.perf_counter() - t0}  # fmt: skip
    if before:
        log.info("untangle %s: %d -> %d crossing pairs (%d vertices moved, at most %.1f mm)",
                 when, before, after, out["vertices_moved"], 1e3 * largest)  # fmt: skip
    return out


def settle_repaired(scene, result, repairs: list, config: RepairConfig, *, progress=None):
    """Untangle a drape that ended with crossing pairs and run it on to the stop rule again.

    While passes are left (``config.max_passes``, those in ``repairs`` counted), the run
    ended tangled, and simulated and wall time are left, the state is untangled and settled
    for at least ``config.settle_s``; a pass that removes nothing ends it. Appends each pass
    to ``repairs`` and returns the last RunResult, its step and time counts summed over the
    runs.
    """
    while len(repairs) < config.max_passes and result.metrics["intersecting_triangle_pairs"]:
        if not time_left(scene, result):
            break  # no time left to settle a repair
        repair = untangle_state(scene, "after the drape", config)
        repairs.append(repair)
        if repair["pairs_after"] >= repair["pairs_before"]:
            break
        collider = scene.solver.self_collider
        if config.narrow_seam_exclusion and collider is not None and scene.model.seam_count:
            # the seams are closed: keep the untangled panels beside them apart
            collider.set_seam_partners(scene.model.seam_pairs_np, neighbours=False)
            repair["narrowed_seam_exclusion"] = True
        result = run_on(scene, result, config.settle_s, progress=progress)
    return result


def settle_covered(scene, result, config: RepairConfig, body_through_m: float, *,
                   progress=None):  # fmt: skip
    """Thicken the contact where the body shows through a drape that ended at rest, and run
    it on to the stop rule again (:attr:`RepairConfig.cover_passes`).

    While passes are left, the deepest body vertex through the cloth
    (``body_through_cloth_max_m``) is deeper than ``body_through_m`` [m] and simulated and
    wall time are left, every closed body collider's contact is thickened where the body
    shows (:meth:`~sandbox.collision.body.BodyCollider.cover`) and the drape runs on for at
    least ``config.settle_s``. Returns the last RunResult (step and time counts summed over
    the runs) and one dict per pass: the body vertices that showed and the deepest [m].
    """
    passes: list[dict] = []
    while len(passes) < config.cover_passes:
        through = result.metrics.get("body_through_cloth_max_m")
        if through is None or through <= body_through_m:
            break
        colliders = [c for c in scene.model.colliders if getattr(c, "closed", False)]
        if not colliders or not time_left(scene, result):
            break  # no body to thicken, or no time left to settle
        x = np.asarray(result.positions, np.float64)
        shows = sum(c.cover(x, scene.model.tri_indices_np) for c in colliders)
        passes.append({"body_vertices": int(shows), "deepest_m": float(through)})
        if not shows:
            break
        result = run_on(scene, result, config.settle_s, progress=progress)
    return result, passes


def time_left(scene, result) -> bool:
    """Whether the drape's stop rule leaves simulated and wall time after ``result``."""
    stop = scene.spec.stop
    sim, wall = result.metrics["sim_time_s"], result.metrics["wall_time_s"]
    return sim < stop.time_limit_s - 1e-9 and wall < stop.wall_limit_s


def run_on(scene, result, settle_s: float, *, progress=None):
    """Run a drape on from where ``result`` ended to the stop rule again, for at least
    ``settle_s`` [s] and within the simulated and wall time its stop rule has left; returns
    the new RunResult with the step and time counts of both runs summed."""
    from sandbox.scene.run import run_scene

    stop = scene.spec.stop
    sim, wall = result.metrics["sim_time_s"], result.metrics["wall_time_s"]
    scene.spec = dataclasses.replace(scene.spec, stop=dataclasses.replace(
        stop, min_time_s=settle_s, time_limit_s=stop.time_limit_s - sim,
        wall_limit_s=stop.wall_limit_s - wall))  # fmt: skip
    try:
        again = run_scene(scene, progress=progress)
    finally:
        scene.spec = dataclasses.replace(scene.spec, stop=stop)
    for key in ("steps", "frames", "sim_time_s", "wall_time_s", "compile_time_s"):
        again.metrics[key] += result.metrics[key]
    return again
