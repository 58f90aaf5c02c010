"""Contact thickness over a body's convex creases, sized to the cloth that drapes over them.

A cloth vertex keeps the contact thickness h from the nearest body face, but the straight
edge between two cloth vertices on either side of a convex crease (the shoulder line, a
coarse bust) passes below the crease, and the body shows through the cloth there. For two
faces whose normals differ by θ, cloth points a cloth edge L apart, L/2 on each side of
the crease and h in front of its faces, meet the crease's bisector at a depth

    d = (L/2) sin(θ/2) − h cos(θ/2)

below the crease (d > 0: the crease shows through): the body is a mesh, and its creases
are sharp at any cloth edge length. Lifting the
cloth vertices on both sides by d / cos(θ/2) along their faces' normals hides the crease;
:func:`crease_thickness` returns that lift per body vertex, spread over the vertices within
1.5 L of the crease edge (full within 0.75 L, falling to zero at 1.5 L); the collider interpolates
it over each face, so the cloth rises smoothly onto the crease.
"""

import numpy as np

EDGE_SPAN = 1.5
"""Cloth edges across a crease are up to this many mean edge lengths long (an irregular
mesh's longer edges and edges that cross the crease at a slant)."""


def crease_thickness(vertices: np.ndarray, triangles: np.ndarray, cloth_edge_m: float,
                     thickness_m: float) -> np.ndarray:  # fmt: skip
    """Extra contact thickness (m,) [m] per body vertex for a cloth of mean edge
    ``cloth_edge_m`` [m] kept ``thickness_m`` [m] from the body (module docstring).

    ``vertices`` (m, 3) [m] and ``triangles`` (k, 3) outward: a closed body. Zero where no
    convex crease is near; at most a quarter of the cloth edge span.
    """
    import trimesh
    from scipy.spatial import cKDTree

    v = np.asarray(vertices, np.float64)
    t = np.asarray(triangles, np.int64)
    extra = np.zeros(len(v))
    if cloth_edge_m <= 0.0 or not len(t):
        return extra
    mesh = trimesh.Trimesh(v, t, process=False)
    pairs = mesh.face_adjacency
    if not len(pairs):
        return extra
    theta = mesh.face_adjacency_angles
    convex = mesh.face_adjacency_convex
    span = EDGE_SPAN * cloth_edge_m
    depth = 0.5 * span * np.sin(0.5 * theta) - thickness_m * np.cos(0.5 * theta)
    lift = np.minimum(depth / np.cos(0.5 * theta), 0.25 * span)
    keep = convex & (depth > 0.0)
    if not keep.any():
        return extra
    ends = v[mesh.face_adjacency_edges[keep]]  # (c, 2, 3)
    mid = ends.mean(axis=1)
    half = 0.5 * np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1)
    near = cKDTree(v).query_ball_point(mid, span + half)
    for lift_e, (a, b), ids in zip(lift[keep], ends, near, strict=True):
        if not ids:
            continue
        ids = np.asarray(ids)
        ab = b - a
        s = np.clip((v[ids] - a) @ ab / max(float(ab @ ab), 1e-30), 0.0, 1.0)
        dist = np.linalg.norm(v[ids] - (a + s[:, None] * ab), axis=1)  # to the crease edge
        weight = np.clip(2.0 - 2.0 * dist / span, 0.0, 1.0)
        extra[ids] = np.maximum(extra[ids], lift_e * weight)
    return extra
