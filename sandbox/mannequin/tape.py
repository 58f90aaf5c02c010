"""The tape measure: the seven measurements of §2.1.4 on any closed body mesh.

Measured as a tailor does, with the tape held against the body so it bridges hollows:

* girths (bust, waist, hip): perimeter of the convex hull of the horizontal section at
  the landmark's level, taking the section loop that encloses the body axis (arms and
  hands are separate loops at those levels and are left out);
* back length: from the back neck point down the centre back to the waist level, along
  the back-side convex hull of the centre-back profile (the tape bridges the lumbar
  hollow);
* shoulder length: side neck point to shoulder point over the shoulder ridge (section by
  the vertical plane through both points, outer hull chain);
* back width: across the back at the back-width level (half the armscye depth below the
  nape, Aldrich) between the back armhole creases, outer hull chain;
* shoulder width: shoulder point to shoulder point over the back neck point (section by
  the plane through the three points, outer hull chain).

Inputs are metres; results are centimetres (the user-facing unit).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from sandbox.errors import SandboxError


def section_polylines(
    vertices: np.ndarray, triangles: np.ndarray, origin, normal
) -> list[tuple[np.ndarray, bool]]:
    """Cut a triangle mesh by a plane: list of (points (k, 3), closed) polylines [m].

    Vertices on the plane count as above it (a consistent perturbation), so a plane through
    a row of vertices returns exactly that row.
    """
    normal = np.asarray(normal, float)
    d = (vertices - np.asarray(origin, float)) @ normal
    above = d >= 0.0
    fa = above[triangles]
    n_above = fa.sum(axis=1)
    cut = (n_above > 0) & (n_above < 3)
    tri = triangles[cut]
    if len(tri) == 0:
        return []
    fa = fa[cut]
    e0 = np.stack([tri[:, 0], tri[:, 1], tri[:, 2]], axis=1)
    e1 = np.stack([tri[:, 1], tri[:, 2], tri[:, 0]], axis=1)
    crosses = fa != np.roll(fa, -1, axis=1)  # edge k = (vk, vk+1)
    rows = np.nonzero(crosses)[0]
    a = e0[crosses]
    b = e1[crosses]
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = lo.astype(np.int64) * len(vertices) + hi
    uniq, node = np.unique(key, return_inverse=True)
    ulo, uhi = uniq // len(vertices), uniq % len(vertices)
    t = d[ulo] / (d[ulo] - d[uhi])
    pts = vertices[ulo] + t[:, None] * (vertices[uhi] - vertices[ulo])
    seg = node.reshape(-1, 2) if len(rows) == 2 * len(tri) else None
    if seg is None:
        raise SandboxError("mesh section: a triangle crossed the plane an odd number of times")
    # adjacency: each node has one or two segments (two on a closed surface)
    ends = seg.ravel()
    other = seg[:, ::-1].ravel()
    order = np.argsort(ends, kind="stable")
    ends, other = ends[order], other[order]
    first = np.searchsorted(ends, np.arange(len(uniq)))
    fill = np.bincount(ends, minlength=len(uniq))
    if np.any(fill > 2):
        raise SandboxError("mesh section: the mesh is not manifold along the cut")
    nbr = np.full((len(uniq), 2), -1)
    nbr[:, 0] = other[first]
    two = fill == 2
    nbr[two, 1] = other[first[two] + 1]
    seen = np.zeros(len(uniq), bool)
    out = []
    starts = list(np.nonzero(fill == 1)[0]) + list(range(len(uniq)))
    for start in starts:
        if seen[start]:
            continue
        chain = [start]
        seen[start] = True
        prev, cur = -1, start
        while True:
            nxt = nbr[cur, 0] if nbr[cur, 0] != prev else nbr[cur, 1]
            if nxt < 0 or seen[nxt]:
                closed = nxt >= 0 and nxt == start
                break
            chain.append(nxt)
            seen[nxt] = True
            prev, cur = cur, nxt
        out.append((pts[chain], bool(closed and len(chain) > 2)))
    return out


def _plane_basis(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = normal / np.linalg.norm(normal)
    helper = np.array([0.0, 1.0, 0.0]) if abs(n[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(helper, n)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(n, e1)


def _inside(poly2: np.ndarray, p: np.ndarray) -> bool:
    """Even-odd point-in-polygon test for a closed 2D polygon (k, 2)."""
    x, y = poly2[:, 0], poly2[:, 1]
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    cond = (y > p[1]) != (y1 > p[1])
    with np.errstate(divide="ignore", invalid="ignore"):
        xi = x + (p[1] - y) * (x1 - x) / (y1 - y)
    return bool(np.count_nonzero(cond & (p[0] < xi)) % 2)


def girth_at(vertices, triangles, y: float, axis_xz=(0.0, 0.0)) -> float:
    """Tape girth [m] at height ``y``: hull perimeter of the loop around the body axis."""
    loops = section_polylines(vertices, triangles, (0.0, y, 0.0), (0.0, 1.0, 0.0))
    best = None
    for pts, closed in loops:
        if closed and len(pts) >= 3 and _inside(pts[:, [0, 2]], np.asarray(axis_xz)):
            area = _hull(pts[:, [0, 2]])
            if area is not None and (best is None or area.volume > best.volume):
                best = area
    if best is None:
        raise SandboxError(f"tape measure: no section around the body axis at y = {y:.3f} m")
    return float(best.area)


def _hull(p2: np.ndarray):
    try:
        return ConvexHull(p2)
    except QhullError:
        return None


def _arc(pts: np.ndarray, closed: bool, i: int, j: int, via: np.ndarray) -> np.ndarray:
    """Sub-polyline from index i to j; for closed loops the arc passing nearest ``via``."""
    if not closed:
        lo, hi = sorted((i, j))
        return pts[lo : hi + 1]
    n = len(pts)
    fwd = pts[np.arange(i, i + ((j - i) % n) + 1) % n]
    bwd = pts[np.arange(j, j + ((i - j) % n) + 1) % n]
    dist_f = np.min(np.linalg.norm(fwd - via, axis=1))
    dist_b = np.min(np.linalg.norm(bwd - via, axis=1))
    return fwd if dist_f <= dist_b else bwd


def hull_chain_length(arc2: np.ndarray, outward: np.ndarray) -> float:
    """Length [m] of a tape laid over a 2D arc from its first to its last point.

    The tape follows the convex hull of the arc on the ``outward`` side: the hull chain
    between the two end points whose vertices lie further along ``outward``.
    """
    if len(arc2) < 3:
        return float(np.linalg.norm(arc2[-1] - arc2[0]))
    hull = _hull(arc2)
    if hull is None:
        return float(np.sum(np.linalg.norm(np.diff(arc2, axis=0), axis=1)))
    hv = list(hull.vertices)  # counter-clockwise
    ends = [0, len(arc2) - 1]
    for k in range(2):
        if ends[k] not in hv:  # end point inside the hull: use the nearest hull vertex
            near = hv[int(np.argmin(np.linalg.norm(arc2[hv] - arc2[ends[k]], axis=1)))]
            ends[k] = near
    a, b = hv.index(ends[0]), hv.index(ends[1])
    n = len(hv)
    chain1 = [hv[(a + k) % n] for k in range((b - a) % n + 1)]
    chain2 = [hv[(b + k) % n] for k in range((a - b) % n + 1)]

    # the chains lie on either side of the chord: take the one bulging to ``outward``
    # (a chain that is just the chord scores 0; the mean over all vertices is not robust
    # when the outer chain's vertices crowd at its low end)
    chord = arc2[ends[1]] - arc2[ends[0]]
    normal = np.array([-chord[1], chord[0]])
    side = float(normal @ outward)
    if abs(side) > 0.1 * np.linalg.norm(normal) * np.linalg.norm(outward):
        normal *= np.sign(side)

        def score(chain):
            inner = chain[1:-1]
            return float(np.max((arc2[inner] - arc2[ends[0]]) @ normal)) if inner else 0.0
    else:

        def score(chain):
            return float(np.mean(arc2[chain] @ outward))

    chain = chain1 if score(chain1) >= score(chain2) else chain2
    p = arc2[chain]
    return float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))


def surface_tape(
    vertices, triangles, p: np.ndarray, q: np.ndarray, normal: np.ndarray, via, outward
) -> float:
    """Tape length [m] from ``p`` to ``q`` in the plane through ``p`` with ``normal``.

    The section arc between the points nearest ``p`` and ``q`` that passes nearest ``via``
    is measured along its outer hull chain (``outward`` 3D direction).
    """
    p, q = np.asarray(p, float), np.asarray(q, float)
    polys = section_polylines(vertices, triangles, p, normal)
    best = None
    for pts, closed in polys:
        dp = np.linalg.norm(pts - p, axis=1)
        dq = np.linalg.norm(pts - q, axis=1)
        err = dp.min() + dq.min()
        if best is None or err < best[0]:
            best = (err, pts, closed, int(dp.argmin()), int(dq.argmin()))
    if best is None or best[0] > 0.02:
        raise SandboxError("tape measure: the section does not pass through the landmarks")
    _, pts, closed, i, j = best
    arc = _arc(pts, closed, i, j, np.asarray(via, float))
    arc = np.concatenate([p[None], arc, q[None]])
    e1, e2 = _plane_basis(np.asarray(normal, float))
    arc2 = np.stack([arc @ e1, arc @ e2], axis=1)
    out2 = np.array([np.dot(outward, e1), np.dot(outward, e2)])
    return hull_chain_length(arc2, out2)


def back_length(vertices, triangles, back_neck, waist_y: float) -> float:
    """Nape to waist [m] over the centre-back profile (sagittal plane through the nape)."""
    back_neck = np.asarray(back_neck, float)
    polys = section_polylines(vertices, triangles, back_neck, (1.0, 0.0, 0.0))
    best = None
    for pts, closed in polys:
        err = np.linalg.norm(pts - back_neck, axis=1).min()
        if best is None or err < best[0]:
            best = (err, pts, closed)
    if best is None or best[0] > 0.02:
        raise SandboxError("tape measure: no centre-back profile through the back neck point")
    _, pts, closed = best
    i = int(np.argmin(np.linalg.norm(pts - back_neck, axis=1)))
    # waist point: on the back (z below the nape's section centre) at the waist level
    cand = np.nonzero(np.abs(pts[:, 1] - waist_y) < 0.03)[0]
    if len(cand) == 0:
        raise SandboxError("tape measure: the centre-back profile does not reach the waist")
    back_side = cand[np.argsort(pts[cand, 2])[: max(1, len(cand) // 2)]]
    j = int(back_side[np.argmin(np.abs(pts[back_side, 1] - waist_y))])
    via = np.array([back_neck[0], 0.5 * (back_neck[1] + waist_y), pts[:, 2].min()])
    arc = _arc(pts, closed, i, j, via)
    arc2 = arc[:, [2, 1]]
    return hull_chain_length(arc2, np.array([-1.0, 0.0]))


def measure(vertices: np.ndarray, triangles: np.ndarray, landmarks: dict | None = None) -> dict:
    """The seven measurements [cm] of a closed body mesh (metres, Y up, front +Z).

    ``landmarks`` maps names to points (3,) [m]: ``bust_point_left/right``,
    ``waist_front``, ``hip_front``, ``back_neck_point``, ``side_neck_point_left``,
    ``shoulder_point_left/right``, ``back_armhole_point_left/right``. Without landmarks
    they are detected (:func:`sandbox.mannequin.landmarks.detect_landmarks`).
    """
    v = np.asarray(vertices, float)
    f = np.asarray(triangles, np.int64)
    if landmarks is None:
        from sandbox.mannequin.landmarks import detect_landmarks

        landmarks = detect_landmarks(v, f)
    lm = {k: np.asarray(p, float) for k, p in landmarks.items()}
    axis = (
        0.5 * (lm["waist_front"][0] + lm["waist_back"][0]),
        0.5 * (lm["waist_front"][2] + lm["waist_back"][2]),
    )
    bust_y = 0.5 * (lm["bust_point_left"][1] + lm["bust_point_right"][1])
    out = {
        "bust_girth": girth_at(v, f, bust_y, axis),
        "waist_girth": girth_at(v, f, float(lm["waist_front"][1]), axis),
        "hip_girth": girth_at(v, f, float(lm["hip_front"][1]), axis),
    }
    out.update(upper_body_measures(v, f, lm))
    out["back_length"] = back_length(v, f, lm["back_neck_point"], float(lm["waist_back"][1]))
    return {k: 100.0 * val for k, val in out.items()}


def upper_body_measures(v: np.ndarray, f: np.ndarray, lm: dict) -> dict:
    """Shoulder width, back width and shoulder length [m] from landmarks (3,) [m]."""
    spl, spr = lm["shoulder_point_left"], lm["shoulder_point_right"]
    bnp = lm["back_neck_point"]
    snp = lm["side_neck_point_left"]
    up = np.array([0.0, 1.0, 0.0])
    back = np.array([0.0, 0.0, -1.0])
    n_sw = np.cross(spr - spl, bnp - spl)
    shoulder_width = surface_tape(v, f, spl, spr, n_sw, bnp, back + 0.5 * up)
    n_sl = np.cross(spl - snp, up)
    shoulder_length = surface_tape(v, f, snp, spl, n_sl, 0.5 * (snp + spl) + 0.01 * up, up)
    bl, br = lm["back_armhole_point_left"], lm["back_armhole_point_right"]
    mid = np.array([0.0, 0.5 * (bl[1] + br[1]), min(bl[2], br[2]) - 0.1])
    back_width = surface_tape(v, f, bl, br, up, mid, back)
    return {
        "shoulder_width": shoulder_width,
        "back_width": back_width,
        "shoulder_length": shoulder_length,
    }
