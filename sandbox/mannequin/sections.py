"""Cross-sections of the control net: torso rings, limb ellipses, the neck base.

Each function returns points of one key row in metres. Torso rings are sampled at the
fixed torso column angles (centre front at angle 0, body left (+x) at pi/2), so the
columns of every ring are the same feature columns (centre lines, princess lines, side
seams).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import ConvexHull


def hull_perimeter(xz: np.ndarray) -> float:
    """Tape-measure girth of 2D points (k, 2) [m]: perimeter of their convex hull."""
    return float(ConvexHull(xz).area)


def superellipse(
    angles: np.ndarray, half_width: float, front: float, back: float, exponent: float
) -> np.ndarray:
    """Points (n, 2) as (x, z) of a superellipse with different front/back half-depths."""
    s, c = np.sin(angles), np.cos(angles)
    e = 2.0 / exponent
    x = half_width * np.sign(s) * np.abs(s) ** e
    depth = np.where(c >= 0.0, front, back)
    z = depth * np.sign(c) * np.abs(c) ** e
    return np.stack([x, z], axis=1)


def breasts(angles: np.ndarray, prominence: float, apex_angle: float) -> np.ndarray:
    """Radial bulge (n,) [m] of two breasts centred at +-``apex_angle`` from centre front."""
    width = 0.36
    return prominence * (
        np.exp(-(((angles - apex_angle) / width) ** 2))
        + np.exp(-(((angles + apex_angle) / width) ** 2))
        + np.exp(-(((angles - 2 * math.pi + apex_angle) / width) ** 2))
    )


def torso_ring(
    angles: np.ndarray,
    *,
    girth: float | None,
    y: float,
    proportions: tuple[float, float, float, float],
    z_centre: float = 0.0,
    bulge: np.ndarray | None = None,
    half_width: float | None = None,
) -> np.ndarray:
    """One horizontal torso ring (n, 3) at height ``y``.

    ``proportions`` = (front depth / width, back depth / width, exponent, unused); the ring
    is scaled so that its convex-hull perimeter equals ``girth`` (exact), or, if ``girth``
    is None, to the given ``half_width``.
    """
    fr, bk, ex, _ = proportions
    xz = superellipse(angles, 1.0, fr, bk, ex)
    if bulge is not None:
        radial = xz / np.maximum(np.linalg.norm(xz, axis=1, keepdims=True), 1e-12)
        scale0 = half_width if girth is None else girth / hull_perimeter(xz)
        xz = xz + radial * (bulge / scale0)[:, None]
    scale = half_width if girth is None else girth / hull_perimeter(xz)
    xz = xz * scale
    out = np.empty((len(angles), 3))
    out[:, 0] = xz[:, 0]
    out[:, 1] = y
    out[:, 2] = xz[:, 1] + z_centre
    return out


def ellipse_perimeter(a: float, b: float) -> float:
    """Ramanujan's approximation of an ellipse perimeter [m]."""
    h = ((a - b) / (a + b)) ** 2
    return math.pi * (a + b) * (1 + 3 * h / (10 + math.sqrt(4 - 3 * h)))


def limb_ring(
    centre: np.ndarray,
    u: np.ndarray,
    v: np.ndarray,
    angles: np.ndarray,
    girth: float,
    aspect: float,
) -> np.ndarray:
    """Ellipse (n, 3) of perimeter ``girth`` around ``centre`` in the plane of unit ``u, v``.

    ``aspect`` = radius along ``u`` / radius along ``v``; point j is at
    ``centre + ru cos(angles_j) u + rv sin(angles_j) v``.
    """
    rv = girth / ellipse_perimeter(aspect, 1.0)
    ru = aspect * rv
    return (
        centre[None, :]
        + (ru * np.cos(angles))[:, None] * u[None, :]
        + (rv * np.sin(angles))[:, None] * v[None, :]
    )
