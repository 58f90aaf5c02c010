"""Coarse to fine for any scene: reach the rest shape on coarser meshes, settle on the fine one.

A run to the stop rule is a search for a rest shape. Most of its simulated time goes into
gross motion (a sheet falling and wrapping a body), which a coarse mesh resolves at a
fraction of the cost: a ninth of the vertices at three times the edge, and a three times
longer explicit step. Every mesh of a cloth is a triangulation of the same pattern piece,
so each fine vertex has pattern coordinates inside the coarse mesh of its piece, and the
coarse positions carry over by the barycentric coordinates of that point
(:func:`carry_positions`). On the finer mesh only local settling is left, which runs
overdamped with its inertia scaled (:mod:`sandbox.sim.inertia`) and the step measured on
the carried shape (:func:`settle_limit`).

A scene asks for it with a ``[multilevel]`` table (:class:`MultilevelSpec`,
docs/scene_format.md); ``python -m sandbox run --direct`` ignores the table. The garment
drape's coarse-to-fine method (:mod:`sandbox.garment.multilevel`) uses the same pieces.

spec -> ``build_scene`` at each coarse edge, coarsest first -> ``run_scene`` (the coarsest:
the scene's own damping) -> :func:`carry_positions` to the next level -> ``run_scene``
(overdamped, inertia scaled) -> ... -> the scene's own mesh.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time

import numpy as np

from sandbox.scene.build import Scene, retime
from sandbox.scene.multilevel_spec import MultilevelSpec, check_levels
from sandbox.sim.inertia import scaled_inertia
from sandbox.sim.stability import dominant_eigenvalue, limit_of

log = logging.getLogger(__name__)

SQUEEZED_BELOW = 0.5
"""A settling level whose measured stability limit is below this fraction of its rest
shape's bound has an element squeezed flat by the carry (see :func:`settle_limit`)."""


def barycentric_locate(points: np.ndarray, uv: np.ndarray, triangles: np.ndarray,
                       chunk: int = 2048) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The triangle of a 2D mesh each point lies in, and its barycentric coordinates.

    Args:
        points: (p, 2) query points [m].
        uv: (n, 2) the mesh's vertices [m]; ``triangles``: (m, 3) vertex indices.
    Returns ``(tri (p,) int, bary (p, 3))``. A point outside the mesh (a curved outline
    discretised differently by two meshes) gets the triangle it is least outside of, its
    coordinates clamped to >= 0 and renormalised: the nearest point of that triangle, near
    enough where the two outlines differ by a fraction of an edge.
    """
    points = np.asarray(points, np.float64)
    a, b, c = (uv[triangles[:, k]] for k in range(3))
    e1, e2 = b - a, c - a
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    det = np.where(np.abs(det) > 1e-300, det, 1e-300)
    tri = np.empty(len(points), np.int64)
    bary = np.empty((len(points), 3))
    for s in range(0, len(points), chunk):
        d = points[s : s + chunk, None, :] - a[None]  # (q, m, 2)
        l1 = (d[..., 0] * e2[:, 1] - d[..., 1] * e2[:, 0]) / det
        l2 = (e1[:, 0] * d[..., 1] - e1[:, 1] * d[..., 0]) / det
        lam = np.stack([1.0 - l1 - l2, l1, l2], axis=-1)  # (q, m, 3)
        best = np.argmax(lam.min(axis=-1), axis=1)
        tri[s : s + chunk] = best
        bary[s : s + chunk] = lam[np.arange(len(best)), best]
    bary = np.clip(bary, 0.0, None)
    bary /= bary.sum(axis=1, keepdims=True)
    return tri, bary


def carry_positions(coarse: Scene, fine: Scene) -> np.ndarray:
    """The coarse scene's positions carried to the fine scene's vertices, (n, 3) [m].

    The two scenes hold the same cloth pieces, in the same order, meshed at different
    edges; each fine vertex takes the barycentric combination of the coarse triangle its
    pattern coordinates (``Model.rest_uv_np``) lie in."""
    cm, fm = coarse.model, fine.model
    x = coarse.state.positions().astype(np.float64)
    out = np.empty((fm.particle_count, 3))
    for pc, pf in zip(cm.pieces, fm.pieces, strict=True):
        cs = slice(pc.particle_start, pc.particle_start + pc.particle_count)
        fs = slice(pf.particle_start, pf.particle_start + pf.particle_count)
        tris = cm.tri_indices_np[pc.tri_start : pc.tri_start + pc.tri_count] - pc.particle_start
        tri, bary = barycentric_locate(fm.rest_uv_np[fs], cm.rest_uv_np[cs], tris)
        out[fs] = np.einsum("pk,pkd->pd", bary, x[cs][tris[tri]])
    return out


def settle_limit(scene: Scene, bound_s: float) -> float:
    """A settling level's explicit stability limit [s], measured on its carried shape, or
    ``bound_s`` (its rest shape's bound) where the measure sees an element squeezed flat.

    The carry can squeeze a triangle flat against a body (a tank top under the arm: two
    vertices 0.13 mm apart that rest 7 mm apart). Its mode is a compression instability,
    which the body's contact holds (300 steps did not undo it): the power method's dominant
    eigenvalue is negative, 80 times the rest shape's largest in size, and a limit taken
    from it cut the whole settling to 15 µs steps (28,000 of them, 75 s wall, against
    7.5 s). A negative dominant eigenvalue limits no step, so then the bound is used; the
    guard stays the safety net."""
    lam = dominant_eigenvalue(scene.solver, scene.state, scene.control, scene.model)
    limit = limit_of(lam)
    if lam < 0.0 and limit < SQUEEZED_BELOW * bound_s:
        log.info("settling level: an element squeezed flat (eigenvalue %.3g /s^2); step "
                 "from the rest shape's bound", lam)  # fmt: skip
        return bound_s
    return limit


def run_multilevel(spec, build, *, progress: bool | None = None):
    """Run the scene ``spec`` (with a ``multilevel`` table) coarse to fine.

    ``build(spec) -> Scene`` builds one level (``build_scene`` with the caller's runtime and
    limits). Returns ``(scene, RunResult)`` of the scene's own mesh; its metrics hold each
    level's figures (``levels``), the method it ran (``method``) and the wall time over all
    levels, building included (``total_wall_time_s``). A coarsest level that ends short of
    its stop rule has no rest shape to carry: then the scene runs directly on its own mesh
    (``method`` says so), its total including the coarse level's time.
    """
    from sandbox.scene.run import run_scene

    ml = spec.multilevel
    check_levels(spec)
    t0 = time.perf_counter()
    levels, prev, method = [], None, "coarse_to_fine"
    for k, edge in enumerate([*ml.coarse_edge_length_m, None]):
        level = _level_spec(spec, edge, ml, first=k == 0)
        t_build = time.perf_counter()
        scene = build(level)
        if prev is None:
            result = run_scene(scene, progress=progress)
        else:
            x = carry_positions(prev, scene)
            scene.state.set(x, np.zeros_like(x))
            result = _settle(scene, ml, progress)
        levels.append(_level_row(result.metrics, edge, time.perf_counter() - t_build))
        if edge is not None and k == 0 and not result.converged:
            log.warning("%s: the coarsest level (%.3g m) ended without reaching its stop "
                        "rule (%s); running the scene directly",
                        spec.name, edge, result.reason)  # fmt: skip
            method = "direct (coarse level not at rest)"
            t_build = time.perf_counter()
            scene = build(dataclasses.replace(spec, multilevel=None))
            result = run_scene(scene, progress=progress)
            levels.append(_level_row(result.metrics, None, time.perf_counter() - t_build))
            break
        prev = scene
    result.metrics.update(method=method, levels=levels,
                          total_wall_time_s=time.perf_counter() - t0)  # fmt: skip
    return scene, result


def _level_row(m: dict, edge, wall_s: float) -> dict:
    """One level's figures for the ``levels`` metric."""
    keys = ("vertex_count", "steps", "dt_s", "sim_time_s", "stop_reason",
            "residual_mean_over_weight")  # fmt: skip
    return {"edge_length_m": edge, **{k: m.get(k) for k in keys}, "wall_time_s": wall_s}


def _level_spec(spec, edge, ml: MultilevelSpec, *, first: bool):
    """The scene of one level: every cloth meshed at ``edge`` (None: the scene's own), the
    coarsest with its own damping, every finer one overdamped. No level has a
    ``multilevel`` table of its own."""
    sim = spec.simulation
    if first:
        damping = sim.damping_per_s if ml.coarse_damping_per_s is None else ml.coarse_damping_per_s
    else:
        damping = ml.settle_damping_per_s
    cloths = spec.cloths if edge is None else [
        dataclasses.replace(c, edge_length_m=edge) for c in spec.cloths]  # fmt: skip
    simulation = dataclasses.replace(sim, damping_per_s=damping)
    return dataclasses.replace(spec, cloths=cloths, multilevel=None, simulation=simulation)


def _settle(scene: Scene, ml: MultilevelSpec, progress):
    """Run a finer level from its carried shape to the stop rule: inertia scaled by
    ``ml.settle_inertia_scale`` (explicit scenes), its step from the stability limit
    measured on the carried shape, trusted up to twice the rest shape's bound (the guard
    stays the safety net). The cap is on the limit, not the step, so that strain-rate
    damping, which shortens a short limit's step more, is applied to the limit used."""
    from sandbox.scene.run import run_scene

    explicit = scene.spec.simulation.integrator == "symplectic_euler"
    s = ml.settle_inertia_scale if explicit else 1.0
    with scaled_inertia(scene, s):
        if explicit:
            bound = scene.dt_limit_s * math.sqrt(s)
            limit = min(settle_limit(scene, bound), 2.0 * bound)
            retime(scene, limit, at_most=math.inf)
        result = run_scene(scene, progress=progress)
    if s != 1.0:  # the step of the cloth's own inertia, for whatever runs it next
        retime(scene, scene.dt_limit_s / math.sqrt(s), at_most=1.0)
    return result
