"""Placed panels made fit to start: relaxed strains, sleeves lifted over the bodice,
crossings untangled; and the measures of a start (stretches, crossing pairs)."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from sandbox.collision.metrics import count_intersecting_pairs
from sandbox.collision.untangle import edge_length_pass, edge_lengths_setup, untangle_positions
from sandbox.pattern.placement.config import DEFAULT_PLACEMENT, PlacementConfig
from sandbox.pattern.placement.wrap import dilate


def untangle(placed: dict, meshes: dict, body, clearance_m: dict,
             config: PlacementConfig = DEFAULT_PLACEMENT) -> dict:  # fmt: skip
    """Placed panels with their start crossings smoothed away (the fewest crossings found).

    Pushing a fine mesh out of a crease (the armpit, where a sleeve cap meets the bodice)
    moves neighbouring vertices to different surfaces, and the panel folds through itself:
    a 1 cm T-shirt started with 74 crossing triangle pairs, and contact handling keeps a
    start crossing for good. :func:`sandbox.collision.untangle.untangle_positions` smooths
    the crossing triangles and a few rings of neighbours and pushes them
    out to their panel's clearance again (``config.untangle_rounds`` rounds at most, each over
    ``config.untangle_rings`` rings of neighbours).

    Args:
        placed: panel name -> (n, 3) positions [m]. meshes: panel name -> mesh (its
            ``triangles``). body: :class:`PlacementBody`. clearance_m: panel name -> [m].
        config: the untangling rounds and rings.
    """
    names = list(placed)
    offsets = np.cumsum([0] + [len(placed[n]) for n in names])
    x = np.vstack([placed[n] for n in names]).astype(float)
    tri = np.vstack([np.asarray(meshes[n].triangles) + offsets[k] for k, n in enumerate(names)])
    uv = np.vstack([np.asarray(meshes[name].points, float) for name in names])

    def push_out(y, mask):
        y = y.copy()
        for p, name in enumerate(names):
            sl = slice(offsets[p], offsets[p + 1])
            if mask[sl].any():
                y[sl], _ = body.push_out(y[sl], clearance_m[name])
        return y

    best, _, _, _ = untangle_positions(
        x, tri, uv, push_out, rounds=config.untangle_rounds,
        rings=config.untangle_rings)  # fmt: skip
    return {name: best[offsets[k] : offsets[k + 1]] for k, name in enumerate(names)}


def panel_clearance_m(panel, config: PlacementConfig = DEFAULT_PLACEMENT) -> float:
    """A wrapped panel's clearance from the body [m] (its placement's, else the default)."""
    u = panel.units_to_m
    return float(panel.placement.get("clearance", config.clearance_m / u)) * u


def start_stretches(meshes: dict, placed: dict) -> np.ndarray:
    """Principal stretches (triangles, 2) of every placed triangle against its pattern
    shape (largest first); ``meshes`` and ``placed`` as :func:`place_pattern`'s."""
    out = []
    for name, mesh in meshes.items():
        t, uv, x = mesh.triangles, mesh.points, placed[name]
        rest = np.stack([uv[t[:, 1]] - uv[t[:, 0]], uv[t[:, 2]] - uv[t[:, 0]]], 2)
        world = np.stack([x[t[:, 1]] - x[t[:, 0]], x[t[:, 2]] - x[t[:, 0]]], 2)
        out.append(np.linalg.svd(world @ np.linalg.inv(rest), compute_uv=False))
    return np.vstack(out)


def crossings(placed: dict, meshes: dict) -> int:
    """Intersecting triangle pairs of all panels together (exact test)."""
    names = list(placed)
    offsets = np.cumsum([0] + [len(placed[n]) for n in names])
    x = np.vstack([placed[n] for n in names])
    tri = np.vstack([meshes[n].triangles + offsets[k] for k, n in enumerate(names)])
    return count_intersecting_pairs(x, tri)


def relax_panel(x: np.ndarray, triangles: np.ndarray, rest_xy: np.ndarray,
                config: PlacementConfig = DEFAULT_PLACEMENT) -> np.ndarray:  # fmt: skip
    """Placed positions (n, 3) [m] moved so the mesh edges get back their pattern lengths.

    Wrapping rows of a panel around body sections of changing shape stretches it where the
    sections change fast (the pencil skirt's back at the hip: 35 % along its length, the
    T-shirt's sleeve at the armpit: 120 %). Started that way, the seam edges and those
    regions leap at tens of m/s in the first steps. Each Jacobi pass moves both ends of
    every edge half-way to its rest length (position-based, averaged per vertex) and pulls
    it ``config.relax_hold`` of the way back to its placed position
    (``config.relax_iterations`` passes); the push-out after it restores the body
    clearance.
    """
    x0 = np.asarray(x, float)
    x = x0.copy()
    i, j, rest, count = edge_lengths_setup(triangles, rest_xy, len(x))
    for _ in range(config.relax_iterations):
        x += edge_length_pass(x, i, j, rest, count)
        x += config.relax_hold * (x0 - x)
    return x


def lift_over_torso(body, frame, out, torso_panels, limb_panels, pattern) -> None:
    """Move limb-panel vertices above the underarm that lie inside (or within
    ``body.config.overlap_margin_m`` of) the torso panels radially outwards, about the torso
    axis, to that margin (``out``: panel name -> (n, 3) [m], changed in place)."""
    if not limb_panels or not torso_panels:
        return
    cfg = body.config

    def cyl(x):
        p = x - frame.origin
        u, w = p @ frame.e1, p @ frame.e2
        return p @ frame.a, np.arctan2(w, u), np.hypot(u, w)

    h_t, th_t, r_t = cyl(np.vstack([out[n] for n in torso_panels]))
    scale = float(np.median(r_t))
    tree = cKDTree(np.stack([h_t, th_t * scale], 1))
    for name in limb_panels:
        part = pattern.panels[name].placement.get("body", "torso")
        side = part.rpartition("_")[2]
        key = f"underarm_point_{side}"
        if part.startswith("leg") or key not in body.landmarks:
            continue
        x = out[name]
        h, th, r = cyl(x)
        above = h >= frame.height(body.landmarks[key]) - 0.01
        if not above.any():
            continue
        idx = np.nonzero(above)[0]
        best = np.full(len(idx), -np.inf)
        for shift in (-2 * np.pi, 0.0, 2 * np.pi):  # angles wrap around
            d, j = tree.query(np.stack([h[idx], (th[idx] + shift) * scale], 1),
                              distance_upper_bound=0.03)  # fmt: skip
            ok = np.isfinite(d)
            best[ok] = np.maximum(best[ok], r_t[j[ok]])
        need = np.where(np.isfinite(best), best + cfg.overlap_margin_m - r[idx], 0.0)
        if not (need > 0).any():
            continue
        # one sideways shift per height row (rows move rigidly: no fold), growing upwards
        lo = frame.height(body.landmarks[key]) - 0.03
        rows = np.floor((h - lo) / cfg.row_m).astype(int)
        lift = np.zeros(rows.max() + 2)
        np.maximum.at(lift, rows[idx], np.maximum(need, 0.0))
        lift = np.maximum.accumulate(dilate(lift, 2))
        hole = f"armhole_{side}"
        centre = body.point(hole) if hole in body.feature_lines else x.mean(axis=0)
        d = centre - frame.origin
        d = d - (d @ frame.a) * frame.a
        d = d / max(np.linalg.norm(d), 1e-9)
        ramp = np.clip((h - lo) / 0.03, 0.0, 1.0)
        shift = lift[np.clip(rows, 0, len(lift) - 1)] * ramp * (h >= lo)
        x = x + shift[:, None] * d[None, :] * 1.2
        x, _ = body.push_out(x, panel_clearance_m(pattern.panels[name], cfg))
        out[name] = x
