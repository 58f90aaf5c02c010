"""Bending hinges of a triangle mesh and the rest weights of their energy (Eq. 7).

A hinge is an interior edge with its two adjacent triangles. Its energy is
U_b = E_b/2 (θ_b − θ_0)^2 with E_b = c_mesh · B(φ) · l²/(A0+A1): l the rest edge length,
A0, A1 the rest areas of the two triangles, B(φ) the fabric's flexural rigidity [N·m] for
a hinge edge at angle φ from the warp, and c_mesh the calibration of
:func:`bending_calibration`. See docs/model.md for the derivation.
"""

from __future__ import annotations

import math

import numpy as np

from sandbox.errors import SandboxError


def find_hinges(tris: np.ndarray) -> np.ndarray:
    """Interior edges of a consistently oriented triangle mesh as hinges.

    Args: tris (m, 3) counter-clockwise triangles.
    Returns: (h, 4) int64 rows (x0, x1, x2, x3): edge x0–x1 as it runs in the first face
    (x0, x1, x2), and x3 opposite it in the second face (which runs x1 -> x0).
    Raises SandboxError for a non-manifold edge (more than two faces).
    """
    if len(tris) == 0:
        return np.zeros((0, 4), dtype=np.int64)
    edges = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
    opposite = np.concatenate([tris[:, 2], tris[:, 0], tris[:, 1]])
    lo, hi = np.minimum(edges[:, 0], edges[:, 1]), np.maximum(edges[:, 0], edges[:, 1])
    key = lo * (int(tris.max()) + 1) + hi
    order = np.argsort(key, kind="stable")
    ks = key[order]
    _, counts = np.unique(ks, return_counts=True)
    if np.any(counts > 2):
        raise SandboxError("mesh has a non-manifold edge shared by more than two triangles")
    same = np.nonzero(ks[1:] == ks[:-1])[0]
    a, b = order[same], order[same + 1]
    return np.stack([edges[a, 0], edges[a, 1], opposite[a], opposite[b]], axis=1)


def hinge_rest_weights(uv: np.ndarray, hinges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rest geometry of each hinge: ``l²/(A0+A1)`` [1] and the edge angle φ from u [rad]."""
    p0, p1, p2, p3 = (uv[hinges[:, i]] for i in range(4))
    e = p1 - p0
    a0 = 0.5 * np.abs(_cross2(e, p2 - p0))
    a1 = 0.5 * np.abs(_cross2(e, p3 - p0))
    l2 = np.sum(e * e, axis=1)
    return l2 / (a0 + a1), np.arctan2(e[:, 1], e[:, 0])


def bending_calibration(uv: np.ndarray, tris: np.ndarray, hinges: np.ndarray) -> dict:
    """Factors that make the hinge energy reproduce a continuum rigidity B on this mesh.

    The hinge sum Σ ½ B l²/(A0+A1) θ_b² matches ½ B κ² per area only up to a factor that
    depends on the mesh's shape statistics and on the bending direction, not on its
    resolution. What matters is the *relaxed* response: a mesh bent by its boundary finds
    zig-zag folds that lower the hinge energy (a regular grid with diagonals keeps only
    67 % of the imposed-cylinder energy). We measure it on the rest mesh itself: bend the
    flat mesh into a cylinder of curvature κ along direction ψ (a height field, small-angle
    θ_b = jump of the facet slope across the edge, linear in the heights), hold the
    boundary and let the interior relax (one sparse linear solve), and compare the energy
    with ½ B κ² A. Returns ``{"warp": c_0°, "weft": c_90°, "bias": c_45°/135°}``: the
    factors that multiply B_warp, B_weft and B_bias.
    """
    if len(hinges) == 0:
        return {"warp": 1.0, "weft": 1.0, "bias": 1.0}
    import scipy.sparse as sp
    import scipy.sparse.linalg as spl

    area = 0.5 * np.abs(_cross2(uv[tris[:, 1]] - uv[tris[:, 0]], uv[tris[:, 2]] - uv[tris[:, 0]]))
    weight, _ = hinge_rest_weights(uv, hinges)
    jump = _slope_jump_matrix(uv, hinges)
    stiffness = (jump.T @ sp.diags(weight) @ jump).tocsr()
    edge_len = float(np.sqrt(weight.mean() * area.mean() * 2.0)) if len(area) else 1.0
    centre = uv.mean(axis=0)
    ratio = {}
    for deg in (0, 45, 90, 135):
        d = np.array([math.cos(math.radians(deg)), math.sin(math.radians(deg))])
        s = (uv - centre) @ d
        # hold two bands at the ends along d; every other vertex (free edges too) relaxes
        held = (s <= s.min() + 1.5 * edge_len) | (s >= s.max() - 1.5 * edge_len)
        free = np.nonzero(~held)[0]
        fixed = np.nonzero(held)[0]
        z = 0.5 * s**2  # κ = 1 cylinder as a height field
        if len(free):
            k_ff = stiffness[free][:, free].tocsc()
            k_fb = stiffness[free][:, fixed]
            z[free] = spl.spsolve(k_ff, -(k_fb @ z[fixed]))
        r = float(0.5 * z @ (stiffness @ z)) / (0.5 * area.sum())
        ratio[deg] = r if math.isfinite(r) and r > 0 else 1.0
    return {
        "warp": 1.0 / ratio[0],
        "weft": 1.0 / ratio[90],
        "bias": 2.0 / (ratio[45] + ratio[135]),
    }


def _slope_jump_matrix(uv, hinges):
    """Sparse (h, n) map from vertex heights z to the small-angle θ_b of each hinge."""
    import scipy.sparse as sp

    p0, p1, p2, p3 = (uv[hinges[:, i]] for i in range(4))
    e = p1 - p0
    le = np.linalg.norm(e, axis=1)
    n = np.stack([e[:, 1], -e[:, 0]], axis=1) / le[:, None]
    t2 = np.sum((p2 - p0) * e, axis=1) / le**2
    t3 = np.sum((p3 - p0) * e, axis=1) / le**2
    d2 = np.sum((p2 - p0) * n, axis=1)
    d3 = np.sum((p3 - p0) * n, axis=1)
    # θ = (z2 − z0 − t2 (z1 − z0))/d2 − (z3 − z0 − t3 (z1 − z0))/d3
    coef = [-(1 - t2) / d2 + (1 - t3) / d3, -t2 / d2 + t3 / d3, 1 / d2, -1 / d3]
    rows = np.tile(np.arange(len(hinges)), 4)
    return sp.csr_matrix((np.concatenate(coef), (rows, hinges.T.ravel())),
                         shape=(len(hinges), len(uv)))  # fmt: skip


def _cross2(a, b):
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
