"""Offscreen pictures of meshes and polylines, written as PNG.

Conventions: Y is up and the front of a body faces +Z. A view looks along a fixed
direction with an orthographic camera that frames the bounding box of everything drawn
(by default 5 % margin on each side, :class:`~sandbox.render.view.RenderStyle`); several
views are placed side by side, each ``width`` x ``height`` pixels.

======  ==================  ==================  ===========
view    camera sits at      image right is      image up is
======  ==================  ==================  ===========
front   +Z, looks to -Z     +X                  +Y
back    -Z, looks to +Z     -X                  +Y
side    +X, looks to -X     -Z                  +Y
======  ==================  ==================  ===========

Shading is the same for both backends (:mod:`sandbox.render.view`): two-sided Lambert per
vertex (normals are turned toward the viewer, so cloth reads the same from either side), one
light from the upper left behind the camera plus ambient, interpolated over the triangle
(Gouraud). Lines are thick polylines in one flat colour, drawn with a depth test that lets
them win against a surface they lie on (tolerance 2 % of the scene size) but hides them
behind the body.

Backends:

``numpy``
    The software rasteriser of :mod:`sandbox.render.raster`: z-buffer, triangles
    processed in batches of similar bounding-box size, no GPU or display needed.
``open3d``
    Open3D's legacy ``Visualizer`` in a hidden window: OpenGL through headless EGL (Mesa
    llvmpipe when there is no GPU) or through GLX when an X display is set. Meshes are
    drawn unlit with the colours shaded here, lines as camera-facing ribbons, and a
    distant pinhole camera stands in for the orthographic one, so the picture matches the
    numpy backend to within edge pixels and the background is exact. One window is kept
    per process (made again when the size changes). About 0.05 s per view after ~1.5 s to
    import Open3D.
``auto``
    The value of ``$SANDBOX_RENDER_BACKEND`` if set, otherwise ``open3d``, falling back to
    ``numpy`` when Open3D cannot open a GL context (numpy draws a 640 x 640 view of 20k
    triangles in ~0.3 s, less than importing Open3D takes, 1-1.5 s).

Open3D's Filament ``OffscreenRenderer`` was measured and not used: on lavapipe (Vulkan in
software) it takes 0.7-2.4 s for the first picture and 0.25-0.35 s for each further one,
it aborts the whole process when no Vulkan driver is installed (no EGL fallback), aborts
at exit when two renderers were alive, and stalled after a few renders of legacy meshes
with vertex colours. See docs/outputs.md for the numbers.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

import numpy as np

from sandbox.atomic import atomic_path
from sandbox.errors import SandboxError
from sandbox.render.gl import render_open3d
from sandbox.render.raster import render_numpy
from sandbox.render.view import DEFAULT_STYLE, VIEWS, RenderStyle, check_color, frame_view, prepare

ENV_BACKEND = "SANDBOX_RENDER_BACKEND"
BACKENDS = ("auto", "numpy", "open3d")


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
    style: RenderStyle,
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
    bg = check_color(f"{target}: background", background, None)
    chosen = resolve_backend(backend)
    mesh_list, line_list = prepare(target, meshes, lines)
    points = np.concatenate(
        [m.vertices[np.unique(m.triangles)] for m in mesh_list if len(m.triangles)]
        + [ln.points for ln in line_list if len(ln.points)]
    )
    automatic = backend == "auto" and not os.environ.get(ENV_BACKEND, "").strip()

    def draw_all(draw):
        tiles = []
        for view in views:
            cam = frame_view(view, points, int(width), int(height), style.margin)
            tiles.append(draw(mesh_list, line_list, cam, bg, float(line_width), style))
        return np.concatenate(tiles, axis=1)

    if chosen == "open3d":
        try:
            return draw_all(render_open3d)
        except SandboxError as exc:
            if not automatic:
                raise
            logging.getLogger(__name__).info("%s; using the numpy renderer", exc)
    return draw_all(render_numpy)


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
    style: RenderStyle = DEFAULT_STYLE,
) -> np.ndarray:
    """Render to an RGB ``uint8`` array of shape (height, width * len(views), 3).

    Arguments as for :func:`render_png`.
    """
    return _render(
        "render_image", meshes, lines, views, width, height, background, line_width, backend,
        style,
    )  # fmt: skip


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
    style: RenderStyle = DEFAULT_STYLE,
) -> Path:
    """Render meshes and polylines to a PNG, written atomically; return the path.

    ``meshes``: dicts ``{"vertices": (n, 3), "triangles": (m, 3), "color": (r, g, b)}``
    (colour optional, floats 0..1). ``lines``: dicts ``{"points": (k, 3), "color": ...}``,
    each a polyline drawn ``line_width`` pixels thick. ``views``: names from
    :data:`VIEWS`, placed left to right, each ``width`` x ``height`` pixels.
    ``backend``: ``"auto"``, ``"numpy"`` or ``"open3d"`` (see the module docstring).
    ``style``: margin, ambient light and line depth tolerance
    (:class:`~sandbox.render.view.RenderStyle`).
    """
    import imageio.v3 as iio

    path = Path(path)
    if path.suffix.lower() != ".png":
        raise SandboxError(f"{path}: render output must be a .png file")
    image = _render(
        str(path), meshes, lines, views, width, height, background, line_width, backend, style
    )
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
