"""What an off-screen picture shows and how: drawn items checked, the camera framing a view,
per-vertex shading and the style settings both backends share (:mod:`sandbox.render.offscreen`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

from sandbox.errors import SandboxError

#: view name -> (viewing direction, image-up direction)
VIEWS: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {
    "front": ((0.0, 0.0, -1.0), (0.0, 1.0, 0.0)),
    "back": ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0)),
    "side": ((-1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
}

DEFAULT_MESH_COLOR = (0.7, 0.7, 0.7)
DEFAULT_LINE_COLOR = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class RenderStyle:
    """Framing and shading of a picture (fractions, no units)."""

    margin: float = 0.05
    """[-] Empty border on each side, as a fraction of the image width/height: 5 % keeps
    the scene's silhouette clear of the edge without wasting pixels."""
    ambient: float = 0.35
    """[-] Light every visible surface gets on top of the Lambert term (which supplies the
    rest up to 1): enough that faces turned away from the light keep their colour."""
    line_depth_tolerance: float = 0.02
    """[-] Lines are drawn over surfaces this far behind them, as a fraction of the scene's
    largest extent (2 %: a seam line lying on cloth wins, one behind the body stays hidden)."""


DEFAULT_STYLE = RenderStyle()
"""The defaults (frozen: shared as the default argument of the render functions)."""


# ---------------------------------------------------------------------------------------
# input


@dataclass(frozen=True)
class DrawMesh:
    vertices: np.ndarray  # (n, 3) float64
    triangles: np.ndarray  # (m, 3) int64
    color: np.ndarray  # (3,) float64
    vertex_colors: np.ndarray | None = None  # (n, 3) in 0..1, instead of ``color``
    normals: np.ndarray | None = None  # (n, 3) unit, instead of the triangles' own


@dataclass(frozen=True)
class DrawLine:
    points: np.ndarray  # (k, 3) float64
    color: np.ndarray  # (3,) float64


def check_color(where: str, value, default) -> np.ndarray:
    c = np.asarray(default if value is None else value, dtype=np.float64)
    if c.shape != (3,) or not np.isfinite(c).all() or (c < 0).any() or (c > 1).any():
        raise SandboxError(f"{where}: color must be three floats in 0..1, got {value!r}")
    return c


def check_points(where: str, name: str, value) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise SandboxError(f"{where}: {name} is not a numeric array") from None
    if a.ndim != 2 or a.shape[1] != 3:
        raise SandboxError(f"{where}: {name} must have shape (n, 3), got {a.shape}")
    if not np.isfinite(a).all():
        raise SandboxError(f"{where}: {name} contain NaN or infinity")
    return a


def _per_vertex(where: str, name: str, value, n: int) -> np.ndarray | None:
    if value is None:
        return None
    arr = check_points(where, name, value)
    if len(arr) != n:
        raise SandboxError(f"{where}: {name} must have one row per vertex ({n}), got {len(arr)}")
    return arr


def prepare(
    target: str, meshes: Iterable[Mapping], lines: Iterable[Mapping]
) -> tuple[list[DrawMesh], list[DrawLine]]:
    out_meshes: list[DrawMesh] = []
    for i, item in enumerate(meshes):
        where = f"{target}: meshes[{i}]"
        if not isinstance(item, Mapping) or "vertices" not in item or "triangles" not in item:
            raise SandboxError(f"{where}: expected a dict with 'vertices' and 'triangles'")
        v = check_points(where, "vertices", item["vertices"])
        t = np.asarray(item["triangles"])
        if t.ndim != 2 or t.shape[1] != 3 or (t.size and t.dtype.kind not in "iu"):
            raise SandboxError(f"{where}: triangles must be integers of shape (m, 3)")
        t = t.astype(np.int64)
        if t.size and (t.min() < 0 or t.max() >= len(v)):
            raise SandboxError(f"{where}: triangle index out of range 0..{len(v) - 1}")
        colors = _per_vertex(where, "vertex_colors", item.get("vertex_colors"), len(v))
        if colors is not None and (colors.min() < 0 or colors.max() > 1):
            raise SandboxError(f"{where}: vertex_colors must lie in 0..1")
        normals = _per_vertex(where, "normals", item.get("normals"), len(v))
        color = check_color(where, item.get("color"), DEFAULT_MESH_COLOR)
        out_meshes.append(DrawMesh(v, t, color, colors, normals))
    out_lines: list[DrawLine] = []
    for i, item in enumerate(lines):
        where = f"{target}: lines[{i}]"
        if not isinstance(item, Mapping) or "points" not in item:
            raise SandboxError(f"{where}: expected a dict with 'points'")
        p = check_points(where, "points", item["points"])
        out_lines.append(DrawLine(p, check_color(where, item.get("color"), DEFAULT_LINE_COLOR)))
    if not any(len(m.triangles) for m in out_meshes) and not any(
        len(ln.points) for ln in out_lines
    ):
        raise SandboxError(f"{target}: nothing to render (no triangles and no line points)")
    return out_meshes, out_lines


# ---------------------------------------------------------------------------------------
# camera and shading


@dataclass(frozen=True)
class Camera:
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


def frame_view(view: str, points: np.ndarray, width: int, height: int, margin: float) -> Camera:
    """The orthographic camera of ``view`` that frames ``points`` (n, 3) [m] in a ``width``
    x ``height`` image with ``margin`` (fraction of the size) left empty on each side."""
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
    scale = min(width * (1 - 2 * margin) / span_a, height * (1 - 2 * margin) / span_b)
    centre = right * mid[0] + up * mid[1] + fwd * mid[2]
    return Camera(
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


def shade(mesh: DrawMesh, cam: Camera, ambient: float) -> np.ndarray:
    """Per-vertex colours (n, 3) in 0..1: two-sided Lambert, light from the upper left, plus
    ``ambient``; of the mesh's ``vertex_colors`` where it has them, else of its ``color``."""
    n = mesh.normals.copy() if mesh.normals is not None else vertex_normals(
        mesh.vertices, mesh.triangles)  # fmt: skip
    toward_viewer = -cam.forward
    n[n @ toward_viewer < 0] *= -1.0
    light = 0.75 * toward_viewer + 0.5 * cam.up - 0.4 * cam.right
    light /= np.linalg.norm(light)
    lambert = np.clip(n @ light, 0.0, 1.0)
    lit = np.linalg.norm(n, axis=1) > 0
    intensity = np.where(lit, ambient + (1.0 - ambient) * lambert, 1.0)
    color = mesh.color[None, :] if mesh.vertex_colors is None else mesh.vertex_colors
    return np.clip(color * intensity[:, None], 0.0, 1.0)


def line_radius(line_width: float) -> float:
    return 0.5 * float(line_width)


def line_bias(cam: Camera, tolerance: float) -> float:
    """How far [m] lines are drawn towards the viewer: ``tolerance`` x the scene size."""
    return tolerance * cam.size


def to_uint8(c: np.ndarray) -> np.ndarray:
    """Colours in 0..1 as 0..255 bytes."""
    return np.round(np.clip(c, 0.0, 1.0) * 255.0).astype(np.uint8)
