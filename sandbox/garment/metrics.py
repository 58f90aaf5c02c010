"""What a finished drape is measured by, and whether it is accepted.

metrics.json of a drape: the run's own metrics (:func:`~sandbox.scene.run.run_scene`: stop
rule, seam gap, contact), the garment and the body it was draped on, the ease at bust,
waist and hip (:func:`ease_cm`), whether it hangs where it should (:func:`hang_metrics`),
how much of it turned over (:func:`fold_metrics`), the folds around a free hem
(:func:`hem_nodes`) and the verdict (:func:`meets_acceptance`).
"""

from __future__ import annotations

import numpy as np

from sandbox.errors import SandboxError
from sandbox.garment.config import AcceptanceConfig, config_dict
from sandbox.garment.inputs import measurements_dict

EASE_LANDMARKS = {"bust": "bust_point_left", "waist": "waist_front", "hip": "hip_front"}
"""The landmark whose height each ease is measured at."""


def drape_metrics(scene, result, *, build_s: float = 0.0) -> dict:
    """metrics.json of a drape: the run's metrics, the garment, the body and the ease."""
    g = scene.garment
    model, mannequin = scene.model, g.mannequin
    m = dict(result.metrics)
    m.setdefault("seam_gap_max_m", None)
    m.update(
        garment=g.pattern.name,
        pattern_source=g.pattern.source,
        panels=[p.name for p in model.pieces],
        fabric=model.pieces[0].material.name,
        mannequin_size=mannequin.size,
        mannequin_measurements_cm=measurements_dict(mannequin),
        edge_length_m=g.edge_length_m,
        integrator=scene.spec.simulation.integrator,
        integrator_warning=g.integrator_warning,
        damping_per_s=float(scene.control.damping_per_s[None]),
        self_collision=scene.model.self_collider is not None,
        build_time_s=build_s,
        nan_positions=int(np.count_nonzero(~np.isfinite(result.positions))),
        drape_config=config_dict(g.config),
    )
    acceptance = g.config.acceptance
    m.update(ease_cm(result.positions, model.tri_indices_np, mannequin, g.placement_body))
    m.update(hang_metrics(model.initial_positions_np, result.positions, mannequin, acceptance))
    turns = turning_triangles(g.pattern, model)
    m.update(fold_metrics(model.initial_positions_np, result.positions, model.tri_indices_np,
                          g.placement_body, acceptance, turns))  # fmt: skip
    m["hem_nodes"] = hem_nodes(g, model, result.positions)
    m["acceptance_failures"] = acceptance_failures(m, acceptance)
    m["meets_acceptance"] = not m["acceptance_failures"]
    return m


def ease_cm(x: np.ndarray, triangles: np.ndarray, mannequin, body=None) -> dict:
    """Ease at bust, waist and hip: garment girth minus body girth [cm].

    At the height of each landmark (bust point, waist front, hip front), the garment's
    section (all its pieces cut by the horizontal plane) is reduced to the pieces around
    the torso (cut lines whose centre lies within 75 % of the torso's half-width: sleeves
    are left out) and measured like the tape measure measures the body: the perimeter of
    the convex hull. ``None`` where the garment does not reach that height or its cut does
    not go around the body axis.
    Returns ``{"ease_bust_cm", "ease_waist_cm", "ease_hip_cm", "garment_girth_*_cm",
    "body_girth_*_cm"}``.
    """
    from scipy.spatial import ConvexHull, QhullError

    from sandbox.mannequin.tape import girth_at, section_polylines
    from sandbox.pattern.placement.body import PlacementBody

    body = body or PlacementBody(mannequin)
    out = {}
    for key, lm in EASE_LANDMARKS.items():
        out[f"ease_{key}_cm"] = None
        out[f"garment_girth_{key}_cm"] = None
        out[f"body_girth_{key}_cm"] = None
        if lm not in body.landmarks:
            continue
        y = float(body.landmarks[lm][1])
        frame = body.frame("torso", y)
        axis = frame.origin[[0, 2]]
        try:
            body_girth = girth_at(body.vertices, body.triangles, y, axis_xz=axis)
        except SandboxError:
            continue
        out[f"body_girth_{key}_cm"] = 100.0 * body_girth
        sel = body.vertices[body.parts["torso"] & (np.abs(body.vertices[:, 1] - y) < 0.02)]
        half = float(np.abs(sel[:, 0] - axis[0]).max()) if len(sel) else 0.2
        cuts = section_polylines(x, triangles, (0.0, y, 0.0), (0.0, 1.0, 0.0))
        pts = [p[:, [0, 2]] for p, _ in cuts if abs(p[:, 0].mean() - axis[0]) <= 0.75 * half]
        if not pts:
            continue
        p2 = np.vstack(pts)
        try:
            hull = ConvexHull(p2)
        except QhullError:
            continue
        if np.any(hull.equations[:, :2] @ axis + hull.equations[:, 2] > 0):
            continue  # the cut does not go around the body
        girth = float(hull.area)
        out[f"garment_girth_{key}_cm"] = 100.0 * girth
        out[f"ease_{key}_cm"] = 100.0 * (girth - body_girth)
    return out


def hangs_from(x_start: np.ndarray, mannequin) -> str:
    """The landmark a garment placed at ``x_start`` (n, 3) [m] hangs from: the shoulders
    (``shoulder_point_left``) when its top is above half-way between the waist and the
    shoulder points, else the waist (``waist_front``)."""
    lm = mannequin.landmarks
    shoulder, waist = float(lm["shoulder_point_left"][1]), float(lm["waist_front"][1])
    start_top = float(np.max(np.asarray(x_start)[:, 1]))
    return "shoulder_point_left" if start_top > 0.5 * (shoulder + waist) else "waist_front"


def hang_metrics(x_start: np.ndarray, x_end: np.ndarray, mannequin,
                 acceptance: AcceptanceConfig | None = None) -> dict:  # fmt: skip
    """Which landmark the garment hangs from, whether it slid off and how far its hem rose.

    Returns ``hangs_from`` (:func:`hangs_from`), ``top_below_anchor_m`` (the landmark's
    height minus the final top's [m]; negative: the top is above it), ``slid_off`` (that
    distance is more than :attr:`AcceptanceConfig.slide_tolerance_m`) and ``hem_rise_m``
    (the final lowest point's height minus the placed one's [m]; a garment whose hem folds
    up rises, but so does one that started stretched downwards, so :func:`fold_metrics`
    decides).
    """
    tolerance = (acceptance or AcceptanceConfig()).slide_tolerance_m
    lm = mannequin.landmarks
    name = hangs_from(x_start, mannequin)
    below = float(lm[name][1]) - float(np.max(np.asarray(x_end)[:, 1]))  # NaN: slid_off
    rise = float(np.min(np.asarray(x_end)[:, 1])) - float(np.min(np.asarray(x_start)[:, 1]))
    return {"hangs_from": name, "top_below_anchor_m": below,
            "slid_off": bool(not below <= tolerance), "hem_rise_m": rise}  # fmt: skip


def fold_metrics(x_start: np.ndarray, x_end: np.ndarray, triangles: np.ndarray,
                 body=None, acceptance: AcceptanceConfig | None = None,
                 meant_to_turn: np.ndarray | None = None) -> dict:  # fmt: skip
    """How much of a garment ended turned over: ``folded_area_pct``, the area [%] (at the
    start) of the triangles turned over, ``rolled_up``, that share above
    :attr:`AcceptanceConfig.fold_tolerance_pct` (or NaN positions), and
    ``fluted_area_pct``, the area turned past 90° in folds that hang free (not counted).

    A garment hanging from the body keeps its outside out; a hem folded up into a roll, or
    a back panel caught in a fold, turns a band of cloth over. A triangle is turned over
    when its normal turned more than 90 degrees and, with ``body`` (a
    :class:`~sandbox.pattern.placement.body.PlacementBody`), the side of it that faced away from the
    body at the start also faces it at the end (its normal against the nearest body
    normal). A strap that bends over the shoulder as it should turns its normal but still
    faces out, so it is not counted; nor is a flare that a hanging hand presses in towards
    the thigh, which faces the hand (the nearest body part) but has not turned.

    Further than :attr:`AcceptanceConfig.fold_free_m` from the body the cloth hangs free,
    and "facing the body" no longer tells a roll from a fold: a flare falls into flutes
    whose walls turn 90-135° about the vertical (measured on GarmentCode's flared skirt
    and three-tier dress at 1.5 cm: 1.85 % and 7.5 % of their area turned 90-120°, 4-19
    cm from the legs). There a triangle is turned over only upside down
    (:func:`upside_down`), as a hem rolled up on itself is. ``meant_to_turn`` (a bool per
    triangle): cloth designed to end turned over (a lapel, see :func:`turning_triangles`),
    not counted.
    """
    a = acceptance or AcceptanceConfig()
    t = np.asarray(triangles, np.int64)

    def normals(x):
        x = np.asarray(x, float)
        return np.cross(x[t[:, 1]] - x[t[:, 0]], x[t[:, 2]] - x[t[:, 0]])

    def outward(x, n):
        c = np.asarray(x, float)[t].mean(axis=1)
        return np.sum(n * body.surface_normals(c), axis=1) > 0

    n0, n1 = normals(x_start), normals(x_end)
    area = np.linalg.norm(n0, axis=1)
    finite = bool(np.all(np.isfinite(x_end)))
    turned = np.sum(n0 * n1, axis=1) < 0
    fluted = np.zeros(len(t), bool)
    if body is not None and finite:
        turned &= outward(x_start, n0) != outward(x_end, n1)
        free = body.distance(np.asarray(x_end, float)[t].mean(axis=1)) > a.fold_free_m
        fluted = turned & free & ~upside_down(x_start, x_end, t)
        turned &= ~fluted
    if meant_to_turn is not None:
        turned &= ~np.asarray(meant_to_turn, bool)
        fluted &= ~np.asarray(meant_to_turn, bool)
    total = max(area.sum(), 1e-300)
    pct = float(100.0 * area[turned].sum() / total)
    return {"folded_area_pct": pct if finite else float("nan"),
            "fluted_area_pct": float(100.0 * area[fluted].sum() / total),
            "rolled_up": bool(not finite or pct > a.fold_tolerance_pct)}  # fmt: skip


def upside_down(x_start: np.ndarray, x_end: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """A bool per triangle: its cloth hangs upside down, i.e. the direction in it that
    pointed down as placed (world −y, projected into the triangle's plane) points up at
    the end, carried along by the triangle's deformation (x_end's edges times the
    pseudo-inverse of x_start's). A fold about a horizontal line (a hem rolled up on
    itself) turns it up; a fold about the vertical (a flute) leaves it pointing down.
    Positions (n, 3) [m], Y up; triangles (k, 3)."""
    t = np.asarray(triangles, np.int64)
    x0, x1 = np.asarray(x_start, float), np.asarray(x_end, float)
    e0 = np.stack([x0[t[:, 1]] - x0[t[:, 0]], x0[t[:, 2]] - x0[t[:, 0]]], axis=2)  # (k, 3, 2)
    e1 = np.stack([x1[t[:, 1]] - x1[t[:, 0]], x1[t[:, 2]] - x1[t[:, 0]]], axis=2)
    n = np.cross(e0[:, :, 0], e0[:, :, 1])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    down = np.array([0.0, -1.0, 0.0])
    d0 = down - (n @ down)[:, None] * n  # down, in the placed triangle's plane
    coef = np.einsum("kij,kj->ki", np.linalg.pinv(e0), d0)  # in the triangle's edges
    d1 = np.einsum("kij,kj->ki", e1, coef)
    return d1 @ down < 0.0


def turning_triangles(pattern, model) -> np.ndarray | None:
    """A bool per triangle: True on the panels whose ``meta.turns_over`` says they are cut to
    end turned over against their neighbours (a lapel; GarmentCode's import sets it for a
    panel all of whose stitches join its right side to their wrong side); None when no
    panel is."""
    names = {n for n, p in pattern.panels.items() if p.meta.get("turns_over")}
    if not names:
        return None
    mask = np.zeros(len(model.tri_indices_np), bool)
    for piece in model.pieces:
        if piece.name in names:
            mask[piece.tri_start : piece.tri_start + piece.tri_count] = True
    return mask


def hem_ring(pattern, meshes: dict, piece_start: dict) -> np.ndarray | None:
    """Particle indices of a garment's free hem around the torso, or None without one.

    The hem is every edge called ``hem`` of a panel placed on the torso (sleeve hems are
    left out) that no seam sews. ``meshes``: panel name -> PanelMesh; ``piece_start``:
    panel name -> index of its first particle.
    """
    sewn = {(name, k) for s in pattern.seams for name, k in (*s.side_a, *s.side_b)}
    out = []
    for name, panel in pattern.panels.items():
        if (panel.placement or {}).get("body", "torso") != "torso" or name not in meshes:
            continue
        for k, e in enumerate(panel.edges):
            if e.name == "hem" and (name, k) not in sewn:
                out.append(piece_start[name] + meshes[name].edge_vertices[k])
    return np.unique(np.concatenate(out)) if out else None


def hem_nodes(garment, model, x_end: np.ndarray, max_gap_deg: float = 45.0) -> int | None:
    """Nodes (folds) around a garment's free hem, counted as the Cusick test counts them.

    The hem (:func:`hem_ring`) is seen from the body's axis (the torso's, at the hip):
    each hem vertex's angle about it where it started (the model's initial positions:
    placed, or carried from a coarse level; single-valued where a fold turns over) against
    its final radial distance [m], and
    :func:`~sandbox.validate.cusick_measure.count_nodes` counts the maxima of that profile
    (3° Gaussian, prominence ≥ 5 mm). None when the garment has no hem on the torso or its
    hem does not go around the body (an angular gap over ``max_gap_deg``).
    """
    from sandbox.validate.cusick_measure import count_nodes

    start = {name: model.pieces[i].particle_start for name, i in garment.piece_index.items()}
    ring = hem_ring(garment.pattern, garment.meshes, start)
    x_end = np.asarray(x_end, float)
    if ring is None or len(ring) < 8 or not np.all(np.isfinite(x_end[ring])):
        return None
    body = garment.placement_body
    lm = body.landmarks.get("hip_front", body.landmarks.get("waist_front"))
    axis = body.frame("torso", None if lm is None else float(lm[1])).origin[[0, 2]]
    d0 = np.asarray(model.initial_positions_np, float)[ring][:, [0, 2]] - axis
    theta = np.mod(np.arctan2(d0[:, 0], d0[:, 1]), 2.0 * np.pi)  # from the front (+Z)
    gaps = np.diff(np.sort(theta), append=np.sort(theta)[0] + 2.0 * np.pi)
    if gaps.max() > np.radians(max_gap_deg):
        return None
    r = np.linalg.norm(x_end[ring][:, [0, 2]] - axis, axis=1)
    return count_nodes(theta, r)


def meets_acceptance(m: dict, acceptance: AcceptanceConfig | None = None) -> bool:
    """The acceptance for one drape's metrics: converged by the stop rule, largest seam gap
    and deepest vertex inside the body within :class:`AcceptanceConfig`'s limits, the body
    showing through the cloth by no more than its limit, no intersecting cloth triangle
    pairs, not slid off (:func:`hang_metrics`), not rolled up (:func:`fold_metrics`), no
    NaN."""
    return not acceptance_failures(m, acceptance)


def acceptance_failures(m: dict, acceptance: AcceptanceConfig | None = None) -> list[str]:
    """The checks of :func:`meets_acceptance` that one drape's metrics miss, in words (e.g.
    ``"seam gap 6.2 mm"``); empty when it meets the acceptance."""
    a = acceptance or AcceptanceConfig()
    gap = m.get("seam_gap_max_m")
    depth = m.get("penetration_max_m")
    through = m.get("body_through_cloth_max_m")
    pairs = m.get("intersecting_triangle_pairs")
    failed = []
    if not m.get("converged"):
        failed.append("not at rest")
    if gap is not None and gap > a.seam_gap_m:
        failed.append(f"seam gap {gap * 1e3:.1f} mm")
    if depth is None or depth > a.penetration_m:
        failed.append("inside the body" + ("" if depth is None else f" {depth * 1e3:.1f} mm"))
    if through is not None and through > a.body_through_m:
        failed.append(f"body through {through * 1e3:.1f} mm")
    if pairs != 0:
        failed.append(f"{pairs} crossing pairs")
    if m.get("slid_off", False):
        failed.append("slid off")
    if m.get("rolled_up", False):
        failed.append("rolled up")
    if m.get("nan_positions", 0) != 0:
        failed.append("NaN positions")
    return failed
