"""Contact thickness over a body's convex creases and where it shows through, sized to the
cloth that drapes over it.

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

Smooth curvature does the same over a coarse cloth: a 3 cm edge pulled taut over a
grown bust cuts the body by its sagitta, L²/8R. Where the body still shows through a cloth
that has settled, :func:`cover_thickness` raises the thickness around the body vertices
that show, by how far they show, spread the same way (the window's contact, after each
frame: :meth:`sandbox.collision.body.BodyCollider.cover`).
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
    spread_lift(extra, v, v[edges[keep, 0]], v[edges[keep, 1]], lift, span)
    return extra


def cover_thickness(vertices: np.ndarray, extra: np.ndarray, through_m: np.ndarray,
                    cloth_edge_m: float, margin_m: float) -> np.ndarray:  # fmt: skip
    """The contact thickness (m,) [m] per body vertex that covers the body where it shows
    through a cloth of mean edge ``cloth_edge_m`` [m]: ``through_m`` (m,) [m] is how far each
    body vertex shows (:func:`sandbox.collision.body_probe.through_cloth_depth`), ``extra``
    (m,) [m] the thickness the contact already adds there.

    A body vertex p showing by d lies above the cloth triangle whose corners are held the
    thickness h + extra(p) from the body; raising those corners by d + ``margin_m`` puts the
    triangle above p. The corners lie within a cloth edge span of p, so the raise is spread
    as over a crease (:func:`spread_lift`). Never less than ``extra``; at most a quarter of
    the span, as the crease thickness.
    """
    v = np.asarray(vertices, np.float64)
    out = np.array(extra, np.float64, copy=True)
    shows = np.nonzero(np.asarray(through_m) > 0.0)[0]
    if cloth_edge_m <= 0.0 or not len(shows):
        return out
    span = EDGE_SPAN * cloth_edge_m
    lift = np.minimum(out[shows] + through_m[shows] + margin_m, 0.25 * span)
    spread_lift(out, v, v[shows], v[shows], lift, span)
    return out


def spread_lift(extra: np.ndarray, v: np.ndarray, a: np.ndarray, b: np.ndarray,
                lift: np.ndarray, span: float) -> None:  # fmt: skip
    """Raise ``extra`` (m,) [m] in place to each source's ``lift`` (s,) [m] at the body
    vertices ``v`` (m, 3) within span/2 [m] of the source segment a–b (s, 3) (a point where
    a = b), falling linearly to nothing at ``span``; the largest of the sources counts."""
    from scipy.spatial import cKDTree

    half = 0.5 * np.linalg.norm(b - a, axis=1)
    # candidate (source, vertex) pairs: vertices within span + the longest half segment of a
    # source's midpoint, then their distance to the segment itself
    near = cKDTree(0.5 * (a + b)).sparse_distance_matrix(
        cKDTree(v), span + float(half.max()), output_type="ndarray")  # fmt: skip
    c, i = near["i"].astype(np.int64), near["j"].astype(np.int64)
    ab = b[c] - a[c]
    s = np.clip(np.einsum("ij,ij->i", v[i] - a[c], ab)
                / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-30), 0.0, 1.0)  # fmt: skip
    dist = np.linalg.norm(v[i] - (a[c] + s[:, None] * ab), axis=1)
    weight = np.clip(2.0 - 2.0 * dist / span, 0.0, 1.0)
    np.maximum.at(extra, i, lift[c] * weight)
