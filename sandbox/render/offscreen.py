"""Offscreen pictures of meshes and polylines, written as PNG.

Conventions: Y is up and the front of a body faces +Z. A view looks along a fixed
direction with an orthographic camera that frames the bounding box of everything drawn
(5 % margin on each side); several views are placed side by side, each ``width`` x
``height`` pixels.

======  ==================  ==================  ===========
view    camera sits at      image right is      image up is
======  ==================  ==================  ===========
front   +Z, looks to -Z     +X                  +Y
back    -Z, looks to +Z     -X                  +Y
side    +X, looks to -X     -Z                  +Y
======  ==================  ==================  ===========

Shading is the same for both backends and computed here: two-sided Lambert per vertex
(normals are turned toward the viewer, so cloth reads the same from either side), one
light from the upper left behind the camera plus ambient, interpolated over the triangle
(Gouraud). Lines are thick polylines in one flat colour, drawn with a depth test that lets
them win against a surface they lie on (tolerance 2 % of the scene size) but hides them
behind the body.

Backends:

``numpy``
    The software rasteriser in this module: z-buffer, triangles processed in batches of
    similar bounding-box size, no GPU or display needed. The default.
``open3d``
    Open3D's legacy ``Visualizer`` in a hidden window: OpenGL through headless EGL (Mesa
    llvmpipe when there is no GPU) or through GLX when an X display is set. Meshes are
    drawn unlit with the colours shaded here, lines as camera-facing ribbons, and a
    distant pinhole camera stands in for the orthographic one, so the picture matches the
    numpy backend to within edge pixels and the background is exact. One window is kept
    per process (made again when the size changes). About 0.05 s per view after ~1.5 s to
    import Open3D.
``auto``
    The value of ``$SANDBOX_RENDER_BACKEND`` if set, otherwise ``numpy``: it draws a
    640 x 640 view of 20k triangles in ~0.3 s, less than importing Open3D takes (1-1.5 s),
    and a run writes only one or two pictures. For many frames choose ``open3d``.

Open3D's Filament ``OffscreenRenderer`` was measured and not used: on lavapipe (Vulkan in
software) it takes 0.7-2.4 s for the first picture and 0.25-0.35 s for each further one,
it aborts the whole process when no Vulkan driver is installed (no EGL fallback), aborts
at exit when two renderers were alive, and stalled after a few renders of legacy meshes
with vertex colours. See docs/outputs.md for the numbers.
"""

from __future__ import annotations

import atexit
import logging
import os
import tempfile
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sandbox.atomic import atomic_path
from sandbox.errors import SandboxError

ENV_BACKEND = "SANDBOX_RENDER_BACKEND"
BACKENDS = ("auto", "numpy", "open3d")

#: view name -> (viewing direction, image-up direction)
VIEWS: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {
    "front": ((0.0, 0.0, -1.0), (0.0, 1.0, 0.0)),
    "back": ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0)),
    "side": ((-1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
}

DEFAULT_MESH_COLOR = (0.7, 0.7, 0.7)
DEFAULT_LINE_COLOR = (0.0, 0.0, 0.0)
MARGIN = 0.05  # of the image size, on each side
AMBIENT = 0.35
LINE_DEPTH_TOLERANCE = 0.02  # of the scene size
_BATCH_ELEMENTS = 1 << 19  # candidate pixels per numpy batch (~70 MB peak)


# ---------------------------------------------------------------------------------------
# input


@dataclass(frozen=True)
class _Mesh:
    vertices: np.ndarray  # (n, 3) float64
    triangles: np.ndarray  # (m, 3) int64
    color: np.ndarray  # (3,) float64


@dataclass(frozen=True)
class _Line:
    points: np.ndarray  # (k, 3) float64
    color: np.ndarray  # (3,) float64


def _color(where: str, value, default) -> np.ndarray:
    c = np.asarray(default if value is None else value, dtype=np.float64)
    if c.shape != (3,) or not np.isfinite(c).all() or (c < 0).any() or (c > 1).any():
        raise SandboxError(f"{where}: color must be three floats in 0..1, got {value!r}")
    return c


def _points(where: str, name: str, value) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise SandboxError(f"{where}: {name} is not a numeric array") from None
    if a.ndim != 2 or a.shape[1] != 3:
        raise SandboxError(f"{where}: {name} must have shape (n, 3), got {a.shape}")
    if not np.isfinite(a).all():
        raise SandboxError(f"{where}: {name} contain NaN or infinity")
    return a


def _prepare(
    target: str, meshes: Iterable[Mapping], lines: Iterable[Mapping]
) -> tuple[list[_Mesh], list[_Line]]:
    out_meshes: list[_Mesh] = []
    for i, item in enumerate(meshes):
        where = f"{target}: meshes[{i}]"
        if not isinstance(item, Mapping) or "vertices" not in item or "triangles" not in item:
            raise SandboxError(f"{where}: expected a dict with 'vertices' and 'triangles'")
        v = _points(where, "vertices", item["vertices"])
        t = np.asarray(item["triangles"])
        if t.ndim != 2 or t.shape[1] != 3 or (t.size and t.dtype.kind not in "iu"):
            raise SandboxError(f"{where}: triangles must be integers of shape (m, 3)")
        t = t.astype(np.int64)
        if t.size and (t.min() < 0 or t.max() >= len(v)):
            raise SandboxError(f"{where}: triangle index out of range 0..{len(v) - 1}")
        out_meshes.append(_Mesh(v, t, _color(where, item.get("color"), DEFAULT_MESH_COLOR)))
    out_lines: list[_Line] = []
    for i, item in enumerate(lines):
        where = f"{target}: lines[{i}]"
        if not isinstance(item, Mapping) or "points" not in item:
            raise SandboxError(f"{where}: expected a dict with 'points'")
        p = _points(where, "points", item["points"])
        out_lines.append(_Line(p, _color(where, item.get("color"), DEFAULT_LINE_COLOR)))
    if not any(len(m.triangles) for m in out_meshes) and not any(
        len(ln.points) for ln in out_lines
    ):
        raise SandboxError(f"{target}: nothing to render (no triangles and no line points)")
    return out_meshes, out_lines


# ---------------------------------------------------------------------------------------
# camera and shading


@dataclass(frozen=True)
class _Camera:
    right: np.ndarray
    up: np.ndarray
    forward: np.ndarray
    centre: np.ndarray  # world point at the image centre (depth 0)
    scale: float  # pixels per metre
    width: int
    height: int
    depth_min: float  # depth range of the scene relative to centre
    depth_max: float
    size: float  # largest extent of the scene, metres

    def project(self, p: np.ndarray) -> np.ndarray:
        """World points (n, 3) -> (n, 3) of pixel x (right), pixel y (down), depth."""
        d = p - self.centre
        out = np.empty_like(d)
        out[:, 0] = d @ self.right * self.scale + 0.5 * self.width
        out[:, 1] = 0.5 * self.height - d @ self.up * self.scale
        out[:, 2] = d @ self.forward
        return out


def _frame(view: str, points: np.ndarray, width: int, height: int) -> _Camera:
    fwd, up = (np.asarray(a, dtype=np.float64) for a in VIEWS[view])
    right = np.cross(fwd, up)
    a, b, z = points @ right, points @ up, points @ fwd
    lo = np.array([a.min(), b.min(), z.min()])
    hi = np.array([a.max(), b.max(), z.max()])
    mid = 0.5 * (lo + hi)
    span = hi - lo
    size = float(span.max())
    if size <= 1e-9 * max(1.0, float(np.abs(points).max())):  # a single point
        size = 1.0
        span = np.full(3, size)  # frame a 1 m square around it
    # a flat scene seen edge-on is framed by its other extent
    span_a, span_b = max(span[0], 1e-3 * size), max(span[1], 1e-3 * size)
    scale = min(width * (1 - 2 * MARGIN) / span_a, height * (1 - 2 * MARGIN) / span_b)
    centre = right * mid[0] + up * mid[1] + fwd * mid[2]
    return _Camera(
        right=right,
        up=up,
        forward=fwd,
        centre=centre,
        scale=float(scale),
        width=width,
        height=height,
        depth_min=float(lo[2] - mid[2]),
        depth_max=float(hi[2] - mid[2]),
        size=size,
    )


def vertex_normals(v: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Unit vertex normals (n, 3): the area-weighted sum of the faces' normals (zero for an
    unused vertex); same dtype as ``v``."""
    fn = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])  # area-weighted
    n = np.zeros_like(v)
    for k in range(3):
        idx = t[:, k]
        for c in range(3):
            n[:, c] += np.bincount(idx, weights=fn[:, c], minlength=len(v))
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, length, out=np.zeros_like(n), where=length > 0)


def _shade(mesh: _Mesh, cam: _Camera) -> np.ndarray:
    """Per-vertex colours (n, 3) in 0..1: two-sided Lambert, light from the upper left."""
    n = vertex_normals(mesh.vertices, mesh.triangles)
    toward_viewer = -cam.forward
    n[n @ toward_viewer < 0] *= -1.0
    light = 0.75 * toward_viewer + 0.5 * cam.up - 0.4 * cam.right
    light /= np.linalg.norm(light)
    lambert = np.clip(n @ light, 0.0, 1.0)
    lit = np.linalg.norm(n, axis=1) > 0
    intensity = np.where(lit, AMBIENT + (1.0 - AMBIENT) * lambert, 1.0)
    return np.clip(mesh.color[None, :] * intensity[:, None], 0.0, 1.0)


def _line_radius(line_width: float) -> float:
    return 0.5 * float(line_width)


def _line_bias(cam: _Camera) -> float:
    return LINE_DEPTH_TOLERANCE * cam.size


# ---------------------------------------------------------------------------------------
# numpy backend


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


def _render_numpy(
    meshes: list[_Mesh],
    lines: list[_Line],
    cam: _Camera,
    background: np.ndarray,
    line_width: float,
) -> np.ndarray:
    w, h = cam.width, cam.height
    zbuf = np.full(w * h, np.inf)
    cbuf = np.empty((w * h, 3))
    cbuf[:] = background
    tris, cols = [], []
    for mesh in meshes:
        if len(mesh.triangles) == 0:
            continue
        proj = cam.project(mesh.vertices)
        shade = _shade(mesh, cam)
        tris.append(proj[mesh.triangles])
        cols.append(shade[mesh.triangles])
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
            _line_radius(line_width),
            _line_bias(cam),
            zbuf,
            cbuf,
            w,
            h,
        )
    return _to_uint8(cbuf).reshape(h, w, 3)


def _to_uint8(c: np.ndarray) -> np.ndarray:
    return np.round(np.clip(c, 0.0, 1.0) * 255.0).astype(np.uint8)


# ---------------------------------------------------------------------------------------
# open3d backend

_GL: dict = {"vis": None, "size": None, "atexit": False}
_CAMERA_DISTANCE = 1000.0  # of the scene size: a pinhole this far away is orthographic to 0.1 %


def _gl_release() -> None:
    vis = _GL["vis"]
    _GL.update(vis=None, size=None)
    if vis is not None:
        vis.destroy_window()


def _gl_visualizer(width: int, height: int):
    """The process's hidden Open3D window of this size (made once, reused)."""
    if _GL["vis"] is not None and _GL["size"] == (width, height):
        return _GL["vis"]
    _gl_release()
    try:
        import open3d as o3d
    except ImportError as exc:
        raise SandboxError(f"open3d render backend unavailable: {exc}") from None
    if not os.environ.get("XDG_RUNTIME_DIR"):  # headless EGL complains without one
        runtime_dir = Path(tempfile.gettempdir()) / f"sandbox-runtime-{os.getuid()}"
        runtime_dir.mkdir(mode=0o700, exist_ok=True)
        os.environ["XDG_RUNTIME_DIR"] = str(runtime_dir)
    with o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error):
        vis = o3d.visualization.Visualizer()
        ok = vis.create_window(window_name="sandbox", width=width, height=height, visible=False)
    if not ok:
        raise SandboxError(
            "open3d render backend unavailable: no OpenGL context could be created (needs an "
            "X display or headless EGL; Debian: apt-get install libgl1 libegl1)"
        )
    option = vis.get_render_option()
    option.light_on = False  # colours are shaded here
    option.mesh_show_back_face = True  # cloth triangles face either way
    _GL.update(vis=vis, size=(width, height))
    if not _GL["atexit"]:
        atexit.register(_gl_release)
        _GL["atexit"] = True
    return vis


def _ribbons(lines: list[_Line], cam: _Camera, line_width: float):
    """Camera-facing quads for the segments and square caps for the joints."""
    half = _line_radius(line_width) / cam.scale
    lift = -cam.forward * _line_bias(cam)  # same depth tolerance as the numpy backend
    verts, tris, cols = [], [], []
    base = 0
    for line in lines:
        if len(line.points) == 0:
            continue
        p = line.points + lift
        quads = []
        if len(p) > 1:
            d = p[1:] - p[:-1]
            side = np.cross(cam.forward, d)
            n = np.linalg.norm(side, axis=1, keepdims=True)
            side = np.where(n > 1e-12, side / np.where(n > 0, n, 1.0), cam.right) * half
            quads.append(np.stack([p[:-1] - side, p[:-1] + side, p[1:] + side, p[1:] - side], 1))
        r, u = cam.right * half, cam.up * half
        quads.append(np.stack([p - r - u, p + r - u, p + r + u, p - r + u], axis=1))
        q = np.concatenate(quads)  # (s, 4, 3)
        idx = base + 4 * np.arange(len(q))[:, None] + np.array([[0, 1, 2], [0, 2, 3]])[:, None]
        verts.append(q.reshape(-1, 3))
        tris.append(idx.transpose(1, 0, 2).reshape(-1, 3))
        cols.append(np.repeat(line.color[None, :], 4 * len(q), axis=0))
        base += 4 * len(q)
    return np.concatenate(verts), np.concatenate(tris), np.concatenate(cols)


def _render_open3d(
    meshes: list[_Mesh],
    lines: list[_Line],
    cam: _Camera,
    background: np.ndarray,
    line_width: float,
) -> np.ndarray:
    import open3d as o3d

    vis = _gl_visualizer(cam.width, cam.height)
    vis.clear_geometries()
    vis.get_render_option().background_color = background

    def add(v: np.ndarray, t: np.ndarray, c: np.ndarray) -> None:
        mesh = o3d.geometry.TriangleMesh(
            o3d.utility.Vector3dVector(v), o3d.utility.Vector3iVector(t.astype(np.int32))
        )
        mesh.vertex_colors = o3d.utility.Vector3dVector(c)
        vis.add_geometry(mesh)

    for mesh in meshes:
        if len(mesh.triangles):
            add(mesh.vertices, mesh.triangles, _shade(mesh, cam))
    if any(len(line.points) for line in lines):
        add(*_ribbons(lines, cam, line_width))

    # A pinhole far away with a long focal length reproduces the orthographic camera;
    # Open3D's convention: x right, y down, z forward, principal point at the centre.
    distance = _CAMERA_DISTANCE * cam.size
    rotation = np.stack([cam.right, -cam.up, cam.forward])
    extrinsic = np.eye(4)
    extrinsic[:3, :3] = rotation
    extrinsic[:3, 3] = -rotation @ (cam.centre - cam.forward * distance)
    params = o3d.camera.PinholeCameraParameters()
    focal = cam.scale * distance
    params.intrinsic = o3d.camera.PinholeCameraIntrinsic(
        cam.width, cam.height, focal, focal, 0.5 * cam.width - 0.5, 0.5 * cam.height - 0.5
    )
    params.extrinsic = extrinsic
    control = vis.get_view_control()
    if not control.convert_from_pinhole_camera_parameters(params, allow_arbitrary=True):
        raise SandboxError("open3d render backend: the camera was rejected")
    control.set_constant_z_near(distance + cam.depth_min - 0.5 * cam.size)
    control.set_constant_z_far(distance + cam.depth_max + 0.5 * cam.size)
    image = np.asarray(vis.capture_screen_float_buffer(do_render=True))
    vis.clear_geometries()
    return _to_uint8(image[:, :, :3])


# ---------------------------------------------------------------------------------------
# public API


def resolve_backend(backend: str = "auto") -> str:
    """The backend that ``backend`` stands for: ``"numpy"`` or ``"open3d"``.

    ``"auto"`` takes ``$SANDBOX_RENDER_BACKEND`` when it is set, else ``"open3d"`` (the
    project's offline renderer); :func:`render_image` falls back to ``"numpy"`` when Open3D
    cannot open a GL context.
    """
    if backend not in BACKENDS:
        raise SandboxError(f"unknown render backend {backend!r}: choose one of {BACKENDS}")
    if backend == "auto":
        env = os.environ.get(ENV_BACKEND, "").strip().lower()
        if env and env not in BACKENDS:
            raise SandboxError(
                f"${ENV_BACKEND}={env!r} is not a render backend: choose one of {BACKENDS}"
            )
        backend = env or "auto"
    return "open3d" if backend == "auto" else backend


def _render(
    target: str,
    meshes: Iterable[Mapping],
    lines: Iterable[Mapping],
    views: Sequence[str] | str,
    width: int,
    height: int,
    background: Sequence[float],
    line_width: float,
    backend: str,
) -> np.ndarray:
    views = (views,) if isinstance(views, str) else tuple(views)
    if not views:
        raise SandboxError(f"{target}: no views requested")
    unknown = [v for v in views if v not in VIEWS]
    if unknown:
        raise SandboxError(f"{target}: unknown view(s) {unknown}: choose from {list(VIEWS)}")
    if not all(isinstance(n, int | np.integer) and n >= 8 for n in (width, height)):
        raise SandboxError(f"{target}: width and height must be integers >= 8")
    if not (isinstance(line_width, int | float) and line_width > 0):
        raise SandboxError(f"{target}: line_width must be a positive number of pixels")
    bg = _color(f"{target}: background", background, None)
    chosen = resolve_backend(backend)
    mesh_list, line_list = _prepare(target, meshes, lines)
    points = np.concatenate(
        [m.vertices[np.unique(m.triangles)] for m in mesh_list if len(m.triangles)]
        + [ln.points for ln in line_list if len(ln.points)]
    )
    automatic = backend == "auto" and not os.environ.get(ENV_BACKEND, "").strip()

    def draw_all(draw):
        tiles = []
        for view in views:
            cam = _frame(view, points, int(width), int(height))
            tiles.append(draw(mesh_list, line_list, cam, bg, float(line_width)))
        return np.concatenate(tiles, axis=1)

    if chosen == "open3d":
        try:
            return draw_all(_render_open3d)
        except SandboxError as exc:
            if not automatic:
                raise
            logging.getLogger(__name__).info("%s; using the numpy renderer", exc)
    return draw_all(_render_numpy)


def render_image(
    meshes: Sequence[Mapping],
    *,
    lines: Sequence[Mapping] = (),
    views: Sequence[str] = ("front",),
    width: int = 640,
    height: int = 640,
    background: Sequence[float] = (1.0, 1.0, 1.0),
    line_width: float = 3.0,
    backend: str = "auto",
) -> np.ndarray:
    """Render to an RGB ``uint8`` array of shape (height, width * len(views), 3).

    Arguments as for :func:`render_png`.
    """
    return _render(
        "render_image", meshes, lines, views, width, height, background, line_width, backend
    )


def render_png(
    path: str | os.PathLike,
    meshes: Sequence[Mapping],
    *,
    lines: Sequence[Mapping] = (),
    views: Sequence[str] = ("front",),
    width: int = 640,
    height: int = 640,
    background: Sequence[float] = (1.0, 1.0, 1.0),
    line_width: float = 3.0,
    backend: str = "auto",
) -> Path:
    """Render meshes and polylines to a PNG, written atomically; return the path.

    ``meshes``: dicts ``{"vertices": (n, 3), "triangles": (m, 3), "color": (r, g, b)}``
    (colour optional, floats 0..1). ``lines``: dicts ``{"points": (k, 3), "color": ...}``,
    each a polyline drawn ``line_width`` pixels thick. ``views``: names from
    :data:`VIEWS`, placed left to right, each ``width`` x ``height`` pixels.
    ``backend``: ``"auto"``, ``"numpy"`` or ``"open3d"`` (see the module docstring).
    """
    import imageio.v3 as iio

    path = Path(path)
    if path.suffix.lower() != ".png":
        raise SandboxError(f"{path}: render output must be a .png file")
    image = _render(str(path), meshes, lines, views, width, height, background, line_width, backend)
    try:
        with atomic_path(path) as tmp:
            iio.imwrite(tmp, image, extension=".png")
    except OSError as exc:
        raise SandboxError(f"{path}: could not write image: {exc}") from None
    return path


def image_is_blank(img, background: Sequence[float] | None = None) -> bool:
    """True when every pixel equals the background colour.

    ``img``: an (h, w[, c]) array or a path to an image file. ``background``: floats in
    0..1; when omitted the top-left pixel is taken. An alpha channel is ignored.
    """
    if isinstance(img, str | os.PathLike):
        import imageio.v3 as iio

        img = iio.imread(img)
    a = np.asarray(img)
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3 or a.size == 0:
        raise SandboxError(f"image_is_blank: expected an (h, w, c) image, got shape {a.shape}")
    a = a[:, :, :3] if a.shape[2] >= 3 else a
    if background is None:
        ref = a[0, 0]
    else:
        ref = np.asarray(background, dtype=np.float64)[: a.shape[2]]
        if a.dtype.kind in "iu":
            return bool((a == np.round(ref * 255.0).astype(a.dtype)).all())
        return bool((np.abs(a - ref) <= 0.5 / 255.0).all())
    return bool((a == ref).all())
