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


def bending_calibration(uv: np.ndarray, tris: np.ndarray, hinges: np.ndarray) -> float:
    """Factor that makes this mesh's hinge energy reproduce a continuum rigidity B.

    The hinge sum Σ ½ B l²/(A0+A1) θ_b² matches ½ B κ² per area only up to a factor that
    depends on the mesh's shape statistics, its free edges and the bending direction, not
    on its resolution. What matters is the *relaxed* response: a mesh bent into a cylinder
    finds small zig-zag folds that lower the hinge energy (a regular grid with alternating
    diagonals keeps only 67 % of the energy of the imposed cylinder).

    We measure it on the piece itself, in its rest (u, v) coordinates: bend it into a
    cylinder of curvature κ = 1 along the directions 0°, 45°, 90° and 135° (a height
    field), hold the vertices within 1.5 edge lengths of the two ends, let every other
    vertex (free edges included) relax with one sparse solve (the small-angle θ_b is the
    jump of the facet slope across the edge, linear in the heights), and compare the
    energy with ½ B κ² A: the ratio r. Directions along which the piece is shorter than 8
    edge lengths, or that give no usable ratio, are left out. Curvature in any direction
    loads hinges of every direction, so the factor is one number for all hinges:
    1 / mean(r). Measured scatter: ±7 % between mesh sizes (docs/model.md).
    """
    ratios = []
    if len(hinges) == 0:
        return 1.0
    import scipy.sparse as sp
    import scipy.sparse.linalg as spl

    area = 0.5 * np.abs(_cross2(uv[tris[:, 1]] - uv[tris[:, 0]], uv[tris[:, 2]] - uv[tris[:, 0]]))
    weight, _ = hinge_rest_weights(uv, hinges)
    edge_len = float(np.median(np.linalg.norm(uv[hinges[:, 1]] - uv[hinges[:, 0]], axis=1)))
    jump = _slope_jump_matrix(uv, hinges)
    stiffness = (jump.T @ sp.diags(weight) @ jump).tocsr()
    for deg in (0, 45, 90, 135):
        d = np.array([math.cos(math.radians(deg)), math.sin(math.radians(deg))])
        s = (uv - uv.mean(axis=0)) @ d
        if s.max() - s.min() < 8.0 * edge_len:
            continue
        held = (s <= s.min() + 1.5 * edge_len) | (s >= s.max() - 1.5 * edge_len)
        free, fixed = np.nonzero(~held)[0], np.nonzero(held)[0]
        z = 0.5 * s**2
        try:
            z[free] = spl.spsolve(
                stiffness[free][:, free].tocsc(), -(stiffness[free][:, fixed] @ z[fixed])
            )
        except RuntimeError:
            continue
        r = float(0.5 * z @ (stiffness @ z)) / (0.5 * float(area.sum()))
        if math.isfinite(r) and 0.5 < r < 2.0:
            ratios.append(r)
    return 1.0 / float(np.mean(ratios)) if ratios else 1.0


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
