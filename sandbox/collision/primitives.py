"""Geometric primitives for cloth contact (Bridson, Fedkiw and Anderson 2002, §6-7).

Taichi functions on 3-vectors, shared by the body collider and the self-collision pass:

* :func:`point_triangle_closest`: the closest point of a triangle to a point, with its
  barycentric weights (used for proximity and for distributing impulses);
* :func:`segment_segment_closest`: closest points of two segments, as parameters;
* :func:`coplanar_times`: the times in [0, 1] at which four linearly moving points become
  coplanar (the cubic of §6.1), the candidates for a continuous collision.
"""

import taichi as ti


@ti.func
def point_triangle_closest(p, a, b, c):
    """Barycentric weights (wa, wb, wc) of the point of triangle abc closest to p.

    Ericson, Real-Time Collision Detection §5.1.5; the closest point is wa a + wb b + wc c.
    """
    ab = b - a
    ac = c - a
    ap = p - a
    d1 = ab.dot(ap)
    d2 = ac.dot(ap)
    w = ti.Vector([1.0, 0.0, 0.0])
    if not (d1 <= 0.0 and d2 <= 0.0):
        bp = p - b
        d3 = ab.dot(bp)
        d4 = ac.dot(bp)
        if d3 >= 0.0 and d4 <= d3:
            w = ti.Vector([0.0, 1.0, 0.0])
        else:
            vc = d1 * d4 - d3 * d2
            if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
                s = d1 / (d1 - d3)
                w = ti.Vector([1.0 - s, s, 0.0])
            else:
                cp = p - c
                d5 = ab.dot(cp)
                d6 = ac.dot(cp)
                if d6 >= 0.0 and d5 <= d6:
                    w = ti.Vector([0.0, 0.0, 1.0])
                else:
                    vb = d5 * d2 - d1 * d6
                    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
                        s = d2 / (d2 - d6)
                        w = ti.Vector([1.0 - s, 0.0, s])
                    else:
                        va = d3 * d6 - d5 * d4
                        if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
                            s = (d4 - d3) / ((d4 - d3) + (d5 - d6))
                            w = ti.Vector([0.0, 1.0 - s, s])
                        else:
                            denom = 1.0 / (va + vb + vc)
                            w = ti.Vector([1.0 - (vb + vc) * denom, vb * denom, vc * denom])
    return w


@ti.func
def segment_segment_closest(p0, p1, q0, q1):
    """Parameters (s, t) in [0, 1] of the closest points p0 + s (p1 − p0), q0 + t (q1 − q0).

    Ericson §5.1.9; degenerate (zero-length) segments are handled.
    """
    d1 = p1 - p0
    d2 = q1 - q0
    r = p0 - q0
    a = d1.dot(d1)
    e = d2.dot(d2)
    f = d2.dot(r)
    s = 0.0
    t = 0.0
    eps = 1e-30
    if a <= eps and e <= eps:
        s = 0.0
        t = 0.0
    elif a <= eps:
        t = ti.math.clamp(f / e, 0.0, 1.0)
    else:
        c = d1.dot(r)
        if e <= eps:
            s = ti.math.clamp(-c / a, 0.0, 1.0)
        else:
            b = d1.dot(d2)
            denom = a * e - b * b
            if denom > 1e-12 * a * e:
                s = ti.math.clamp((b * f - c * e) / denom, 0.0, 1.0)
            t = (b * s + f) / e
            if t < 0.0:
                t = 0.0
                s = ti.math.clamp(-c / a, 0.0, 1.0)
            elif t > 1.0:
                t = 1.0
                s = ti.math.clamp((b - c) / a, 0.0, 1.0)
    return s, t


@ti.func
def _cubic(c3, c2, c1, c0, t):
    return ((c3 * t + c2) * t + c1) * t + c0


@ti.func
def _bisect(c3, c2, c1, c0, lo, hi):
    f_lo = _cubic(c3, c2, c1, c0, lo)
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        f_mid = _cubic(c3, c2, c1, c0, mid)
        if (f_mid < 0.0) == (f_lo < 0.0):
            lo = mid
            f_lo = f_mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@ti.func
def coplanar_times(x1, x2, x3, x4, v1, v2, v3, v4):
    """Times t in [0, 1] at which x_i + t v_i (i = 1..4) are coplanar (§6.1).

    The condition (x21 + t v21) × (x31 + t v31) · (x41 + t v41) = 0 is a cubic in t.
    Returns up to three roots in increasing order as a 3-vector (unused entries 2.0),
    and their count.
    """
    a0, b0, c0 = x2 - x1, x3 - x1, x4 - x1
    a1, b1, c1 = v2 - v1, v3 - v1, v4 - v1
    # coefficients of (a0 + t a1) × (b0 + t b1) · (c0 + t c1)
    k3 = a1.cross(b1).dot(c1)
    k2 = a1.cross(b1).dot(c0) + (a0.cross(b1) + a1.cross(b0)).dot(c1)
    k1 = (a0.cross(b1) + a1.cross(b0)).dot(c0) + a0.cross(b0).dot(c1)
    k0 = a0.cross(b0).dot(c0)
    # split [0, 1] at the critical points (roots of 3 k3 t^2 + 2 k2 t + k1), then bisect
    # every interval whose ends differ in sign
    cuts = ti.Vector([0.0, 2.0, 2.0, 1.0])
    qa, qb, qc = 3.0 * k3, 2.0 * k2, k1
    if ti.abs(qa) > 1e-30:
        disc = qb * qb - 4.0 * qa * qc
        if disc > 0.0:
            sq = ti.sqrt(disc)
            r1 = (-qb - sq) / (2.0 * qa)
            r2 = (-qb + sq) / (2.0 * qa)
            cuts[1] = ti.min(r1, r2)
            cuts[2] = ti.max(r1, r2)
    elif ti.abs(qb) > 1e-30:
        cuts[1] = -qc / qb
    roots = ti.Vector([2.0, 2.0, 2.0])
    count = 0
    lo = 0.0
    for k in range(1, 4):
        hi = cuts[k]
        if hi > lo and hi <= 1.0 or k == 3:
            hi = ti.min(hi, 1.0)
            if hi > lo:
                f_lo = _cubic(k3, k2, k1, k0, lo)
                f_hi = _cubic(k3, k2, k1, k0, hi)
                if f_lo == 0.0:
                    if count < 3:
                        roots[count] = lo
                        count += 1
                elif (f_lo < 0.0) != (f_hi < 0.0):
                    if count < 3:
                        roots[count] = _bisect(k3, k2, k1, k0, lo, hi)
                        count += 1
                lo = hi
    if count < 3 and _cubic(k3, k2, k1, k0, 1.0) == 0.0:
        roots[count] = 1.0
        count += 1
    return roots, count
