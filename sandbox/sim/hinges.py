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
    """Factor that makes the hinge energy reproduce a continuum rigidity B on this mesh.

    A flat mesh bent into a cylinder of small curvature κ has continuum energy ½ B κ² A.
    The hinge sum Σ ½ B l²/(A0+A1) θ_b² gives that only up to a factor that depends on the
    mesh's shape statistics (≈ 1.14 for our quality Delaunay meshes, ≈ 0.98 for a grid bent
    along its axes), not on its resolution. We measure the factor on the rest mesh itself,
    averaged over the bending directions 0°, 45°, 90° and 135°, and divide it out. θ_b of
    the cylinder is computed in the small-curvature limit: for a height field z(u, v) the
    dihedral angle of a hinge is the jump of the facet slope across the edge.
    """
    if len(hinges) == 0:
        return 1.0
    area = 0.5 * np.abs(_cross2(uv[tris[:, 1]] - uv[tris[:, 0]], uv[tris[:, 2]] - uv[tris[:, 0]]))
    weight, _ = hinge_rest_weights(uv, hinges)
    centre = uv.mean(axis=0)
    ratios = []
    for ang in (0.0, 0.25 * math.pi, 0.5 * math.pi, 0.75 * math.pi):
        d = np.array([math.cos(ang), math.sin(ang)])
        z = 0.5 * ((uv - centre) @ d) ** 2  # κ = 1 cylinder as a height field
        theta = _slope_jump(uv, z, hinges)
        hinge_energy = np.sum(0.5 * weight * theta**2)
        ratios.append(hinge_energy / (0.5 * area.sum()))
    return 1.0 / float(np.mean(ratios))


def _slope_jump(uv, z, hinges):
    """Jump of the linear-interpolant slope across each hinge edge (small-angle θ_b)."""
    p0, p1, p2, p3 = (uv[hinges[:, i]] for i in range(4))
    z0, z1, z2, z3 = (z[hinges[:, i]] for i in range(4))
    e = p1 - p0
    le = np.linalg.norm(e, axis=1)
    n = np.stack([e[:, 1], -e[:, 0]], axis=1) / le[:, None]  # in-plane normal of the edge

    def height_over_edge(p, zp):
        # signed distance of the opposite vertex from the edge line, and its height above
        # the edge's linear interpolation: slope normal to the edge = dz / dist
        t = np.sum((p - p0) * e, axis=1) / le**2
        dist = np.sum((p - p0) * n, axis=1)
        return (zp - (z0 + t * (z1 - z0))) / dist

    return height_over_edge(p2, z2) - height_over_edge(p3, z3)


def _cross2(a, b):
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
