"""Mesh a flat pattern piece into irregular triangles (paper §2.1: patterns as grids).

Coordinates are in the pattern plane, in metres. The boundary is first resampled so no
boundary edge is longer than the target edge length, then a quality constrained Delaunay
triangulation (Shewchuk's Triangle, through the ``triangle`` package) fills the inside with
a minimum angle and a maximum area that match the target edge length.
"""

from __future__ import annotations

import math

import numpy as np
import triangle as tr

from sandbox.errors import SandboxError

MIN_ANGLE_DEG = 28.0
DUPLICATE_TOLERANCE = 1e-9
"""Points closer than this fraction of the outline's size count as one point."""


def polygon_area(outline: np.ndarray) -> float:
    """Signed area [m^2] of a closed polygon (k, 2); positive when counter-clockwise."""
    x, y = outline[:, 0], outline[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def estimate_vertex_count(area_m2: float, perimeter_m: float, edge_length: float) -> float:
    """Vertices of a quality mesh of ``edge_length`` [m] over ``area_m2`` bounded by
    ``perimeter_m`` (within about 20 % of Triangle's count; inf when it overflows)."""
    h = np.float64(edge_length)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        n = 1.2 * abs(area_m2) / (h * h) + perimeter_m / h
    return float(n) if math.isfinite(n) else math.inf


def check_mesh_size(vertices: float, limit: int, where: str, what: str):
    """SandboxError when an estimated vertex count is over ``limit``."""
    if not vertices <= limit:
        count = "an overflowing number of" if math.isinf(vertices) else f"about {vertices:,.0f}"
        raise SandboxError(
            f"{where}: {what} would have {count} vertices, more than the limit of {limit:,} "
            "(PatternLimits.max_mesh_vertices): use a larger mesh edge"
        )


def triangulate(pslg: dict, switches: str, where: str) -> dict:
    """Shewchuk's Triangle on a checked planar straight line graph.

    ``pslg`` holds ``vertices`` (k, 2) and ``segments`` (s, 2). The caller has made sure the
    boundary is simple (no duplicate points, no crossings): Triangle can crash the process on
    such input. NaN or infinite coordinates and any failure of Triangle become a SandboxError
    naming ``where``. Returns Triangle's output: ``vertices`` (n, 2) float64, ``triangles``
    (m, 3) int64 and, when it gives them, ``segments``.
    """
    v = np.asarray(pslg["vertices"], dtype=np.float64)
    seg = np.asarray(pslg["segments"], dtype=np.int32)
    if v.ndim != 2 or v.shape[1] != 2 or len(v) < 3 or not np.all(np.isfinite(v)):
        raise SandboxError(f"{where}: the outline needs at least 3 finite points")
    if len(seg) and (seg.min() < 0 or seg.max() >= len(v) or np.any(seg[:, 0] == seg[:, 1])):
        raise SandboxError(f"{where}: a segment of the outline joins a point to itself")
    try:
        out = tr.triangulate({"vertices": v, "segments": seg}, switches)
    except Exception as exc:  # Triangle reports bad input as generic errors
        raise SandboxError(f"{where}: could not mesh the outline ({exc})") from None
    if "triangles" not in out or len(out["triangles"]) == 0:
        raise SandboxError(f"{where}: meshing produced no triangles")
    pts = np.asarray(out["vertices"], dtype=np.float64)
    tris = np.asarray(out["triangles"], dtype=np.int64)
    if not np.all(np.isfinite(pts)) or tris.min() < 0 or tris.max() >= len(pts):
        raise SandboxError(f"{where}: the mesher returned an invalid mesh")
    return {**out, "vertices": pts, "triangles": tris}


def clean_outline(outline: np.ndarray, where: str) -> np.ndarray:
    """The outline (k, 2) without repeated points (consecutive ones within
    DUPLICATE_TOLERANCE of its size, the last against the first), checked to be simple.

    Raises SandboxError for fewer than 3 distinct points, zero area, a fold back or a crossing
    (naming the two sides by their first point's index and where they meet).
    """
    from sandbox.pattern.crossing import (
        OutlineTooIntricate,
        crossing_point,
        first_crossing,
        on_one_line,
    )

    scale = float(np.ptp(outline, axis=0).max())
    tol = DUPLICATE_TOLERANCE * scale
    keep = np.linalg.norm(outline - np.roll(outline, 1, axis=0), axis=1) > tol
    index = np.flatnonzero(keep)  # the points that stay, by their index in the input
    if len(index) < 3:
        raise SandboxError(f"{where}: an outline needs at least 3 distinct points")
    pts = outline[index]
    area = polygon_area(pts)
    if not (math.isfinite(scale) and math.isfinite(area)):
        raise SandboxError(f"{where}: the outline's coordinates are too large ({scale:g} m across)")
    if on_one_line(pts, scale):
        raise SandboxError(f"{where}: outline has zero area (its points are on one line)")
    try:
        hit = first_crossing(pts, scale)
    except OutlineTooIntricate as exc:
        raise SandboxError(f"{where}: {exc}") from None
    if hit is not None:
        i, j = hit
        x, y = crossing_point(pts, i, j)
        a, b = (f"{index[k]}-{index[(k + 1) % len(index)]}" for k in (i, j))
        raise SandboxError(
            f"{where}: the outline crosses or touches itself: side {a} meets side {b} "
            f"(points by index) at ({x:.6g}, {y:.6g}) m"
        )
    if not abs(area) > 1e-12 * scale * scale or not abs(area) > 1e-30:
        raise SandboxError(f"{where}: outline has zero area")
    return pts


def resample_outline(outline: np.ndarray, edge_length: float) -> np.ndarray:
    """Split each polygon side into equal pieces no longer than ``edge_length``.

    Returns the new closed outline (k', 2) without repeating the first point.
    """
    pts = []
    k = len(outline)
    for i in range(k):
        a, b = outline[i], outline[(i + 1) % k]
        n = max(1, math.ceil(np.linalg.norm(b - a) / edge_length - 1e-9))
        for j in range(n):
            pts.append(a + (b - a) * (j / n))
    return np.asarray(pts, dtype=np.float64)


def mesh_polygon(
    outline,
    edge_length: float,
    *,
    where: str = "polygon",
    min_angle_deg: float = MIN_ANGLE_DEG,
    inner_segments=(),
    limits=None,
) -> tuple[np.ndarray, np.ndarray]:
    """Irregular quality mesh of a simple polygon.

    Args:
        outline: polygon corners (k, 2) [m], either orientation, not repeated at the end.
        edge_length: target edge length [m].
        where: names the input in error messages.
        inner_segments: straight segments ``((u0, v0), (u1, v1))`` inside the polygon that
            mesh edges must follow (for example a clamp line), resampled like the boundary.
        limits: a :class:`~sandbox.pattern.limits.PatternLimits` (its ``max_mesh_vertices``).

    Repeated points are dropped; a self-crossing outline, a zero-length or outside inner
    segment and a mesh over the vertex limit are SandboxErrors naming ``where``.

    Returns:
        ``(points (n, 2) float64 [m], triangles (m, 3) int64)``, triangles counter-clockwise.
    """
    outline = np.asarray(outline, dtype=np.float64)
    if outline.ndim != 2 or outline.shape[1] != 2 or len(outline) < 3:
        raise SandboxError(f"{where}: an outline needs at least 3 points [u, v]")
    if not np.all(np.isfinite(outline)):
        raise SandboxError(f"{where}: outline has a NaN or infinite coordinate")
    if not (edge_length > 0 and math.isfinite(edge_length)):
        raise SandboxError(f"{where}: edge length must be a positive number, got {edge_length}")
    with np.errstate(over="ignore", invalid="ignore"):  # too large is an error below
        outline = clean_outline(outline, where)
        area = polygon_area(outline)
        perimeter = float(np.linalg.norm(outline - np.roll(outline, 1, axis=0), axis=1).sum())
    from sandbox.pattern.limits import DEFAULT_LIMITS

    limit = (limits or DEFAULT_LIMITS).max_mesh_vertices
    vertex_estimate = estimate_vertex_count(area, perimeter, edge_length)
    check_mesh_size(vertex_estimate, limit, where, f"a {edge_length:g} m mesh of the outline")
    if area < 0:
        outline = outline[::-1]
    _check_inner_segments(outline, inner_segments, edge_length, where)
    boundary = resample_outline(outline, edge_length)
    k = len(boundary)
    segments = [np.stack([np.arange(k), (np.arange(k) + 1) % k], axis=1)]
    points = [boundary]
    tol = 1e-9 * float(np.ptp(boundary, axis=0).max())
    for seg in inner_segments:
        pts = _resample_segment(np.asarray(seg[0], float), np.asarray(seg[1], float), edge_length)
        all_pts = np.vstack(points)
        idx = []
        for q in pts:  # reuse an existing point (e.g. a boundary corner): no duplicates
            d = np.linalg.norm(all_pts - q, axis=1)
            j = int(np.argmin(d))
            if d[j] <= tol:
                idx.append(j)
            else:
                idx.append(len(all_pts))
                all_pts = np.vstack([all_pts, q])
                points.append(q[None, :])
        idx = np.asarray(idx)
        segments.append(np.stack([idx[:-1], idx[1:]], axis=1))
    boundary = np.vstack(points)
    segments = np.vstack(segments)
    max_area = math.sqrt(3.0) / 4.0 * edge_length**2 * 1.4
    switches = f"pq{min_angle_deg:g}a{np.format_float_positional(max_area, trim='-')}Q"
    out = triangulate({"vertices": boundary, "segments": segments}, switches, where)
    pts, tris = out["vertices"], out["triangles"]
    return spatial_order(pts, orient_ccw(pts, tris))


def _check_inner_segments(outline: np.ndarray, inner_segments, edge_length: float, where: str):
    """Each inner segment: finite, of non-zero length, inside the outline (ends on it
    allowed), and not so finely resampled that it exceeds the outline's own count."""
    scale = float(np.ptp(outline, axis=0).max())
    tol = 1e-7 * scale
    for k, seg in enumerate(inner_segments):
        ab = np.asarray(seg, dtype=np.float64)
        if ab.shape != (2, 2) or not np.all(np.isfinite(ab)):
            raise SandboxError(f"{where}: inner line {k} must be two finite points [[u0, v0], "
                               "[u1, v1]]")  # fmt: skip
        length = float(np.linalg.norm(ab[1] - ab[0]))
        if length <= DUPLICATE_TOLERANCE * scale:
            raise SandboxError(f"{where}: inner line {k} has zero length")
        inside = bool(np.all(_inside_or_on(outline, ab, tol)))  # ends first: bounds its length
        if not inside or not np.all(
            _inside_or_on(outline, _resample_segment(*ab, edge_length), tol)
        ):
            raise SandboxError(f"{where}: inner line {k} {ab.tolist()} leaves the outline")


def _inside_or_on(poly: np.ndarray, pts: np.ndarray, tol: float) -> np.ndarray:
    """(len(pts),) True where a point is inside the closed polygon or within tol of it."""
    a, b = poly, np.roll(poly, -1, axis=0)
    x, y = pts[:, 0:1], pts[:, 1:2]
    crosses = (a[None, :, 1] > y) != (b[None, :, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xs = a[None, :, 0] + (y - a[None, :, 1]) * (b[None, :, 0] - a[None, :, 0]) / (
            b[None, :, 1] - a[None, :, 1]
        )
    inside = np.sum(crosses & (x < xs), axis=1) % 2 == 1
    d = b - a
    dd = np.maximum((d * d).sum(-1), 1e-300)
    t = np.clip(((pts[:, None, :] - a[None]) * d[None]).sum(-1) / dd, 0.0, 1.0)
    near = np.linalg.norm(pts[:, None, :] - (a[None] + t[..., None] * d[None]), axis=-1) <= tol
    return inside | near.any(axis=1)


def spatial_order(points: np.ndarray, tris: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Renumber vertices along a Z-order (Morton) curve and sort triangles to match.

    Neighbouring vertices then sit near each other in memory, which makes the solver's
    gather loops several times faster than Triangle's own numbering. Geometry unchanged.
    """
    order = morton_order(points)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    tris = rank[tris]
    tris = tris[np.argsort(tris.min(axis=1), kind="stable")]
    return points[order], tris


def morton_order(points: np.ndarray) -> np.ndarray:
    """Permutation (n,) that sorts points (n, 2) along a Z-order (Morton) curve.

    ``points[order]`` is the order :func:`spatial_order` uses.
    """
    lo = points.min(axis=0)
    span = max(float(np.ptp(points, axis=0).max()), 1e-30)
    q = np.clip(((points - lo) / span * 65535.0).astype(np.int64), 0, 65535)
    key = _spread_bits(q[:, 0]) | (_spread_bits(q[:, 1]) << 1)
    return np.argsort(key, kind="stable")


def _spread_bits(v: np.ndarray) -> np.ndarray:
    v = v & 0xFFFF
    v = (v | (v << 8)) & 0x00FF00FF
    v = (v | (v << 4)) & 0x0F0F0F0F
    v = (v | (v << 2)) & 0x33333333
    return (v | (v << 1)) & 0x55555555


def mesh_grid(
    width: float, height: float, edge_length: float, *, alternate: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """Structured mesh of the rectangle [0, width] x [0, height].

    Each square is split by a diagonal, alternating in a checkerboard (``alternate``) or
    all the same way. Used by validation runs to separate mesh irregularity from other
    errors.
    """
    nx = max(1, round(width / edge_length))
    ny = max(1, round(height / edge_length))
    xs, ys = np.linspace(0.0, width, nx + 1), np.linspace(0.0, height, ny + 1)
    px, py = np.meshgrid(xs, ys, indexing="xy")
    pts = np.stack([px.ravel(), py.ravel()], axis=1)
    tris = []
    for j in range(ny):
        for i in range(nx):
            a, b = j * (nx + 1) + i, j * (nx + 1) + i + 1
            c, d = a + nx + 1, b + nx + 1
            if not alternate or (i + j) % 2 == 0:
                tris += [(a, b, d), (a, d, c)]
            else:
                tris += [(a, b, c), (b, d, c)]
    return pts, np.asarray(tris, dtype=np.int64)


def _resample_segment(a, b, edge_length):
    n = max(1, math.ceil(np.linalg.norm(b - a) / edge_length - 1e-9))
    return a + (b - a) * (np.arange(n + 1)[:, None] / n)


def orient_ccw(points: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Return ``tris`` with every triangle counter-clockwise in the plane."""
    p = points[tris]
    cross = (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (p[:, 1, 1] - p[:, 0, 1]) * (
        p[:, 2, 0] - p[:, 0, 0]
    )
    tris = tris.copy()
    flip = cross < 0
    tris[flip] = tris[flip][:, [0, 2, 1]]
    return tris


def min_angle_deg(points: np.ndarray, tris: np.ndarray) -> float:
    """Smallest interior angle [deg] over all triangles."""
    p = points[tris]
    angles = []
    for i in range(3):
        a = p[:, (i + 1) % 3] - p[:, i]
        b = p[:, (i + 2) % 3] - p[:, i]
        cosang = np.sum(a * b, axis=1) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
        angles.append(np.degrees(np.arccos(np.clip(cosang, -1, 1))))
    return float(np.min(angles))
