"""The numpy backend of :mod:`sandbox.render.offscreen`: a software rasteriser with a
z-buffer, triangles processed in batches of similar bounding-box size, lines as thick
segments in front of the surfaces within the style's depth tolerance."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from sandbox.render.view import (
    Camera,
    DrawLine,
    DrawMesh,
    RenderStyle,
    line_bias,
    line_radius,
    shade,
    to_uint8,
)

_BATCH_ELEMENTS = 1 << 19  # candidate pixels per numpy batch (~70 MB peak)


def _batches(bw: np.ndarray, bh: np.ndarray) -> Iterable[tuple[np.ndarray, int, int]]:
    """Group primitives by power-of-two box size; yield (indices, box width, box height)."""
    key = np.ceil(np.log2(bw)).astype(np.int64) * 64 + np.ceil(np.log2(bh)).astype(np.int64)
    order = np.argsort(key, kind="stable")
    key_sorted = key[order]
    starts = np.flatnonzero(np.r_[True, key_sorted[1:] != key_sorted[:-1]])
    ends = np.r_[starts[1:], len(order)]
    for s, e in zip(starts, ends, strict=True):
        group = order[s:e]
        gw, gh = int(bw[group].max()), int(bh[group].max())
        step = max(1, _BATCH_ELEMENTS // (gw * gh))
        for i in range(0, len(group), step):
            yield group[i : i + step], gw, gh


def _resolve(pix: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """Indices of the nearest fragment per pixel."""
    order = np.lexsort((depth, pix))
    p = pix[order]
    first = np.ones(len(order), dtype=bool)
    first[1:] = p[1:] != p[:-1]
    return order[first]


def _box(lo: np.ndarray, hi: np.ndarray, limit: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel index range whose centres (i + 0.5) fall in [lo, hi], clipped to the image."""
    i0 = np.maximum(np.ceil(lo - 0.5), 0).astype(np.int64)
    i1 = np.minimum(np.floor(hi - 0.5), limit - 1).astype(np.int64)
    return i0, i1


def _fill_triangles(
    xyz: np.ndarray, rgb: np.ndarray, zbuf: np.ndarray, cbuf: np.ndarray, w: int, h: int
) -> None:
    """Rasterise triangles ``xyz`` (m, 3 corners, x/y/depth) with corner colours ``rgb``."""
    x, y = xyz[:, :, 0], xyz[:, :, 1]
    area = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    x0, x1 = _box(x.min(axis=1), x.max(axis=1), w)
    y0, y1 = _box(y.min(axis=1), y.max(axis=1), h)
    keep = np.flatnonzero((np.abs(area) > 1e-12) & (x0 <= x1) & (y0 <= y1))
    if keep.size == 0:
        return
    xyz, rgb, area = xyz[keep], rgb[keep], area[keep]
    x0, x1, y0, y1 = x0[keep], x1[keep], y0[keep], y1[keep]
    inv_area = 1.0 / area
    for idx, bw, bh in _batches(x1 - x0 + 1, y1 - y0 + 1):
        px = x0[idx, None, None] + np.arange(bw)[None, None, :]  # (k, 1, bw)
        py = y0[idx, None, None] + np.arange(bh)[None, :, None]  # (k, bh, 1)
        cx, cy = px + 0.5, py + 0.5
        tx, ty = xyz[idx, :, 0], xyz[idx, :, 1]
        ax, ay = tx[:, 0, None, None] - cx, ty[:, 0, None, None] - cy
        bx, by = tx[:, 1, None, None] - cx, ty[:, 1, None, None] - cy
        qx, qy = tx[:, 2, None, None] - cx, ty[:, 2, None, None] - cy
        ia = inv_area[idx, None, None]
        w0 = (bx * qy - qx * by) * ia
        w1 = (qx * ay - ax * qy) * ia
        w2 = 1.0 - w0 - w1
        eps = -1e-9
        inside = (w0 >= eps) & (w1 >= eps) & (w2 >= eps)
        inside &= (px <= x1[idx, None, None]) & (py <= y1[idx, None, None])
        k, r, c = np.nonzero(inside)
        if k.size == 0:
            continue
        b0, b1, b2 = w0[k, r, c], w1[k, r, c], w2[k, r, c]
        tri = idx[k]
        z = xyz[tri, :, 2]
        depth = b0 * z[:, 0] + b1 * z[:, 1] + b2 * z[:, 2]
        pix = (y0[tri] + r) * w + (x0[tri] + c)
        win = _resolve(pix, depth)
        p, d = pix[win], depth[win]
        closer = d < zbuf[p]
        win, p = win[closer], p[closer]
        zbuf[p] = d[closer]
        col = rgb[tri[win]]
        cbuf[p] = b0[win, None] * col[:, 0] + b1[win, None] * col[:, 1] + b2[win, None] * col[:, 2]


def _draw_segments(
    a: np.ndarray,
    b: np.ndarray,
    color: np.ndarray,
    radius: float,
    bias: float,
    zbuf: np.ndarray,
    cbuf: np.ndarray,
    w: int,
    h: int,
) -> None:
    """Draw capsules of ``radius`` px from a to b (each (s, 3): x, y, depth) over cbuf."""
    x0, x1 = _box(np.minimum(a[:, 0], b[:, 0]) - radius, np.maximum(a[:, 0], b[:, 0]) + radius, w)
    y0, y1 = _box(np.minimum(a[:, 1], b[:, 1]) - radius, np.maximum(a[:, 1], b[:, 1]) + radius, h)
    keep = np.flatnonzero((x0 <= x1) & (y0 <= y1))
    if keep.size == 0:
        return
    a, b, color = a[keep], b[keep], color[keep]
    x0, x1, y0, y1 = x0[keep], x1[keep], y0[keep], y1[keep]
    d = b[:, :2] - a[:, :2]
    len2 = np.einsum("ij,ij->i", d, d)
    inv_len2 = np.divide(1.0, len2, out=np.zeros_like(len2), where=len2 > 1e-12)
    lbuf = np.full(zbuf.shape, np.inf)
    for idx, bw, bh in _batches(x1 - x0 + 1, y1 - y0 + 1):
        px = x0[idx, None, None] + np.arange(bw)[None, None, :]
        py = y0[idx, None, None] + np.arange(bh)[None, :, None]
        rx = px + 0.5 - a[idx, 0, None, None]
        ry = py + 0.5 - a[idx, 1, None, None]
        dx, dy = d[idx, 0, None, None], d[idx, 1, None, None]
        t = np.clip((rx * dx + ry * dy) * inv_len2[idx, None, None], 0.0, 1.0)
        ex, ey = rx - t * dx, ry - t * dy
        inside = ex * ex + ey * ey <= radius * radius
        inside &= (px <= x1[idx, None, None]) & (py <= y1[idx, None, None])
        k, r, c = np.nonzero(inside)
        if k.size == 0:
            continue
        seg = idx[k]
        tt = t[k, r, c]
        depth = a[seg, 2] + tt * (b[seg, 2] - a[seg, 2])
        pix = (y0[seg] + r) * w + (x0[seg] + c)
        visible = depth <= zbuf[pix] + bias
        pix, depth, seg = pix[visible], depth[visible], seg[visible]
        win = _resolve(pix, depth)
        p, dd = pix[win], depth[win]
        closer = dd < lbuf[p]
        p = p[closer]
        lbuf[p] = dd[closer]
        cbuf[p] = color[seg[win][closer]]


def render_numpy(
    meshes: list[DrawMesh],
    lines: list[DrawLine],
    cam: Camera,
    background: np.ndarray,
    line_width: float,
    style: RenderStyle,
) -> np.ndarray:
    """One view as an (h, w, 3) uint8 image; ``line_width`` [px]."""
    w, h = cam.width, cam.height
    zbuf = np.full(w * h, np.inf)
    cbuf = np.empty((w * h, 3))
    cbuf[:] = background
    tris, cols = [], []
    for mesh in meshes:
        if len(mesh.triangles) == 0:
            continue
        proj = cam.project(mesh.vertices)
        colors = shade(mesh, cam, style.ambient)
        tris.append(proj[mesh.triangles])
        cols.append(colors[mesh.triangles])
    if tris:
        _fill_triangles(np.concatenate(tris), np.concatenate(cols), zbuf, cbuf, w, h)
    seg_a, seg_b, seg_c = [], [], []
    for line in lines:
        if len(line.points) == 0:
            continue
        proj = cam.project(line.points)
        if len(proj) == 1:
            proj = np.repeat(proj, 2, axis=0)
        seg_a.append(proj[:-1])
        seg_b.append(proj[1:])
        seg_c.append(np.repeat(line.color[None, :], len(proj) - 1, axis=0))
    if seg_a:
        _draw_segments(
            np.concatenate(seg_a),
            np.concatenate(seg_b),
            np.concatenate(seg_c),
            line_radius(line_width),
            line_bias(cam, style.line_depth_tolerance),
            zbuf,
            cbuf,
            w,
            h,
        )
    return to_uint8(cbuf).reshape(h, w, 3)
