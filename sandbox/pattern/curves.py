"""Pattern edge curves: straight lines, circular arcs (by sagitta), quadratic and cubic Béziers.

Every function takes the edge's end points ``p0``, ``p1`` (2,) [m] and the curve's parameters
in metres, in the same panel coordinates:

* ``"line"``: no parameter;
* ``"arc"``: ``sagitta`` [m], the signed height of the arc's midpoint over the chord, positive
  to the LEFT of p0 -> p1 (|sagitta| > chord/2 is a larger-than-half circle; 0 is a line);
* ``"quadratic"``: one control point (1, 2) [m];
* ``"cubic"``: two control points (2, 2) [m].

:func:`sample_curve` turns an edge into a polyline whose points are evenly spaced by arc
length, no segment longer than a target length; :func:`curve_length` is its exact arc length
(closed form for lines and arcs, Gauss-Legendre quadrature for Béziers).
"""

from __future__ import annotations

import math

import numpy as np

KINDS = ("line", "arc", "quadratic", "cubic")

_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)
_BEZIER_PANELS = 256  # arc-length table resolution of a Bézier (each panel: 8-point Gauss)


def _bezier_nodes(p0, p1, controls) -> np.ndarray:
    """Control polygon (d + 1, 2): start, controls..., end."""
    return np.vstack([np.asarray(p0, float), np.asarray(controls, float).reshape(-1, 2), p1])


def bezier_point(nodes: np.ndarray, t) -> np.ndarray:
    """Points (len(t), 2) of the Bézier with control polygon ``nodes`` (d + 1, 2) at ``t``."""
    t = np.atleast_1d(np.asarray(t, float))[:, None]
    d = len(nodes) - 1
    out = np.zeros((len(t), 2))
    for i in range(d + 1):
        out += math.comb(d, i) * (1 - t) ** (d - i) * t**i * nodes[i]
    return out


def bezier_speed(nodes: np.ndarray, t) -> np.ndarray:
    """|B'(t)| (len(t),) [m per unit t]."""
    t = np.atleast_1d(np.asarray(t, float))[:, None]
    d = len(nodes) - 1
    diff = d * np.diff(nodes, axis=0)
    out = np.zeros((len(t), 2))
    for i in range(d):
        out += math.comb(d - 1, i) * (1 - t) ** (d - 1 - i) * t**i * diff[i]
    return np.linalg.norm(out, axis=1)


def _bezier_table(nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Parameter grid (N+1,) and cumulative arc length (N+1,) [m] at those parameters."""
    tg = np.linspace(0.0, 1.0, _BEZIER_PANELS + 1)
    a, b = tg[:-1], tg[1:]
    half = 0.5 * (b - a)
    ts = (0.5 * (a + b))[:, None] + half[:, None] * _GL_X[None, :]
    speed = bezier_speed(nodes, ts.ravel()).reshape(ts.shape)
    panel = half * (speed @ _GL_W)
    return tg, np.concatenate([[0.0], np.cumsum(panel)])


def _bezier_params_at_lengths(nodes: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Parameters t with arc length s from the start (Newton on the quadrature table)."""
    tg, cum = _bezier_table(nodes)
    t = np.interp(s, cum, tg)
    for _ in range(4):  # Newton: L(t) - s = 0, L'(t) = |B'(t)|
        j = np.clip(np.searchsorted(tg, t, side="right") - 1, 0, len(tg) - 2)
        a = tg[j]
        half = 0.5 * (t - a)
        ts = (0.5 * (a + t))[:, None] + half[:, None] * _GL_X[None, :]
        part = half * (bezier_speed(nodes, ts.ravel()).reshape(ts.shape) @ _GL_W)
        err = cum[j] + part - s
        speed = np.maximum(bezier_speed(nodes, t), 1e-300)
        t = np.clip(t - err / speed, 0.0, 1.0)
    return t


def arc_geometry(p0, p1, sagitta: float) -> tuple[np.ndarray, float, float, float]:
    """Circle of an arc: ``(centre (2,), radius, start angle, signed sweep)`` [m, rad].

    The sweep is negative (clockwise) for a positive sagitta (the arc bulges to the left of
    p0 -> p1). Central angle θ = 4 atan(2|s|/c) for chord c, radius r = (c²/4 + s²) / (2|s|).
    """
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    d = p1 - p0
    c = float(np.linalg.norm(d))
    s = float(sagitta)
    left = np.array([-d[1], d[0]]) / c
    r = (0.25 * c * c + s * s) / (2.0 * abs(s))
    centre = 0.5 * (p0 + p1) + (s - math.copysign(r, s)) * left
    theta = 4.0 * math.atan(2.0 * abs(s) / c)
    phi0 = math.atan2(p0[1] - centre[1], p0[0] - centre[0])
    return centre, r, phi0, -math.copysign(theta, s)


def curve_length(kind: str, p0, p1, *, sagitta: float = 0.0, controls=()) -> float:
    """Arc length [m] of an edge (see the module docstring for the parameters)."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    chord = float(np.linalg.norm(p1 - p0))
    if kind == "line" or (kind == "arc" and sagitta == 0.0):
        return chord
    if kind == "arc":
        _, r, _, sweep = arc_geometry(p0, p1, sagitta)
        return r * abs(sweep)
    if kind in ("quadratic", "cubic"):
        return float(_bezier_table(_bezier_nodes(p0, p1, controls))[1][-1])
    raise ValueError(f"unknown curve kind {kind!r}; known: {', '.join(KINDS)}")


def points_at_lengths(
    kind: str, p0, p1, s, *, sagitta: float = 0.0, controls=(), length: float | None = None
) -> np.ndarray:
    """Points (len(s), 2) [m] at arc lengths ``s`` [m] from p0 along the edge (0 <= s <= L)."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    if length is None:
        length = curve_length(kind, p0, p1, sagitta=sagitta, controls=controls)
    u = np.asarray(s, float) / length
    if kind == "line" or (kind == "arc" and sagitta == 0.0):
        return p0 + (p1 - p0) * u[:, None]
    if kind == "arc":
        centre, r, phi0, sweep = arc_geometry(p0, p1, sagitta)
        ang = phi0 + sweep * u
        return centre + r * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    nodes = _bezier_nodes(p0, p1, controls)
    return bezier_point(nodes, _bezier_params_at_lengths(nodes, u * length))


def sample_curve(
    kind: str, p0, p1, max_segment_m: float, *, sagitta: float = 0.0, controls=()
) -> np.ndarray:
    """Polyline (k+1, 2) [m] from p0 to p1 (both included, exactly), evenly spaced by arc length.

    k = ceil(L / max_segment_m), so every segment (a chord of an arc piece of length L / k) is
    at most ``max_segment_m`` long.
    """
    if not (max_segment_m > 0 and math.isfinite(max_segment_m)):
        raise ValueError(f"max_segment_m must be positive, got {max_segment_m}")
    length = curve_length(kind, p0, p1, sagitta=sagitta, controls=controls)
    k = max(1, math.ceil(length / max_segment_m - 1e-9))
    s = length * np.linspace(0.0, 1.0, k + 1)
    return _exact_ends(
        points_at_lengths(kind, p0, p1, s, sagitta=sagitta, controls=controls, length=length),
        p0,
        p1,
    )


def sample_curve_graded(
    kind: str, p0, p1, max_segment_m: float, start_m: float, end_m: float, *,
    growth: float = 0.2, sagitta: float = 0.0, controls=(),
) -> np.ndarray:  # fmt: skip
    """Like :func:`sample_curve`, but segments shrink towards shorter neighbours at the ends.

    The target spacing along the edge is h(s) = min(h, start_m + growth s, end_m +
    growth (L - s)) with h the even spacing of :func:`sample_curve`; points are placed at
    equal steps of ∫ ds / h. When neither end needs a shorter segment the result is exactly
    :func:`sample_curve`'s. Every segment is at most ``max_segment_m`` long.
    """
    length = curve_length(kind, p0, p1, sagitta=sagitta, controls=controls)
    k = max(1, math.ceil(length / max_segment_m - 1e-9))
    h = length / k
    if start_m >= h * (1 - 1e-9) and end_m >= h * (1 - 1e-9):
        return sample_curve(kind, p0, p1, max_segment_m, sagitta=sagitta, controls=controls)
    grid = np.linspace(0.0, length, 4097)
    size = np.minimum(h, np.minimum(start_m + growth * grid, end_m + growth * (length - grid)))
    inv = 1.0 / size
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (inv[1:] + inv[:-1]) * np.diff(grid))])
    n = max(1, math.ceil(cum[-1] - 1e-9))
    s = np.interp(np.linspace(0.0, cum[-1], n + 1), cum, grid)
    pts = points_at_lengths(kind, p0, p1, s, sagitta=sagitta, controls=controls, length=length)
    return _exact_ends(pts, p0, p1)


def _exact_ends(pts: np.ndarray, p0, p1) -> np.ndarray:
    pts[0], pts[-1] = p0, p1  # exact shared corners
    return pts


def sample_edge(edge, max_segment_m: float) -> np.ndarray:
    """:func:`sample_curve` for a :class:`sandbox.pattern.spec.Edge`."""
    return sample_curve(
        edge.kind,
        edge.p0_m,
        edge.p1_m,
        max_segment_m,
        sagitta=edge.sagitta_m,
        controls=edge.controls_m,
    )


def edge_length(edge) -> float:
    """:func:`curve_length` [m] of a :class:`sandbox.pattern.spec.Edge`."""
    return curve_length(
        edge.kind, edge.p0_m, edge.p1_m, sagitta=edge.sagitta_m, controls=edge.controls_m
    )
