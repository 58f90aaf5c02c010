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


def polygon_area(outline: np.ndarray) -> float:
    """Signed area [m^2] of a closed polygon (k, 2); positive when counter-clockwise."""
    x, y = outline[:, 0], outline[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


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
) -> tuple[np.ndarray, np.ndarray]:
    """Irregular quality mesh of a simple polygon.

    Args:
        outline: polygon corners (k, 2) [m], either orientation, not repeated at the end.
        edge_length: target edge length [m].
        where: names the input in error messages.
        inner_segments: straight segments ``((u0, v0), (u1, v1))`` inside the polygon that
            mesh edges must follow (for example a clamp line), resampled like the boundary.

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
    area = polygon_area(outline)
    if abs(area) < 1e-12:
        raise SandboxError(f"{where}: outline has zero area")
    if area < 0:
        outline = outline[::-1]
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
    try:
        out = tr.triangulate(
            {"vertices": boundary, "segments": segments},
            f"pq{min_angle_deg:g}a{max_area:.15f}Q",
        )
    except Exception as exc:  # Triangle reports self-intersections as generic errors
        raise SandboxError(f"{where}: could not mesh the outline ({exc})") from None
    if "triangles" not in out or len(out["triangles"]) == 0:
        raise SandboxError(f"{where}: meshing produced no triangles (self-intersecting outline?)")
    pts = np.asarray(out["vertices"], dtype=np.float64)
    tris = np.asarray(out["triangles"], dtype=np.int64)
    return spatial_order(pts, orient_ccw(pts, tris))


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
