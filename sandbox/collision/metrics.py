"""Contact measures that do not depend on the solver's own collision detection.

Every run reports, in ``metrics.json``:

* ``penetration_max_m``: the deepest cloth vertex inside the body [m] (0.0 if none);
* ``vertices_inside_body``: how many cloth vertices are deeper than a tolerance;
* ``intersecting_triangle_pairs``: cloth–cloth triangle pairs that intersect, by an exact
  triangle–triangle test; pairs sharing a vertex are not counted, nor (optionally) pairs
  joined by a seam.

Body queries (:func:`body_inside_check`, :class:`BodyProbe`) run on Open3D's
``RaycastingScene`` (Embree BVH, float32): distances from ``compute_distance``; inside/outside
from the *winding number along rays*: every ray crossing is signed by the face normal and
summed, and a point is inside if the sum is at least one, by majority over five fixed ray
directions. Unlike ray parity (``compute_occupancy``, trimesh ``contains``) this stays right
where a closed body overlaps itself, e.g. one assembled from overlapping parts (the union is
inside); on a body without self-intersections (the project's mannequin) both agree.

Triangle pairs (:func:`intersecting_pairs` and friends): a uniform-grid broad phase on
axis-aligned boxes, then an exact test of the closed triangles in float64 (edge against
triangle, with coplanar and degenerate cases handled separately). Distances below a tolerance
(default ``1e-10`` times the bounding-box diagonal) count as zero, so triangles that touch
count as intersecting. See ``docs/collision_metrics.md`` for the rules and timings.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from sandbox.errors import SandboxError

TOLERANCE_REL = 1e-10  # triangle test: distances below this x bbox diagonal are zero
RAY_MERGE_REL = 1e-6  # ray hits closer than this x body bbox diagonal are one crossing
PAIR_CHUNK = 2_000_000  # candidate pairs handled at once (bounds memory)

# Fixed ray directions for the winding-number vote: no component near 0 or equal to another,
# so no ray runs along an axis, a coordinate plane or a diagonal of a lattice.
_RAY_DIRECTIONS = np.array(
    [
        [0.4313, 0.6129, 0.6620],
        [-0.7189, 0.2943, 0.6297],
        [0.5407, -0.7822, 0.3093],
        [-0.3366, -0.4527, -0.8257],
        [0.8138, 0.2286, -0.5343],
    ]
)
_RAY_DIRECTIONS /= np.linalg.norm(_RAY_DIRECTIONS, axis=1, keepdims=True)


# ---------------------------------------------------------------------------------------
# input checks


def _mesh_arrays(vertices, triangles, what: str) -> tuple[np.ndarray, np.ndarray]:
    """(n, 3) float64 vertices and (m, 3) int64 triangles, checked."""
    try:
        v = np.asarray(vertices, dtype=np.float64)
        t = np.asarray(triangles)
    except (TypeError, ValueError) as exc:
        raise SandboxError(f"{what}: vertices/triangles are not numeric arrays ({exc})") from exc
    if v.ndim != 2 or v.shape[1] != 3:
        raise SandboxError(f"{what}: vertices must have shape (n, 3), got {v.shape}")
    if t.ndim != 2 or t.shape[1] != 3:
        raise SandboxError(f"{what}: triangles must have shape (m, 3), got {t.shape}")
    if t.size and not np.issubdtype(t.dtype, np.integer):
        if not np.array_equal(t, np.round(t)):
            raise SandboxError(f"{what}: triangle indices must be integers")
    t = t.astype(np.int64)
    if t.size and (t.min() < 0 or t.max() >= len(v)):
        raise SandboxError(
            f"{what}: a triangle refers to a missing vertex (indices {t.min()}..{t.max()}, "
            f"{len(v)} vertices)"
        )
    if not np.isfinite(v).all():
        raise SandboxError(f"{what}: vertices contain NaN or infinity")
    return v, t


def _points_array(points, what: str) -> np.ndarray:
    p = np.asarray(points, dtype=np.float64)
    if p.ndim == 1 and p.shape == (3,):
        p = p[None]
    if p.ndim != 2 or p.shape[1] != 3:
        raise SandboxError(f"{what}: points must have shape (n, 3), got {p.shape}")
    if not np.isfinite(p).all():
        raise SandboxError(f"{what}: points contain NaN or infinity")
    return p


def _pair_array(pairs, what: str, limit: int) -> np.ndarray:
    p = np.asarray(pairs)
    if p.size == 0:
        return np.zeros((0, 2), np.int64)
    if p.ndim != 2 or p.shape[1] != 2 or not np.issubdtype(p.dtype, np.integer):
        raise SandboxError(f"{what}: must be integer pairs of shape (k, 2), got {p.shape}")
    p = p.astype(np.int64)
    if p.min() < 0 or p.max() >= limit:
        raise SandboxError(f"{what}: an index is out of range 0..{limit - 1}")
    return p


# ---------------------------------------------------------------------------------------
# body: distance, inside, signed distance


def edge_report(triangles: np.ndarray, vertex_count: int) -> dict[str, int]:
    """Counts of what keeps a triangle mesh from being closed and consistently oriented.

    ``boundary_edges`` (used by one triangle), ``nonmanifold_edges`` (more than two),
    ``misoriented_edges`` (two triangles walking the edge in the same direction) and
    ``degenerate_triangles`` (a repeated vertex index). All zero for a closed mesh.
    """
    t = np.asarray(triangles, np.int64)
    degenerate = (t[:, 0] == t[:, 1]) | (t[:, 1] == t[:, 2]) | (t[:, 2] == t[:, 0])
    t = t[~degenerate]
    e = t[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    lo, hi = e.min(1), e.max(1)
    key = lo * np.int64(vertex_count) + hi
    _, inv, counts = np.unique(key, return_inverse=True, return_counts=True)
    forward = np.bincount(inv, weights=(e[:, 0] < e[:, 1]), minlength=len(counts))
    return {
        "boundary_edges": int(np.sum(counts == 1)),
        "nonmanifold_edges": int(np.sum(counts > 2)),
        "misoriented_edges": int(np.sum((counts == 2) & (forward != 1))),
        "degenerate_triangles": int(degenerate.sum()),
    }


class BodyProbe:
    """Distance, inside/outside and signed distance of points against a body mesh.

    Build with :func:`body_inside_check`. ``distance`` works on any triangle mesh;
    ``inside`` and ``signed_distance`` need a closed mesh (every edge shared by exactly two
    triangles walking it in opposite directions) and raise :class:`SandboxError` otherwise.

    Attributes: ``name``, ``vertices`` (m, 3) float64, ``triangles`` (k, 3) int64,
    ``closed`` (bool), ``problems`` (:func:`edge_report`), ``inward`` (the faces pointed
    inwards and were taken reversed; the inside test does not depend on it).
    """

    def __init__(self, vertices, triangles, *, name: str = "body"):
        import open3d as o3d  # heavy import, only where a body is probed

        what = f"body {name!r}"
        v, t = _mesh_arrays(vertices, triangles, what)
        if len(t) == 0:
            raise SandboxError(f"{what}: the mesh has no triangles")
        self.name = name
        self.vertices = v
        self.triangles = t
        self.problems = edge_report(t, len(v))
        self.closed = not any(self.problems.values())
        used = v[np.unique(t)]
        lo, hi = used.min(0), used.max(0)
        self._center = 0.5 * (lo + hi)  # float32 precision is relative to this
        self._size = float(np.linalg.norm(hi - lo)) or 1.0
        a, b, c = (v[t[:, k]] - self._center for k in range(3))
        normal = np.cross(b - a, c - a)
        self.inward = bool(np.einsum("ij,ij->", a, normal) < 0)  # 6 x signed volume
        self._normal = -normal if self.inward else normal  # outward, not normalised
        self._o3d = o3d
        self._scene = o3d.t.geometry.RaycastingScene()
        self._scene.add_triangles(
            o3d.core.Tensor(np.ascontiguousarray(v - self._center, dtype=np.float32)),
            o3d.core.Tensor(np.ascontiguousarray(t, dtype=np.uint32)),
        )

    def __repr__(self) -> str:
        state = "closed" if self.closed else "open"
        return f"BodyProbe({self.name!r}, {len(self.triangles)} triangles, {state})"

    def _query(self, points) -> np.ndarray:
        p = _points_array(points, f"body {self.name!r}")
        return np.ascontiguousarray(p - self._center, dtype=np.float32)

    def _require_closed(self) -> None:
        if self.closed:
            return
        labels = {
            "boundary_edges": "boundary edges (used by one triangle)",
            "nonmanifold_edges": "non-manifold edges (used by more than two triangles)",
            "misoriented_edges": "inconsistently oriented edges",
            "degenerate_triangles": "triangles with a repeated vertex",
        }
        found = ", ".join(f"{n} {labels[k]}" for k, n in self.problems.items() if n)
        raise SandboxError(
            f"body {self.name!r}: the inside test needs a closed mesh (every edge shared by "
            f"exactly two consistently oriented triangles), but this one has {found}; "
            "distance() still works on it"
        )

    def distance(self, points) -> np.ndarray:
        """Unsigned distance [m] from each point to the nearest body triangle, (n,) float64.

        Works on open meshes too. Accuracy: float32 on coordinates relative to the body's
        centre, about 1e-7 of the body size.
        """
        q = self._query(points)
        if len(q) == 0:
            return np.zeros(0)
        d = self._scene.compute_distance(self._o3d.core.Tensor(q)).numpy()
        return d.astype(np.float64)

    def inside(self, points) -> np.ndarray:
        """True where a point is inside the closed body, (n,) bool.

        Winding number along rays: crossings signed by the outward normal (+1 leaving),
        hits closer than 1e-6 body diagonals merged into one (a ray through an edge or a
        vertex), inside if the sum is >= 1; majority vote of five fixed directions. Points
        on the surface (closer than float32 precision) may go either way.
        """
        self._require_closed()
        q = self._query(points)
        n = len(q)
        if n == 0:
            return np.zeros(0, bool)
        merge = RAY_MERGE_REL * self._size
        votes = np.zeros(n, np.int64)
        for d in _RAY_DIRECTIONS:
            rays = np.empty((n, 6), np.float32)
            rays[:, :3] = q
            rays[:, 3:] = d
            hits = self._scene.list_intersections(self._o3d.core.Tensor(rays))
            ray = hits["ray_ids"].numpy().astype(np.int64)
            if len(ray) == 0:
                continue
            t_hit = hits["t_hit"].numpy().astype(np.float64)
            prim = hits["primitive_ids"].numpy().astype(np.int64)
            sign = np.sign(self._normal[prim] @ d)
            order = np.lexsort((t_hit, ray))
            ray, t_hit, sign = ray[order], t_hit[order], sign[order]
            new = np.ones(len(ray), bool)
            new[1:] = (ray[1:] != ray[:-1]) | (t_hit[1:] - t_hit[:-1] > merge)
            cluster = np.cumsum(new) - 1
            crossing = np.sign(np.bincount(cluster, weights=sign))
            winding = np.bincount(ray[new], weights=crossing, minlength=n)
            votes += winding > 0.5
        return votes > len(_RAY_DIRECTIONS) // 2

    def signed_distance(self, points) -> np.ndarray:
        """Distance to the nearest body triangle [m], negative inside, (n,) float64."""
        self._require_closed()
        d = self.distance(points)
        return np.where(self.inside(points), -d, d)


def body_inside_check(body_vertices, body_triangles, *, name: str = "body") -> BodyProbe:
    """Check a body mesh and return a :class:`BodyProbe` for point queries.

    Args:
        body_vertices: (m, 3) positions [m]. body_triangles: (k, 3) vertex indices.
        name: used in error messages.

    Malformed input (shapes, indices, NaN, no triangles) raises :class:`SandboxError` at
    once. A mesh that is not closed is accepted: ``probe.closed`` is False,
    ``probe.problems`` says why, ``probe.distance`` works, and ``inside`` /
    ``signed_distance`` raise :class:`SandboxError` naming the boundary, non-manifold and
    misoriented edge counts.
    """
    return BodyProbe(body_vertices, body_triangles, name=name)


def penetration_metrics(cloth_vertices, probe: BodyProbe, *, tolerance_m: float = 0.0) -> dict:
    """How deep cloth vertices sit inside the body.

    Returns ``{"penetration_max_m": float, "vertices_inside_body": int}``: the largest depth
    (distance to the body surface) of a vertex inside the body, 0.0 if none is inside; and
    the number of vertices deeper than ``tolerance_m``. Raises :class:`SandboxError` if the
    body is not closed or the tolerance is negative.
    """
    if not np.isfinite(tolerance_m) or tolerance_m < 0:
        raise SandboxError(f"penetration tolerance_m must be >= 0, got {tolerance_m}")
    sd = probe.signed_distance(_points_array(cloth_vertices, "cloth vertices"))
    depth = -sd
    return {
        "penetration_max_m": float(max(0.0, depth.max())) if len(depth) else 0.0,
        "vertices_inside_body": int(np.sum(depth > tolerance_m)),
    }


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
# narrow phase: exact test of closed triangles, vectorised over pairs


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", a, b)


def _snap(x: np.ndarray, eps: float) -> np.ndarray:
    return np.where(np.abs(x) <= eps, 0.0, x)


def _in_triangle(x, t0, t1, t2, n, eps) -> np.ndarray:
    """x (in the plane with unit normal n) lies in the closed triangle, either orientation."""
    s = []
    for a, b in ((t0, t1), (t1, t2), (t2, t0)):
        e = b - a
        s.append(_dot(np.cross(e, x - a), n) / np.linalg.norm(e, axis=1))
    s = np.stack(s, 1)
    return (s >= -eps).all(1) | (s <= eps).all(1)


def _segments_meet_in_plane(p, q, a, b, n, eps) -> np.ndarray:
    """Closed segments pq and ab, in a plane with unit normal n, meet; |ab| > 0."""
    u, w = q - p, b - a
    lu = np.linalg.norm(u, axis=1)
    lw = np.linalg.norm(w, axis=1)
    safe_u = np.where(lu > 0, lu, 1.0)
    o1 = _snap(_dot(np.cross(u, a - p), n) / safe_u, eps) * (lu > 0)
    o2 = _snap(_dot(np.cross(u, b - p), n) / safe_u, eps) * (lu > 0)
    o3 = _snap(_dot(np.cross(w, p - a), n) / lw, eps)
    o4 = _snap(_dot(np.cross(w, q - a), n) / lw, eps)
    # one segment on the other's line (within eps): compare positions along ab instead
    collinear = ((o1 == 0) & (o2 == 0)) | ((o3 == 0) & (o4 == 0))
    crossing = (np.sign(o1) * np.sign(o2) <= 0) & (np.sign(o3) * np.sign(o4) <= 0) & ~collinear
    sp, sq = _dot(p - a, w) / lw, _dot(q - a, w) / lw  # positions along ab [m]
    overlap = (np.maximum(sp, sq) >= -eps) & (np.minimum(sp, sq) <= lw + eps)
    return crossing | (collinear & overlap)


def _segment_meets_triangle_in_plane(p, q, t0, t1, t2, n, eps) -> np.ndarray:
    hit = _in_triangle(p, t0, t1, t2, n, eps) | _in_triangle(q, t0, t1, t2, n, eps)
    for a, b in ((t0, t1), (t1, t2), (t2, t0)):
        rest = ~hit
        if not rest.any():
            break
        hit[rest] = _segments_meet_in_plane(p[rest], q[rest], a[rest], b[rest], n[rest], eps)
    return hit


def _edge_meets_triangle(p, q, dp, dq, t0, t1, t2, n, eps) -> np.ndarray:
    """Closed segment pq meets the closed triangle (t0, t1, t2) with unit normal n.

    dp, dq: signed distances of p and q from the triangle's plane, already snapped to 0.
    """
    hit = np.zeros(len(p), bool)
    in_plane = (dp == 0) & (dq == 0)
    through = (np.sign(dp) * np.sign(dq) <= 0) & ~in_plane
    if through.any():
        i = np.nonzero(through)[0]
        s = dp[i] / (dp[i] - dq[i])
        x = p[i] + s[:, None] * (q[i] - p[i])
        hit[i] = _in_triangle(x, t0[i], t1[i], t2[i], n[i], eps)
    if in_plane.any():
        i = np.nonzero(in_plane)[0]
        hit[i] = _segment_meets_triangle_in_plane(p[i], q[i], t0[i], t1[i], t2[i], n[i], eps)
    return hit


def _segment_distance(p1, q1, p2, q2) -> np.ndarray:
    """Distance between closed 3D segments, either possibly of zero length (Ericson 5.1.9)."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a, e = _dot(d1, d1), _dot(d2, d2)
    b, c, f = _dot(d1, d2), _dot(d1, r), _dot(d2, r)
    tiny = 1e-300
    pa, pe = a > tiny, e > tiny
    sa, se = np.where(pa, a, 1.0), np.where(pe, e, 1.0)
    denom = a * e - b * b
    s = np.where(
        denom > tiny, np.clip((b * f - c * e) / np.where(denom > tiny, denom, 1.0), 0, 1), 0
    )
    t = (b * s + f) / se
    s = np.where(t < 0, np.clip(-c / sa, 0, 1), np.where(t > 1, np.clip((b - c) / sa, 0, 1), s))
    t = np.clip(t, 0, 1)
    # a segment of zero length: the other's parameter from the point alone
    s = np.where(pe, s, np.clip(-c / sa, 0, 1))
    t = np.where(pe, t, 0.0)
    s = np.where(pa, s, 0.0)
    t = np.where(pa, t, np.clip(f / se, 0, 1) * pe)
    return np.linalg.norm(p1 + d1 * s[:, None] - p2 - d2 * t[:, None], axis=1)


def _triangles_meet(A: np.ndarray, B: np.ndarray, eps: float) -> np.ndarray:
    """Closed triangles A[i] and B[i] ((P, 3, 3) corners) share a point, up to eps [m]."""
    P = len(A)
    out = np.zeros(P, bool)
    if P == 0:
        return out
    nA = np.cross(A[:, 1] - A[:, 0], A[:, 2] - A[:, 0])
    nB = np.cross(B[:, 1] - B[:, 0], B[:, 2] - B[:, 0])
    lnA, lnB = np.sqrt(_dot(nA, nA)), np.sqrt(_dot(nB, nB))

    def longest2(T):  # squared longest edge
        e = T[:, [1, 2, 0]] - T
        return np.einsum("pkj,pkj->pk", e, e).max(1)

    # degenerate: height (2 area / longest edge) within eps -> a segment or a point
    degA = lnA**2 <= eps**2 * longest2(A)
    degB = lnB**2 <= eps**2 * longest2(B)
    nA = nA / np.where(degA, 1.0, lnA)[:, None]
    nB = nB / np.where(degB, 1.0, lnB)[:, None]

    both = ~degA & ~degB
    if both.any():
        i = np.nonzero(both)[0]
        a, b = A[i], B[i]
        na, nb = nA[i], nB[i]
        dA = _snap(np.einsum("pkj,pj->pk", a - b[:, :1], nb), eps)  # A's corners vs plane B
        dB = _snap(np.einsum("pkj,pj->pk", b - a[:, :1], na), eps)
        apart = (dA > 0).all(1) | (dA < 0).all(1) | (dB > 0).all(1) | (dB < 0).all(1)
        coplanar = ~apart & ((dA == 0).all(1) | (dB == 0).all(1))
        general = ~apart & ~coplanar
        if general.any():
            g = np.nonzero(general)[0]
            ga, gb, gna, gnb, gdA, gdB = a[g], b[g], na[g], nb[g], dA[g], dB[g]
            hit = np.zeros(len(g), bool)
            for k0, k1 in ((0, 1), (1, 2), (2, 0)):
                r = ~hit
                hit[r] = _edge_meets_triangle(
                    ga[r, k0], ga[r, k1], gdA[r, k0], gdA[r, k1],
                    gb[r, 0], gb[r, 1], gb[r, 2], gnb[r], eps,
                )  # fmt: skip
                r = ~hit
                hit[r] = _edge_meets_triangle(
                    gb[r, k0], gb[r, k1], gdB[r, k0], gdB[r, k1],
                    ga[r, 0], ga[r, 1], ga[r, 2], gna[r], eps,
                )  # fmt: skip
            out[i[g]] = hit
        if coplanar.any():
            c = np.nonzero(coplanar)[0]
            ca, cb = a[c], b[c]
            n = np.where((lnA[i[c]] >= lnB[i[c]])[:, None], na[c], nb[c])
            hit = _in_triangle(ca[:, 0], cb[:, 0], cb[:, 1], cb[:, 2], n, eps)
            hit |= _in_triangle(cb[:, 0], ca[:, 0], ca[:, 1], ca[:, 2], n, eps)
            for k0, k1 in ((0, 1), (1, 2), (2, 0)):
                for j0, j1 in ((0, 1), (1, 2), (2, 0)):
                    r = ~hit
                    hit[r] = _segments_meet_in_plane(
                        ca[r, k0], ca[r, k1], cb[r, j0], cb[r, j1], n[r], eps
                    )
            out[i[c]] = hit

    # one degenerate: it is the union of its edges, test them against the other's plane
    for seg, tri, nt, mask in ((A, B, nB, degA & ~degB), (B, A, nA, degB & ~degA)):
        if not mask.any():
            continue
        i = np.nonzero(mask)[0]
        s, t, n = seg[i], tri[i], nt[i]
        d = _snap(np.einsum("pkj,pj->pk", s - t[:, :1], n), eps)
        hit = np.zeros(len(i), bool)
        for k0, k1 in ((0, 1), (1, 2), (2, 0)):
            r = ~hit
            hit[r] = _edge_meets_triangle(
                s[r, k0], s[r, k1], d[r, k0], d[r, k1], t[r, 0], t[r, 1], t[r, 2], n[r], eps
            )
        out[i] = hit

    both_deg = degA & degB
    if both_deg.any():
        i = np.nonzero(both_deg)[0]
        a, b = A[i], B[i]
        hit = np.zeros(len(i), bool)
        for k0, k1 in ((0, 1), (1, 2), (2, 0)):
            for j0, j1 in ((0, 1), (1, 2), (2, 0)):
                r = ~hit
                hit[r] = _segment_distance(a[r, k0], a[r, k1], b[r, j0], b[r, j1]) <= eps
        out[i] = hit
    return out


# ---------------------------------------------------------------------------------------
# public: triangle pairs


def _tolerance(vertices: np.ndarray, tolerance_m: float | None) -> float:
    if tolerance_m is None:
        if len(vertices) == 0:
            return 0.0
        return TOLERANCE_REL * float(np.linalg.norm(vertices.max(0) - vertices.min(0)))
    if not np.isfinite(tolerance_m) or tolerance_m < 0:
        raise SandboxError(f"triangle intersection tolerance_m must be >= 0, got {tolerance_m}")
    return float(tolerance_m)


def _member(keys: np.ndarray, table: np.ndarray) -> np.ndarray:
    """keys (any shape) found in the sorted unique 1-D ``table``."""
    if len(table) == 0:
        return np.zeros(keys.shape, bool)
    idx = np.searchsorted(table, keys)
    return table[np.minimum(idx, len(table) - 1)] == keys


def seam_joined_pairs(seam_pairs, vertex_count: int | None = None) -> np.ndarray:
    """Vertex pairs (p, 2), i < j, that a seam joins into one point of the garment: the
    sewn pairs and, where three panels meet (an underarm: front, back and sleeve), the
    partners of partners. The metrics count two triangles that hold such a pair as
    touching at that point, as two triangles that share a vertex (the self-collider leaves
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
    joined = (a + a @ a).tocoo()
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
    v, t = _mesh_arrays(vertices, triangles, "cloth mesh")
    m = len(t)
    excl = _pair_array(exclude_pairs if exclude_pairs is not None else [], "exclude_pairs", m)
    vexcl = _pair_array(
        exclude_vertex_pairs if exclude_vertex_pairs is not None else [],
        "exclude_vertex_pairs",
        len(v),
    )
    if m < 2:
        return np.zeros((0, 2), np.int64)
    eps = _tolerance(v[np.unique(t)], tolerance_m)
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
        hit = _triangles_meet(corners[a], corners[b], eps)
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
    va, ta = _mesh_arrays(verts_a, tris_a, "mesh A")
    vb, tb = _mesh_arrays(verts_b, tris_b, "mesh B")
    if len(ta) == 0 or len(tb) == 0:
        return np.zeros((0, 2), np.int64)
    used = np.concatenate([va[np.unique(ta)], vb[np.unique(tb)]])
    eps = _tolerance(used, tolerance_m)
    corners = np.concatenate([va[ta], vb[tb]])
    lo, hi = corners.min(1) - eps, corners.max(1) + eps
    second = np.zeros(len(corners), bool)
    second[len(ta) :] = True
    found = []
    for a, b in _grid_candidates(lo, hi, second):
        hit = _triangles_meet(corners[a], corners[b], eps)
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


def contact_metrics(
    cloth_vertices,
    cloth_triangles,
    probe: BodyProbe | None = None,
    *,
    seam_pairs=None,
    penetration_tolerance_m: float = 0.0,
) -> dict:
    """The three metrics.json measures for a final cloth state.

    ``penetration_max_m`` and ``vertices_inside_body`` (only with a closed ``probe``; see
    :func:`penetration_metrics`) and ``intersecting_triangle_pairs`` (seam-joined vertex
    pairs ``seam_pairs`` excluded; see :func:`intersecting_pairs`).
    """
    out = {}
    if probe is not None:
        out.update(penetration_metrics(cloth_vertices, probe, tolerance_m=penetration_tolerance_m))
    out["intersecting_triangle_pairs"] = count_intersecting_pairs(
        cloth_vertices, cloth_triangles, exclude_vertex_pairs=seam_pairs
    )
    return out


def body_vertices_through_cloth(
    cloth_vertices, cloth_triangles, body_vertices, body_triangles, *, reach_m: float = 0.01
) -> int:
    """Body vertices that show through the cloth: the cloth lies *under* them.

    For each body vertex, a ray from it into the body (against its area-weighted vertex
    normal) that meets a cloth triangle within ``reach_m`` [m] means the cloth passes
    below the body surface there: a coarse triangle sagging through a convex part of the
    body while its corners stay outside. Body vertices farther than ``reach_m`` from the
    cloth's bounding box are not tested. Returns the count (should be 0). numpy, in chunks
    (Möller–Trumbore against the triangles whose boxes the short ray meets).
    """
    import trimesh

    cv, ct = _mesh_arrays(cloth_vertices, cloth_triangles, "cloth")
    bv, bt = _mesh_arrays(body_vertices, body_triangles, "body")
    if len(ct) == 0:
        return 0
    lo, hi = cv.min(axis=0) - reach_m, cv.max(axis=0) + reach_m
    near = np.all((bv >= lo) & (bv <= hi), axis=1)
    if not near.any():
        return 0
    normals = trimesh.Trimesh(bv, bt, process=False).vertex_normals[near]
    origins = bv[near]
    a, b, c = cv[ct[:, 0]], cv[ct[:, 1]], cv[ct[:, 2]]
    t_lo, t_hi = np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c)
    e1, e2 = b - a, c - a
    count = 0
    for k in range(len(origins)):
        o, d = origins[k], -normals[k]
        end = o + reach_m * d
        r_lo, r_hi = np.minimum(o, end), np.maximum(o, end)
        sel = np.nonzero(np.all((t_lo <= r_hi) & (t_hi >= r_lo), axis=1))[0]
        if len(sel) == 0:
            continue
        p = np.cross(d, e2[sel])
        det = np.einsum("ij,ij->i", e1[sel], p)
        ok = np.abs(det) > 1e-18
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = o - a[sel]
        u = np.einsum("ij,ij->i", s, p) * inv
        q = np.cross(s, e1[sel])
        v = (q @ d) * inv
        t = np.einsum("ij,ij->i", e2[sel], q) * inv
        hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0) & (t < reach_m)
        count += bool(hit.any())
    return count
