"""Self-crossing test of a closed polyline in O(n log n) for ordinary outlines.

Segments are binned into a uniform grid over the outline's bounding box (about √n cells a
side, each segment in the cells its bounding box covers); only segments that share a cell
are tested against each other, in vectorised batches, stopping at the first hit. Memory
stays in the tens of megabytes for outlines of hundreds of thousands of points, where an
all-pairs test needs n²/2 pairs.
"""

from __future__ import annotations

import math

import numpy as np

from sandbox.errors import SandboxError

GRID_ENTRIES_MAX = 2_000_000
"""(segment, cell) entries the grid may hold; a coarser grid is used above it."""
PAIR_BATCH = 1_000_000
"""Candidate pairs tested per vectorised batch."""
CANDIDATE_PAIRS_MAX = 20_000_000
"""More candidate pairs than this (long segments all through one region, as in a star of
thousands of spikes; no garment outline comes near) is refused as too intricate."""


class OutlineTooIntricate(SandboxError):
    """The outline has too many long segments crowded together to be checked quickly."""


def _cross(o, p, q):
    return (p[..., 0] - o[..., 0]) * (q[..., 1] - o[..., 1]) - (p[..., 1] - o[..., 1]) * (
        q[..., 0] - o[..., 0]
    )


def first_crossing(poly: np.ndarray, scale: float) -> tuple[int, int] | None:
    """A pair of segments (i < j) of a closed polyline that touch or cross, or None.

    Segment i runs from ``poly[i]`` to ``poly[i + 1]`` (the last back to ``poly[0]``).
    Neighbouring segments share an end point and only count when they fold back onto each
    other (collinear, opposite directions). ``scale`` [m] (the outline's size) sets the
    tolerance: points within about 1e-10 of it count as touching. Raises
    :class:`OutlineTooIntricate` (a SandboxError) when too many long segments crowd together.
    """
    poly = np.asarray(poly, dtype=np.float64)
    n = len(poly)
    if n < 3:
        return None
    a, b = poly, np.roll(poly, -1, axis=0)
    eps = 1e-10 * scale * scale
    pad = 1e-12 * scale
    d = b - a
    dn = np.roll(d, -1, axis=0)  # segment i and i + 1 (the last with the first)
    fold = (np.abs(d[:, 0] * dn[:, 1] - d[:, 1] * dn[:, 0]) <= eps) & (np.sum(d * dn, axis=1) < 0)
    if np.any(fold):
        i = int(np.argmax(fold))
        return (i, i + 1) if i + 1 < n else (0, n - 1)
    lo, hi = np.minimum(a, b) - pad, np.maximum(a, b) + pad
    for i, j in _candidate_batches(lo, hi):
        hit = _touch_or_cross(a, b, i, j, eps, pad)
        if np.any(hit):
            k = np.flatnonzero(hit)
            best = k[np.lexsort((j[k], i[k]))[0]]
            return int(i[best]), int(j[best])
    return None


def _candidate_batches(lo: np.ndarray, hi: np.ndarray):
    """Batches ``(i, j)`` (i < j, not neighbours) of segments whose boxes overlap; each such
    pair once (in the cell holding the lower-left corner of the boxes' overlap)."""
    n = len(lo)
    origin = lo.min(axis=0)
    span = max(float((hi.max(axis=0) - origin).max()), 1e-300)
    g = int(min(4096, max(1, math.isqrt(n))))
    while True:
        size = span / g
        c0 = np.clip(((lo - origin) / size).astype(np.int64), 0, g - 1)
        c1 = np.clip(((hi - origin) / size).astype(np.int64), 0, g - 1)
        w = c1[:, 0] - c0[:, 0] + 1
        counts = w * (c1[:, 1] - c0[:, 1] + 1)
        if int(counts.sum()) <= GRID_ENTRIES_MAX or g == 1:
            break
        g = max(1, g // 2)
    seg = np.repeat(np.arange(n), counts)
    k = np.arange(len(seg)) - np.repeat(np.cumsum(counts) - counts, counts)
    ws = np.repeat(w, counts)
    key = (np.repeat(c0[:, 0], counts) + k % ws) * g + np.repeat(c0[:, 1], counts) + k // ws
    order = np.argsort(key, kind="stable")
    key, seg = key[order], seg[order]
    start = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    sizes = np.diff(np.r_[start, len(key)])
    pairs = int(np.sum(sizes * (sizes - 1) // 2))
    if pairs > CANDIDATE_PAIRS_MAX:
        raise OutlineTooIntricate(
            f"the outline is too intricate to check for self-crossings ({n} segments, "
            f"{pairs:,} candidate pairs, at most {CANDIDATE_PAIRS_MAX:,}): simplify it"
        )
    group_end = np.repeat(np.r_[start[1:], len(key)], np.diff(np.r_[start, len(key)]))
    pending_i, pending_j, pending = [], [], 0
    live, step = np.arange(len(key)), 1
    while len(live):
        live = live[live + step < group_end[live]]
        if not len(live):
            break
        s, t = seg[live], seg[live + step]
        i, j = np.minimum(s, t), np.maximum(s, t)
        keep = (j - i != 1) & ~((i == 0) & (j == n - 1))
        i, j, cell = i[keep], j[keep], key[live][keep]
        corner = np.maximum(lo[i], lo[j])
        overlap = np.all(corner <= np.minimum(hi[i], hi[j]), axis=1)
        cc = np.clip(((corner - origin) / size).astype(np.int64), 0, g - 1)
        own = overlap & (cc[:, 0] * g + cc[:, 1] == cell)
        if np.any(own):
            pending_i.append(i[own])
            pending_j.append(j[own])
            pending += int(own.sum())
        if pending >= PAIR_BATCH:
            yield np.concatenate(pending_i), np.concatenate(pending_j)
            pending_i, pending_j, pending = [], [], 0
        step += 1
    if pending:
        yield np.concatenate(pending_i), np.concatenate(pending_j)


def _touch_or_cross(a, b, i, j, eps: float, pad: float) -> np.ndarray:
    p, q, r, s = a[i], b[i], a[j], b[j]
    d1, d2 = _cross(r, s, p), _cross(r, s, q)
    d3, d4 = _cross(p, q, r), _cross(p, q, s)
    proper = (d1 * d2 < 0) & (d3 * d4 < 0)

    def on_seg(o, e, x, d):  # x collinear with o-e and inside its box
        inside = np.all((x >= np.minimum(o, e) - pad) & (x <= np.maximum(o, e) + pad), axis=1)
        return (np.abs(d) <= eps) & inside

    touch = on_seg(r, s, p, d1) | on_seg(r, s, q, d2) | on_seg(p, q, r, d3) | on_seg(p, q, s, d4)
    return proper | touch


def on_one_line(poly: np.ndarray, scale: float) -> bool:
    """True when every point (n, 2) lies within 1e-9 of ``scale`` of one straight line."""
    poly = np.asarray(poly, dtype=np.float64)
    far = poly[int(np.argmax(np.linalg.norm(poly - poly[0], axis=1)))]
    d = far - poly[0]
    length = float(np.linalg.norm(d))
    if not length > 0:
        return True
    return bool(np.all(np.abs(_cross(poly[0], far, poly)) <= 1e-9 * scale * length))


def crossing_point(poly: np.ndarray, i: int, j: int) -> np.ndarray:
    """Where segments i and j of a closed polyline meet (2,): the intersection of the two
    lines when they cross, else the end point of one nearest to the other segment."""
    poly = np.asarray(poly, dtype=np.float64)
    n = len(poly)
    p, q = poly[i], poly[(i + 1) % n]
    r, s = poly[j], poly[(j + 1) % n]
    d, e = q - p, s - r
    den = d[0] * e[1] - d[1] * e[0]
    if abs(den) > 1e-12 * (np.linalg.norm(d) * np.linalg.norm(e) + 1e-300):
        t = ((r[0] - p[0]) * e[1] - (r[1] - p[1]) * e[0]) / den
        if -1e-9 <= t <= 1 + 1e-9:
            return p + np.clip(t, 0.0, 1.0) * d
    cands = [(p, r, s), (q, r, s), (r, p, q), (s, p, q)]
    dist = [_point_segment_distance(x, u, v) for x, u, v in cands]
    return cands[int(np.argmin(dist))][0].copy()


def _point_segment_distance(x, u, v) -> float:
    d = v - u
    t = float(np.clip(np.dot(x - u, d) / max(float(np.dot(d, d)), 1e-300), 0.0, 1.0))
    return float(np.linalg.norm(x - (u + t * d)))
