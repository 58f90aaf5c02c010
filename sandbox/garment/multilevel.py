"""Coarse to fine: drape on a coarse mesh, carry its rest shape to the fine mesh, settle there.

A drape is a search for a rest shape. Most of its simulated time goes into gross motion
(seams closing, panels wrapping, the garment dropping onto the shoulders or hips), which a
coarse mesh resolves at a fraction of the cost: fewer vertices and a longer stable step
(the explicit step grows with the edge length). Every mesh of a panel is a triangulation of
the same pattern piece, so a point of the fine mesh has pattern coordinates inside the
coarse mesh of its panel, and the coarse drape's positions carry over by the barycentric
coordinates of that point (:func:`transfer_positions`). On the fine mesh only local
settling is left: the same solver, the same stop rule, from a state that is almost at rest.

pattern + mannequin -> ``build_drape`` at ``config.coarse_edge_m`` -> ``run_drape`` (sew,
drape) -> ``build_drape`` at the requested edge -> :func:`transfer_positions` ->
``untangle_state`` -> ``run_scene`` -> ``settle_repaired``.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time

import numpy as np

from sandbox.garment.build import build_drape
from sandbox.scene.build import retime
from sandbox.scene.multilevel import barycentric_locate, settle_limit
from sandbox.sim.inertia import scaled_inertia

log = logging.getLogger(__name__)


def panel_maps(coarse_meshes: dict, fine_meshes: dict) -> dict:
    """Where each fine vertex lies in its panel's coarse mesh: panel name -> ``(tri (p,),
    bary (p, 3))`` (:func:`barycentric_locate` on the pattern coordinates)."""
    return {name: barycentric_locate(fine.points, coarse_meshes[name].points,
                                     coarse_meshes[name].triangles)
            for name, fine in fine_meshes.items()}  # fmt: skip


def carry(maps: dict, coarse_meshes: dict, coarse_x: dict) -> dict:
    """Coarse panel positions (panel name -> (n_c, 3) [m]) carried to the fine meshes by
    :func:`panel_maps`: panel name -> (n_f, 3) [m]."""
    out = {}
    for name, (tri, bary) in maps.items():
        corners = np.asarray(coarse_x[name], np.float64)[coarse_meshes[name].triangles[tri]]
        out[name] = np.einsum("pk,pkd->pd", bary, corners)
    return out


def panel_positions(scene, x: np.ndarray) -> dict:
    """Positions (n, 3) of a scene's particles split by panel: name -> (n_panel, 3)."""
    return {p.name: x[p.particle_start : p.particle_start + p.particle_count]
            for p in scene.model.pieces}  # fmt: skip


def transfer_positions(coarse, fine) -> np.ndarray:
    """The coarse scene's current positions carried to the fine scene's vertices, (n, 3) [m].

    Both scenes are drapes of the same pattern (:func:`build_drape`); each fine vertex takes
    the barycentric combination of the coarse triangle its pattern coordinates lie in, in
    the same panel.
    """
    maps = panel_maps(coarse.garment.meshes, fine.garment.meshes)
    moved = carry(maps, coarse.garment.meshes, panel_positions(coarse, coarse.state.positions()))
    return np.vstack([moved[p.name] for p in fine.model.pieces])


def drape_coarse_to_fine(pattern, mannequin, *, fabric=None, edge_length_m: float | None,
                         config, progress: bool | None = None):  # fmt: skip
    """Sew and drape on a ``config.coarse_edge_m`` mesh, then settle on the ``edge_length_m``
    mesh from the carried-over shape (module docstring).

    Returns ``(fine scene, RunResult, build_s)``: the fine run's result, whose metrics also
    hold the coarse stage (``coarse_*`` keys: its vertices, simulated and wall time, build
    time, steps) and the totals over both stages (``total_wall_time_s``, ``sim_time_s``).
    The sewing keys are the coarse stage's.

    A coarse level that ends without reaching its stop rule has no rest shape to carry over
    (measured: the silk circle skirt slides slowly down the hips at 3 cm and goes on sliding
    at 1 cm, 10 cm below the direct drape). Then the fine level is not built and the return
    is ``(None, coarse RunResult, coarse wall time [s])``: the caller drapes directly.
    """
    from sandbox.garment.pipeline import run_drape

    t0 = time.perf_counter()
    coarse_config = dataclasses.replace(
        config,
        self_collision=config.coarse_self_collision,
        damping_per_s=config.damping_per_s
        if config.coarse_damping_per_s is None
        else config.coarse_damping_per_s,
        sewing=dataclasses.replace(config.sewing, self_collision=config.coarse_self_collision),
    )
    fine_edge = pattern.mesh_edge_m if edge_length_m is None else float(edge_length_m)
    coarse = build_drape(pattern, mannequin, fabric=fabric, edge_length_m=config.coarse_edge_m,
                         config=coarse_config, contact_edge_m=fine_edge)  # fmt: skip
    coarse_build_s = time.perf_counter() - t0
    coarse_result = run_drape(coarse, progress=progress, cover=False)
    cm = coarse_result.metrics
    redrape = None
    if _layers_crossed(cm, coarse, coarse_config):
        # layered cloth passed through itself: drape the coarse level again with contact
        redrape = {"crossing_pairs": cm["intersecting_triangle_pairs"],
                   "wall_time_s": time.perf_counter() - t0}  # fmt: skip
        log.info("coarse level: %d crossing triangle pairs at rest (of %d triangles): "
                 "draped again with cloth-cloth contact", redrape["crossing_pairs"],
                 len(coarse.model.tri_indices_np))  # fmt: skip
        coarse_config = dataclasses.replace(
            coarse_config, self_collision=True,
            sewing=dataclasses.replace(coarse_config.sewing, self_collision=True))  # fmt: skip
        t0 = time.perf_counter()
        coarse = build_drape(pattern, mannequin, fabric=fabric, edge_length_m=config.coarse_edge_m,
                             config=coarse_config, contact_edge_m=fine_edge)  # fmt: skip
        coarse_build_s = time.perf_counter() - t0 + redrape["wall_time_s"]
        coarse_result = run_drape(coarse, progress=progress, cover=False)
        cm = coarse_result.metrics
    if not cm["converged"]:
        return None, coarse_result, coarse_build_s + cm["total_wall_time_s"]

    t1 = time.perf_counter()
    maps = {}

    def place(meshes):  # the coarse placement, carried: same seam directions, same folds
        maps.update(panel_maps(coarse.garment.meshes, meshes))
        return carry(maps, coarse.garment.meshes, coarse.garment.placed)

    fine_config = dataclasses.replace(config, damping_per_s=config.fine_damping_per_s)
    fine = build_drape(pattern, mannequin, fabric=fabric, edge_length_m=edge_length_m,
                       config=fine_config, place=place, like=coarse)  # fmt: skip
    fine.garment.config = config
    moved = carry(maps, coarse.garment.meshes, panel_positions(coarse, coarse.state.positions()))
    x = np.vstack([moved[p.name] for p in fine.model.pieces])
    # a coarse triangle over a convex part of the body is a chord: the fine vertices on it
    # can lie inside the body, which contact only keeps cloth from entering
    x, pushed = fine.garment.placement_body.push_out(x, config.thickness_m)
    fine.state.set(x, np.zeros_like(x))
    dt_bound = fine.dt_s
    explicit = fine.spec.simulation.integrator == "symplectic_euler"
    inertia = config.fine_inertia_scale if explicit else 1.0
    with scaled_inertia(fine, inertia):
        if config.fine_measured_dt and explicit:
            # the fine level starts next to rest, where the bound is ~1.4x too cautious
            retime(fine, settle_limit(fine, fine.dt_limit_s * math.sqrt(inertia)),
                   at_most=2.0 * math.sqrt(inertia))  # fmt: skip
        elif inertia != 1.0:
            retime(fine, fine.dt_limit_s * math.sqrt(inertia), at_most=math.sqrt(inertia))
        build_s = time.perf_counter() - t1
        result, repairs = _settle_fine(fine, config, progress)
    if inertia != 1.0:  # the step of the garment's own inertia, for whatever runs it next
        retime(fine, fine.dt_limit_s / math.sqrt(inertia), at_most=1.0)
    m = result.metrics
    coarse_wall = coarse_build_s + cm["total_wall_time_s"]
    m.update({k: cm[k] for k in cm if k.startswith("sew_")})
    m.update(
        method="coarse_to_fine",
        coarse_edge_length_m=config.coarse_edge_m,
        coarse_vertex_count=cm["vertex_count"],
        coarse_steps=cm["steps"],
        coarse_dt_s=cm["dt_s"],
        coarse_sim_time_s=cm["sim_time_s"] + cm.get("sew_sim_time_s", 0.0),
        coarse_converged=cm["converged"],
        coarse_wall_time_s=coarse_wall,
        coarse_untangle=cm["untangle"],
        coarse_redrape=redrape,
        carried_pushed_out=int(pushed),
        fine_sim_time_s=m["sim_time_s"],
        fine_wall_time_s=m["wall_time_s"],
        fine_steps=m["steps"],
        fine_dt_bound_s=dt_bound,
        fine_inertia_scale=inertia,
        untangle=repairs,
        untangled_pairs=sum(r["pairs_before"] - r["pairs_after"] for r in repairs),
        strain_damping_s=float(fine.model.strain_damping_s[None]),
        total_wall_time_s=coarse_wall + build_s + m["wall_time_s"],
    )
    return fine, result, coarse_build_s + build_s


def _layers_crossed(metrics: dict, scene, config) -> bool:
    """Whether a coarse level run without cloth-cloth contact came to rest with more of its
    triangles crossed than ``config.coarse_tangled_fraction`` (layers passed through)."""
    if config.self_collision or not metrics["converged"]:
        return False
    pairs = metrics.get("intersecting_triangle_pairs") or 0
    return pairs > config.coarse_tangled_fraction * len(scene.model.tri_indices_np)


def _settle_fine(fine, config, progress):
    """The fine level from the carried shape: untangled, run to the stop rule (with the
    residual's and from ``fine_min_time_s``), repaired. Returns ``(RunResult, repairs)``."""
    from sandbox.garment.repair import settle_repaired, untangle_state
    from sandbox.scene.run import run_scene

    repairs = [untangle_state(fine, "after the coarse drape", config.repair)]
    collider = fine.solver.self_collider
    if collider is not None and fine.model.seam_count:
        # the seams arrive closed: the panels beside them are kept apart at once
        collider.set_seam_partners(fine.model.seam_pairs_np, neighbours=False)
    stop = fine.spec.stop
    fine.spec = dataclasses.replace(
        fine.spec,
        stop=dataclasses.replace(
            stop, min_time_s=config.fine_min_time_s, residual_mean=config.fine_residual_mean
        ),
    )
    try:
        result = run_scene(fine, progress=progress)
        result = settle_repaired(fine, result, repairs, config.repair, progress=progress)
    finally:
        fine.spec = dataclasses.replace(fine.spec, stop=stop)
    return result, repairs
