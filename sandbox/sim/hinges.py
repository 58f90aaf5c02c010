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


def seam_hinges(line_a, line_b, tris: np.ndarray, rest: np.ndarray):
    """Hinges across one seam, so that a sewn seam bends like the cloth on either side.

    A seam joins two boundary edges of the meshes; once it is closed, the triangle on each
    side of it form a hinge like any interior edge (Eq. 7), flat at rest. For each segment
    of line A (two consecutive particles on a boundary edge of their mesh) the segment of
    line B at the same arc-length parameter (Fig. 5(b)'s matching) gives the other
    triangle: the hinge is A's edge (x0, x1), x2 opposite it in A's triangle and x3
    opposite B's edge in B's triangle. Only a seam that joins the two sides the way one
    uncut sheet would (B's triangle runs the edge the other way round) gets hinges; a
    seam that folds one side back over the other gets none.

    Args:
        line_a, line_b: :class:`~sandbox.sim.seams.SeamLine` s, B already running the
            same way as A (as :func:`~sandbox.sim.seams.sew` orients it); global particles.
        tris: (m, 3) global counter-clockwise triangles; rest: (n, 2) rest material
            coordinates [m] of every particle.
    Returns:
        (h, 4) int64 hinges (x0, x1, x2, x3) and their (h,) rest weights l²/(A0+A1) [1],
        with the (h, 2) edge angles from the warp [rad] of the A and the B edge.
    """
    opposite = {}
    for t in np.asarray(tris, np.int64):
        for k in range(3):
            opposite[(int(t[k]), int(t[(k + 1) % 3]))] = int(t[(k + 2) % 3])
    pa, pb = line_a.particles, line_b.particles
    ta, tb = line_a.params, line_b.params
    rows, weights, phis = [], [], []
    for i in range(len(pa) - 1):
        p, q = int(pa[i]), int(pa[i + 1])
        if ((p, q) in opposite) == ((q, p) in opposite):  # not on the mesh, or interior
            continue
        j = int(np.clip(np.searchsorted(tb, 0.5 * (ta[i] + ta[i + 1])), 1, len(pb) - 1))
        u, w = int(pb[j - 1]), int(pb[j])  # B's segment; u lies at p's end, w at q's
        if ((u, w) in opposite) == ((w, u) in opposite):
            continue
        x0, x1, mu, mw = (p, q, u, w) if (p, q) in opposite else (q, p, w, u)
        if (mw, mu) not in opposite:  # B runs the edge the same way: a fold, not a join
            continue
        x2, x3 = opposite[(x0, x1)], opposite[(mw, mu)]
        if len({x0, x1, x2, x3}) < 4:
            continue
        e_a, e_b = rest[x1] - rest[x0], rest[mu] - rest[mw]
        a0 = 0.5 * abs(_cross2(e_a[None], (rest[x2] - rest[x0])[None])[0])
        a1 = 0.5 * abs(_cross2(e_b[None], (rest[x3] - rest[mw])[None])[0])
        rows.append((x0, x1, x2, x3))
        weights.append(float(e_a @ e_a) / (a0 + a1))
        phis.append((math.atan2(e_a[1], e_a[0]), math.atan2(e_b[1], e_b[0])))
    if not rows:
        return np.zeros((0, 4), np.int64), np.zeros(0), np.zeros((0, 2))
    return np.asarray(rows, np.int64), np.asarray(weights), np.asarray(phis)
