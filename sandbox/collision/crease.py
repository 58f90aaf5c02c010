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

SADDLE_RAD = 0.5
"""A concave crease sharper than this (29°) at either end of a convex one makes it a saddle,
left alone (:func:`crease_thickness`)."""

EDGE_SPAN = 1.5
"""Cloth edges across a crease are up to this many mean edge lengths long (an irregular
mesh's longer edges and edges that cross the crease at a slant)."""


def crease_adjacency(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The body's face pairs that share an edge: ``(pairs (e, 2), edges (e, 2), opposite
    (e,))`` with ``opposite`` the vertex of the second face off the shared edge. Depends on
    the triangles only, so a resized body reuses it."""
    import trimesh

    t = np.asarray(triangles, np.int64)
    pairs, edges = trimesh.graph.face_adjacency(t, return_edges=True)
    second = t[pairs[:, 1]]
    opposite = second[(second != edges[:, :1]) & (second != edges[:, 1:])]
    return pairs, edges, opposite


def crease_thickness(vertices: np.ndarray, triangles: np.ndarray, cloth_edge_m: float,
                     thickness_m: float, adjacency=None) -> np.ndarray:  # fmt: skip
    """Extra contact thickness (m,) [m] per body vertex for a cloth of mean edge
    ``cloth_edge_m`` [m] kept ``thickness_m`` [m] from the body (module docstring).

    ``vertices`` (m, 3) [m] and ``triangles`` (k, 3) outward: a closed body; ``adjacency``:
    :func:`crease_adjacency` of the triangles, if already made. Zero where no convex crease
    is near; at most a quarter of the cloth edge span.
    """
    from scipy.spatial import cKDTree

    v = np.asarray(vertices, np.float64)
    t = np.asarray(triangles, np.int64)
    extra = np.zeros(len(v))
    if cloth_edge_m <= 0.0 or not len(t):
        return extra
    pairs, edges, opposite = adjacency if adjacency is not None else crease_adjacency(t)
    if not len(pairs):
        return extra
    n = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    n1, n2 = n[pairs[:, 0]], n[pairs[:, 1]]
    theta = np.arccos(np.clip(np.einsum("ij,ij->i", n1, n2), -1.0, 1.0))
    # convex: the second face's far corner lies behind the first face's plane
    convex = np.einsum("ij,ij->i", v[opposite] - v[edges[:, 0]], n1) < 0.0
    span = EDGE_SPAN * cloth_edge_m
    depth = 0.5 * span * np.sin(0.5 * theta) - thickness_m * np.cos(0.5 * theta)
    # a convex crease beside a concave one is a saddle (where an arm or a leg meets the
    # torso): cloth spans the hollow there, and a lift would only pull it out of it
    hollow = np.zeros(len(v), bool)
    hollow[edges[~convex & (theta > SADDLE_RAD)].ravel()] = True
    ring = hollow[edges[:, 0]] | hollow[edges[:, 1]]  # and one ring of faces around it
    hollow[edges[ring].ravel()] = True
    keep = convex & (depth > 0.0) & ~hollow[edges[:, 0]] & ~hollow[edges[:, 1]]
    if not keep.any():
        return extra
    lift = np.minimum(depth[keep] / np.cos(0.5 * theta[keep]), 0.25 * span)
    a, b = v[edges[keep, 0]], v[edges[keep, 1]]
    half = 0.5 * np.linalg.norm(b - a, axis=1)
    # candidate (crease, vertex) pairs: vertices within span + the longest half edge of a
    # crease's midpoint, then their distance to the crease edge itself
    near = cKDTree(0.5 * (a + b)).sparse_distance_matrix(
        cKDTree(v), span + float(half.max()), output_type="ndarray")  # fmt: skip
    c, i = near["i"].astype(np.int64), near["j"].astype(np.int64)
    ab = b[c] - a[c]
    s = np.clip(np.einsum("ij,ij->i", v[i] - a[c], ab)
                / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-30), 0.0, 1.0)  # fmt: skip
    dist = np.linalg.norm(v[i] - (a[c] + s[:, None] * ab), axis=1)
    weight = np.clip(2.0 - 2.0 * dist / span, 0.0, 1.0)
    np.maximum.at(extra, i, lift[c] * weight)
    return extra
