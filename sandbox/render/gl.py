"""The Open3D backend of :mod:`sandbox.render.offscreen`: the legacy ``Visualizer`` in a
hidden window (headless EGL or GLX), meshes unlit with the colours shaded here, lines as
camera-facing ribbons, a distant pinhole standing in for the orthographic camera."""

from __future__ import annotations

import atexit
import os
import tempfile
from pathlib import Path

import numpy as np

from sandbox.errors import SandboxError
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


def _ribbons(lines: list[DrawLine], cam: Camera, line_width: float, style: RenderStyle):
    """Camera-facing quads for the segments and square caps for the joints."""
    half = line_radius(line_width) / cam.scale
    lift = -cam.forward * line_bias(cam, style.line_depth_tolerance)  # as the numpy backend
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


def render_open3d(
    meshes: list[DrawMesh],
    lines: list[DrawLine],
    cam: Camera,
    background: np.ndarray,
    line_width: float,
    style: RenderStyle,
) -> np.ndarray:
    """One view as an (h, w, 3) uint8 image; ``line_width`` [px]."""
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
            add(mesh.vertices, mesh.triangles, shade(mesh, cam, style.ambient))
    if any(len(line.points) for line in lines):
        add(*_ribbons(lines, cam, line_width, style))

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
    return to_uint8(image[:, :, :3])
