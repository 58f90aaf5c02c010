"""Cloth triangle pairs that intersect, independent of the solver's own collision detection.

Every run reports, in ``metrics.json`` (:func:`sandbox.scene.run.contact_metrics`):

* ``penetration_max_m``: the deepest cloth vertex inside the body [m] (0.0 if none);
* ``vertices_inside_body``: how many cloth vertices are deeper than a tolerance
  (both from :mod:`sandbox.collision.body_probe`);
* ``intersecting_triangle_pairs``: cloth–cloth triangle pairs that intersect, by an exact
  triangle–triangle test; pairs sharing a vertex are not counted, nor (optionally) pairs
  joined by a seam (this module).

Triangle pairs (:func:`intersecting_pairs` and friends): a uniform-grid broad phase on
axis-aligned boxes, then the exact test of closed triangles of
:mod:`sandbox.collision.triangle_test`. See ``docs/collision_metrics.md`` for the rules and
timings.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from sandbox.collision.mesh_checks import mesh_arrays, pair_array
from sandbox.collision.triangle_test import pair_tolerance, triangles_meet

PAIR_CHUNK = 2_000_000  # candidate pairs handled at once (bounds memory)


# ---------------------------------------------------------------------------------------
# broad phase: uniform grid on axis-aligned boxes


def _grid_candidates(
    lo: np.ndarray, hi: np.ndarray, second: np.ndarray | None = None
) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Pairs (a, b) of boxes that overlap (closed boxes), each pair once, in chunks.

    Each box is registered in every grid cell it touches; a pair found in a cell is kept
    only in the cell holding the low corner of the boxes' overlap, so it is reported once.
    With ``second`` (bool per box) only pairs with ``second[a] == False`` and
    ``second[b] == True`` are produced.
    """
    m = len(lo)
    if m < 2:
        return
    gmin = lo.min(0)
    span_all = float(np.max(hi.max(0) - gmin))
    ext = (hi - lo).max(1)
    h = float(np.median(ext))
    h = max(h, span_all * 1e-6, 1e-300)
    while True:  # coarsen until boxes touch few cells and keys fit in int64
        cells = np.floor((hi.max(0) - gmin) / h).astype(np.int64) + 1
        lo_c = np.floor((lo - gmin) / h).astype(np.int64)
        hi_c = np.floor((hi - gmin) / h).astype(np.int64)
        span = hi_c - lo_c + 1
        if cells.max() <= 2**20 and np.prod(span, axis=1, dtype=np.float64).sum() <= 8 * m + 64:
            break
        h *= 1.6
    nx, ny = int(cells[0]), int(cells[1])
    count = np.prod(span, axis=1)
    box = np.repeat(np.arange(m), count)
    local = np.arange(len(box)) - np.repeat(np.cumsum(count) - count, count)
    sx, sy = span[box, 0], span[box, 1]
    cx = lo_c[box, 0] + local % sx
    cy = lo_c[box, 1] + (local // sx) % sy
    cz = lo_c[box, 2] + local // (sx * sy)
    key = cx + nx * (cy + ny * cz)
    if second is None:
        order = np.argsort(key, kind="stable")
    else:
        order = np.lexsort((second[box], key))  # first-set boxes before second-set in a cell
    key, box = key[order], box[order]
    n_e = len(key)
    pos = np.arange(n_e)
    start = np.ones(n_e, bool)
    start[1:] = key[1:] != key[:-1]
    group_start = np.maximum.accumulate(np.where(start, pos, 0))
    stop = np.ones(n_e, bool)
    stop[:-1] = start[1:]
    group_end = np.minimum.accumulate(np.where(stop, pos + 1, n_e)[::-1])[::-1]
    if second is None:
        first_partner = pos + 1
        n_pairs = group_end - first_partner
    else:
        is_b = second[box]
        b_start = np.where(is_b, pos, n_e)  # first second-set entry of each cell
        b_start = np.minimum.accumulate(b_start[::-1])[::-1]
        first_partner = np.minimum(np.maximum(b_start, group_start), group_end)
        n_pairs = np.where(is_b, 0, group_end - first_partner)
    del group_start
    cum = np.cumsum(n_pairs)
    total = int(cum[-1]) if n_e else 0
    done, e0 = 0, 0
    while done < total:
        e1 = int(np.searchsorted(cum, done + PAIR_CHUNK, side="right"))
        e1 = max(e1, e0 + 1)
        cnt = n_pairs[e0:e1]
        k = int(cnt.sum())
        ent = np.repeat(np.arange(e0, e1), cnt)
        off = np.arange(k) - np.repeat(np.cumsum(cnt) - cnt, cnt)
        partner = first_partner[ent] + off
        a, b = box[ent], box[partner]
        lo_o = np.maximum(lo[a], lo[b])
        keep = (lo_o <= np.minimum(hi[a], hi[b])).all(1)
        ref = np.floor((lo_o - gmin) / h).astype(np.int64)
        keep &= ref[:, 0] + nx * (ref[:, 1] + ny * ref[:, 2]) == key[ent]
        yield a[keep], b[keep]
        done += k
        e0 = e1


# ---------------------------------------------------------------------------------------
# public: triangle pairs


def _member(keys: np.ndarray, table: np.ndarray) -> np.ndarray:
    """keys (any shape) found in the sorted unique 1-D ``table``."""
    if len(table) == 0:
        return np.zeros(keys.shape, bool)
    idx = np.searchsorted(table, keys)
    return table[np.minimum(idx, len(table) - 1)] == keys


def seam_joined_pairs(seam_pairs, vertex_count: int | None = None) -> np.ndarray:
    """Vertex pairs (p, 2), i < j, that a seam joins into one point of the garment: the
    sewn pairs; where three panels meet (an underarm: front, back and sleeve), the
    partners of partners; where four meet, sewn in a chain (a hood's two halves and the
    two fronts at the front of the neckline), their partners in turn. The metrics count
    two triangles that hold such a pair as touching at that point, as two triangles that
    share a vertex (the self-collider leaves
    the same pairs free, :meth:`~sandbox.collision.self_contact.SelfCollider.set_seam_partners`).
    """
    import scipy.sparse as sp

    if seam_pairs is None or len(seam_pairs) == 0:
        return np.zeros((0, 2), np.int64)
    p = np.asarray(seam_pairs, np.int64).reshape(-1, 2)
    p = p[p[:, 0] != p[:, 1]]
    n = int(vertex_count) if vertex_count is not None else int(p.max()) + 1
    a = sp.coo_matrix((np.ones(2 * len(p)), (np.r_[p[:, 0], p[:, 1]], np.r_[p[:, 1], p[:, 0]])),
                      shape=(n, n)).tocsr()  # fmt: skip
    a2 = a @ a
    joined = (a + a2 + a2 @ a).tocoo()
    keep = joined.row < joined.col
    return np.unique(np.stack([joined.row[keep], joined.col[keep]], 1).astype(np.int64), axis=0)


def intersecting_pairs(
    vertices,
    triangles,
    *,
    exclude_pairs=None,
    exclude_vertex_pairs=None,
    tolerance_m: float | None = None,
) -> np.ndarray:
    """Pairs of triangles of one mesh that intersect: (p, 2) int64, i < j, sorted.

    Args:
        vertices: (n, 3) [m]. triangles: (m, 3) vertex indices.
        exclude_pairs: (k, 2) triangle index pairs never counted (either order).
        exclude_vertex_pairs: (s, 2) vertex pairs (e.g. seam springs); a triangle pair is
            skipped if any vertex of one is paired with any vertex of the other.
        tolerance_m: distances up to this count as contact; default 1e-10 x the bounding
            box diagonal of the vertices.

    Pairs sharing a vertex index are never tested. Triangles that only touch (within the
    tolerance) count; coplanar triangles count if they overlap or touch in their plane.
    """
    v, t = mesh_arrays(vertices, triangles, "cloth mesh")
    m = len(t)
    excl = pair_array(exclude_pairs if exclude_pairs is not None else [], "exclude_pairs", m)
    vexcl = pair_array(
        exclude_vertex_pairs if exclude_vertex_pairs is not None else [],
        "exclude_vertex_pairs",
        len(v),
    )
    if m < 2:
        return np.zeros((0, 2), np.int64)
    eps = pair_tolerance(v[np.unique(t)], tolerance_m)
    corners = v[t]
    lo, hi = corners.min(1) - eps, corners.max(1) + eps
    tri_table = np.unique(excl.min(1) * m + excl.max(1))
    nv = np.int64(len(v))
    vert_table = np.unique(vexcl.min(1) * nv + vexcl.max(1))
    found = []
    for a, b in _grid_candidates(lo, hi):
        a, b = np.minimum(a, b), np.maximum(a, b)
        ta, tb = t[a], t[b]
        keep = ~(ta[:, :, None] == tb[:, None, :]).any((1, 2))
        if len(tri_table):
            keep &= ~_member(a * m + b, tri_table)
        if len(vert_table):
            va, vb = ta[:, :, None], tb[:, None, :]
            vkey = np.minimum(va, vb) * nv + np.maximum(va, vb)
            keep &= ~_member(vkey, vert_table).any((1, 2))
        a, b = a[keep], b[keep]
        hit = triangles_meet(corners[a], corners[b], eps)
        found.append(np.stack([a[hit], b[hit]], 1))
    if not found:
        return np.zeros((0, 2), np.int64)
    pairs = np.concatenate(found).astype(np.int64)
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


def count_intersecting_pairs(
    vertices,
    triangles,
    *,
    exclude_pairs=None,
    exclude_vertex_pairs=None,
    tolerance_m: float | None = None,
) -> int:
    """Number of intersecting triangle pairs of one mesh; see :func:`intersecting_pairs`."""
    return len(
        intersecting_pairs(
            vertices,
            triangles,
            exclude_pairs=exclude_pairs,
            exclude_vertex_pairs=exclude_vertex_pairs,
            tolerance_m=tolerance_m,
        )
    )


def intersecting_pairs_between(
    verts_a, tris_a, verts_b, tris_b, *, tolerance_m: float | None = None
) -> np.ndarray:
    """Pairs (i, j) with triangle i of mesh A meeting triangle j of mesh B: (p, 2) int64.

    No pair is skipped (the meshes share no vertices). Same test and tolerance rule as
    :func:`intersecting_pairs`, the default tolerance from both meshes' bounding box.
    """
    va, ta = mesh_arrays(verts_a, tris_a, "mesh A")
    vb, tb = mesh_arrays(verts_b, tris_b, "mesh B")
    if len(ta) == 0 or len(tb) == 0:
        return np.zeros((0, 2), np.int64)
    used = np.concatenate([va[np.unique(ta)], vb[np.unique(tb)]])
    eps = pair_tolerance(used, tolerance_m)
    corners = np.concatenate([va[ta], vb[tb]])
    lo, hi = corners.min(1) - eps, corners.max(1) + eps
    second = np.zeros(len(corners), bool)
    second[len(ta) :] = True
    found = []
    for a, b in _grid_candidates(lo, hi, second):
        hit = triangles_meet(corners[a], corners[b], eps)
        found.append(np.stack([a[hit], b[hit] - len(ta)], 1))
    if not found:
        return np.zeros((0, 2), np.int64)
    pairs = np.concatenate(found).astype(np.int64)
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]


def count_intersections_between(
    verts_a, tris_a, verts_b, tris_b, *, tolerance_m: float | None = None
) -> int:
    """Number of (A, B) triangle pairs that intersect; see :func:`intersecting_pairs_between`."""
    return len(
        intersecting_pairs_between(verts_a, tris_a, verts_b, tris_b, tolerance_m=tolerance_m)
    )
