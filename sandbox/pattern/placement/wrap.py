"""Panel points wrapped round a body part's placement surface, or laid flat in front of it.

Rows of the panel at fixed heights (:attr:`PlacementConfig.row_m`) are laid along the
section hull at that height, offset by the clearance and further where the panel is too wide
for its sector; see :mod:`sandbox.pattern.placement`.
"""

from __future__ import annotations

import math

import numpy as np

from sandbox.pattern.placement.body import BodyFrame, Curve, PlacementBody
from sandbox.pattern.placement.config import PlacementConfig


def wrap_panel(body: PlacementBody, frame: BodyFrame, theta: float, s, h, clearance: float,
               before: float, after: float) -> np.ndarray:  # fmt: skip
    """World positions (n, 3) [m] of panel points wrapped round a body part.

    ``s`` (n,) [m]: arc length from the anchor line (towards increasing angle); ``h`` (n,)
    [m]: height along the axis of ``frame``; the anchor line lies at angle ``theta``
    [rad] and the panel may use ``before`` and ``after`` [rad] on either side of it. Rows,
    offsets and slopes follow ``body.config``.
    """
    cfg = body.config
    # rows on a fixed grid of heights (shared by all panels: the curves are cached)
    first, last = math.floor(float(h.min()) / cfg.row_m), math.ceil(float(h.max()) / cfg.row_m)
    last = max(last, first + 1)
    rows = cfg.row_m * np.arange(first, last + 1)
    nb, lo, step = len(rows), float(rows[0]), cfg.row_m
    # the panel's width either side of the anchor line, per row
    k = np.clip(np.rint((h - lo) / step).astype(int), 0, nb - 1)
    need_after = np.full(nb, -np.inf)
    need_before = np.full(nb, -np.inf)
    np.maximum.at(need_after, k, s)
    np.maximum.at(need_before, k, -s)
    for arr in (need_after, need_before):  # rows without a vertex: their neighbours
        good = np.isfinite(arr)
        arr[~good] = np.interp(rows[~good], rows[good], arr[good])
    need_after = dilate(need_after * cfg.fit_margin, 2)
    need_before = dilate(need_before * cfg.fit_margin, 2)
    curves, extras = [], np.zeros(nb)
    for j, hr in enumerate(rows):
        c = body.curve(frame, hr, clearance)
        extra = 0.0
        for _ in range(3):  # grow the offset until the row fits its sector
            s0 = c.arc_at_angle(theta)
            room_after = np.mod(c.arc_at_angle(theta + after) - s0, c.length)
            room_before = np.mod(s0 - c.arc_at_angle(theta - before), c.length)
            short = max(need_after[j] - room_after, need_before[j] - room_before)
            if short <= 1e-4:
                break
            extra += short / max(min(before, after), 0.2)
            c = body.curve(frame, hr, clearance + extra)
        curves.append(c)
        extras[j] = extra
    # below a wide row, no row falls back towards the body faster than cfg.max_offset_slope
    drop = rows[None, :] - rows[:, None]  # [j, k]: how far row k is above row j
    slope = cfg.max_offset_slope
    envelope = np.max(np.where(drop >= 0, extras[None, :] - slope * drop, 0.0), axis=1)
    for j in np.nonzero(envelope > extras + 1e-4)[0]:
        curves[j] = body.curve(frame, rows[j], clearance + envelope[j])
    curves = _hang(curves, cfg)
    starts = [c.arc_at_angle(theta) for c in curves]
    f = np.clip((h - lo) / step, 0, nb - 1)
    k0 = np.minimum(np.floor(f).astype(int), nb - 2)
    w = (f - k0)[:, None]
    uw = np.zeros((len(h), 2))
    for j in np.unique(np.concatenate([k0, k0 + 1])):
        for sel, wt in ((k0 == j, 1.0 - w), (k0 + 1 == j, w)):
            if sel.any():
                uw[sel] += wt[sel] * curves[j].point_at_arc(starts[j] + s[sel])
    return frame.world(h, uw)


def _hang(curves: list[Curve], cfg: PlacementConfig) -> list[Curve]:
    """Rows (bottom to top) whose curve comes in faster than ``cfg.shrink_slope`` below the
    rows above it, in any direction, pushed out to that slope (star-shaped polygons)."""
    phi = np.linspace(-math.pi, math.pi, cfg.radial_samples, endpoint=False)
    ray = np.stack([np.cos(phi), np.sin(phi)], 1)
    radius = np.array([np.linalg.norm(c.point_at_arc(c.arcs_at_angles(phi)), axis=1)
                       for c in curves])  # fmt: skip
    hung = radius.copy()
    for j in range(len(curves) - 2, -1, -1):
        hung[j] = np.maximum(radius[j], hung[j + 1] - cfg.shrink_slope * cfg.row_m)
    out = list(curves)
    for j in np.nonzero((hung > radius + 1e-4).any(axis=1))[0]:
        out[j] = Curve(hung[j][:, None] * ray)
    return out


def flat_panel(body: PlacementBody, frame: BodyFrame, theta: float, s, h, clearance: float):
    """World positions (n, 3) [m] of panel points laid flat, facing ``theta``, in front of
    the body part's extent in that direction plus ``clearance`` [m] (``s``, ``h`` as
    :func:`wrap_panel`'s)."""
    n2 = np.array([math.cos(theta), math.sin(theta)])
    hs, uw, band = body.part_data(frame)
    sel = (hs >= h.min() - band) & (hs <= h.max() + band)
    pts = uw[sel] if sel.sum() >= 3 else uw
    dist = float((pts @ n2).max()) + clearance
    t2 = np.array([-n2[1], n2[0]])  # direction of increasing angle
    plane = dist * n2[None, :] + s[:, None] * t2[None, :]
    return frame.world(h, plane)


def dilate(a: np.ndarray, r: int) -> np.ndarray:
    """Running maximum of ``a`` over ``r`` neighbours on each side."""
    out = a.copy()
    for k in range(1, r + 1):
        out[k:] = np.maximum(out[k:], a[:-k])
        out[:-k] = np.maximum(out[:-k], a[k:])
    return out
