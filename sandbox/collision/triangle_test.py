"""Exact intersection test of closed triangles in float64, vectorised over pairs: edge
against triangle, with coplanar and degenerate cases handled separately. Distances below a
tolerance (default :data:`TOLERANCE_REL` times the bounding-box diagonal) count as zero, so
triangles that touch count as intersecting (``docs/collision_metrics.md``)."""

from __future__ import annotations

import numpy as np

from sandbox.errors import SandboxError

TOLERANCE_REL = 1e-10  # triangle test: distances below this x bbox diagonal are zero


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


def triangles_meet(A: np.ndarray, B: np.ndarray, eps: float) -> np.ndarray:
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


def pair_tolerance(vertices: np.ndarray, tolerance_m: float | None) -> float:
    if tolerance_m is None:
        if len(vertices) == 0:
            return 0.0
        return TOLERANCE_REL * float(np.linalg.norm(vertices.max(0) - vertices.min(0)))
    if not np.isfinite(tolerance_m) or tolerance_m < 0:
        raise SandboxError(f"triangle intersection tolerance_m must be >= 0, got {tolerance_m}")
    return float(tolerance_m)
