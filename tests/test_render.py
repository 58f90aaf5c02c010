"""Mesh files (OBJ/PLY with UVs, reading) and offscreen rendering (numpy and Open3D)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest
import trimesh

from sandbox.errors import SandboxError
from sandbox.render import (
    ENV_BACKEND,
    image_is_blank,
    read_mesh,
    render_image,
    render_png,
    resolve_backend,
    write_mesh,
)

# ---------------------------------------------------------------------------------------
# fixtures


def panel(nx: int = 7, ny: int = 5, seed: int = 0):
    """A curved rectangular cloth panel: vertices (m), triangles, pattern UVs (m)."""
    rng = np.random.default_rng(seed)
    u, v = np.meshgrid(np.linspace(0.0, 0.43, nx), np.linspace(0.0, 0.61, ny))
    uv = np.c_[u.ravel(), v.ravel()] + rng.normal(scale=1e-3, size=(nx * ny, 2))
    xyz = np.c_[uv[:, 0] - 0.2, uv[:, 1] + 0.9, 0.1 * np.sin(3.0 * uv[:, 0])]
    tris = []
    for j in range(ny - 1):
        for i in range(nx - 1):
            a, b, c, d = j * nx + i, j * nx + i + 1, (j + 1) * nx + i, (j + 1) * nx + i + 1
            tris += [(a, b, d), (a, d, c)]
    return xyz, np.array(tris, dtype=np.int64), uv


def obj_uvs(path: Path) -> np.ndarray:
    """Per-vertex UVs from an OBJ, mapped through the face v/vt pairs."""
    lines = path.read_text().splitlines()
    n = sum(line.startswith("v ") for line in lines)
    vt = np.array([[float(x) for x in line.split()[1:3]] for line in lines if line[:3] == "vt "])
    out = np.full((n, 2), np.nan)
    for line in lines:
        if line.startswith("f "):
            for corner in line.split()[1:]:
                vi, ti = (int(x) - 1 for x in corner.split("/")[:2])
                out[vi] = vt[ti]
    return out


def sphere(centre=(0.0, 0.0, 0.0), radius=1.0, subdivisions=3):
    s = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    return np.asarray(s.vertices) + np.asarray(centre), np.asarray(s.faces)


def non_background_box(img: np.ndarray, background=(255, 255, 255)):
    mask = (img[:, :, :3] != np.asarray(background, dtype=img.dtype)).any(axis=2)
    ys, xs = np.nonzero(mask)
    return xs.min(), xs.max(), ys.min(), ys.max()


def assert_centred(img: np.ndarray, tol: float = 0.10):
    h, w = img.shape[:2]
    x0, x1, y0, y1 = non_background_box(img)
    assert abs(0.5 * (x0 + x1 + 1) - 0.5 * w) <= tol * w
    assert abs(0.5 * (y0 + y1 + 1) - 0.5 * h) <= tol * h


def has_color(img: np.ndarray, rgb) -> bool:
    return bool((img[:, :, :3] == np.asarray(rgb, dtype=np.uint8)).all(axis=2).any())


# ---------------------------------------------------------------------------------------
# write_mesh / read_mesh


def test_obj_round_trip_keeps_vertices_order_and_uvs(tmp_path):
    v, t, uv = panel()
    path = write_mesh(tmp_path / "panel.obj", v, t, uvs=uv)
    assert path == tmp_path / "panel.obj"
    text = path.read_text()
    assert sum(line.startswith("vt ") for line in text.splitlines()) == len(v)
    np.testing.assert_allclose(obj_uvs(path), uv, rtol=0, atol=1e-8)
    rv, rt = read_mesh(path)
    assert rv.dtype == np.float64 and rt.dtype == np.int64
    np.testing.assert_allclose(rv, v, rtol=0, atol=1e-8)
    np.testing.assert_array_equal(rt, t)
    loaded = trimesh.load(path, process=False, maintain_order=True)
    np.testing.assert_allclose(loaded.visual.uv, uv, rtol=0, atol=1e-8)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["panel.obj"]  # no .mtl, no temp


def test_ply_round_trip_keeps_uvs(tmp_path):
    v, t, uv = panel()
    path = write_mesh(tmp_path / "panel.ply", v, t, uvs=uv)
    header = path.read_bytes().split(b"end_header")[0].decode("ascii")
    assert "binary_little_endian" in header
    assert "property double s" in header and "property double t" in header
    rv, rt = read_mesh(path)
    np.testing.assert_allclose(rv, v, rtol=0, atol=1e-6)  # float32 positions
    np.testing.assert_array_equal(rt, t)
    loaded = trimesh.load(path, process=False)
    np.testing.assert_allclose(loaded.visual.uv, uv, rtol=0, atol=1e-12)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["panel.ply"]


@pytest.mark.parametrize("suffix", [".obj", ".ply"])
def test_vertex_colors_and_uvs_together(tmp_path, suffix):
    v, t, uv = panel()
    colors = np.linspace(0, 1, 3 * len(v)).reshape(-1, 3)
    path = write_mesh(tmp_path / f"c{suffix}", v, t, uvs=uv, vertex_colors=colors)
    loaded = trimesh.load(path, process=False, maintain_order=True)
    if suffix == ".obj":
        np.testing.assert_allclose(obj_uvs(path), uv, atol=1e-8)
        rows = [line.split() for line in path.read_text().splitlines() if line[:2] == "v "]
        np.testing.assert_allclose(np.array(rows)[:, 4:].astype(float), colors, atol=1e-6)
    else:
        np.testing.assert_allclose(loaded.visual.uv, uv, atol=1e-12)
        header = path.read_bytes().split(b"end_header")[0].decode("ascii")
        assert "property uchar red" in header
    np.testing.assert_array_equal(read_mesh(path)[1], t)


def test_write_without_uvs(tmp_path):
    v, t, _ = panel()
    for name in ("a.obj", "a.ply"):
        rv, rt = read_mesh(write_mesh(tmp_path / name, v, t))
        np.testing.assert_allclose(rv, v, atol=1e-6)
        np.testing.assert_array_equal(rt, t)


def _bad_inputs():
    v, t, uv = panel()
    nan_v = v.copy()
    nan_v[3, 1] = np.nan
    out_of_range = t.copy()
    out_of_range[2, 0] = len(v)
    negative = t.copy()
    negative[0, 0] = -1
    return {
        "nan vertices": ((nan_v, t), {}, "NaN"),
        "index out of range": ((v, out_of_range), {}, "out of range"),
        "negative index": ((v, negative), {}, "out of range"),
        "vertices not (n, 3)": ((v[:, :2], t), {}, "shape"),
        "triangles not (m, 3)": ((v, np.c_[t, t[:, :1]]), {}, "shape"),
        "float triangles": ((v, t.astype(float)), {}, "integers"),
        "no triangles": ((v, np.zeros((0, 3), int)), {}, "empty"),
        "uvs wrong rows": ((v, t), {"uvs": uv[:-1]}, "one row per vertex"),
        "uvs not (n, 2)": ((v, t), {"uvs": v}, "shape"),
        "nan uvs": ((v, t), {"uvs": np.where(uv > 0.3, np.nan, uv)}, "NaN"),
        "colours out of 0..1": ((v, t), {"vertex_colors": v * 10}, "0..1"),
    }


@pytest.mark.parametrize("suffix", [".obj", ".ply"])
@pytest.mark.parametrize("case", list(_bad_inputs()))
def test_write_mesh_rejects_bad_input_and_leaves_no_file(tmp_path, suffix, case):
    args, kwargs, words = _bad_inputs()[case]
    path = tmp_path / f"bad{suffix}"
    with pytest.raises(SandboxError) as err:
        write_mesh(path, *args, **kwargs)
    assert str(path) in str(err.value) and words in str(err.value)
    assert list(tmp_path.iterdir()) == []


def test_write_mesh_rejects_unknown_suffix(tmp_path):
    v, t, _ = panel()
    with pytest.raises(SandboxError, match="format"):
        write_mesh(tmp_path / "x.stl", v, t)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("suffix", [".obj", ".ply"])
def test_failed_write_leaves_old_file_and_no_temp(tmp_path, monkeypatch, suffix):
    v, t, uv = panel()
    path = tmp_path / f"keep{suffix}"
    path.write_bytes(b"old contents")

    def broken(self, data):
        with open(self, "wb") as fh:
            fh.write(data[:10])
        raise OSError("disk full")

    monkeypatch.setattr(Path, "write_bytes", broken)
    with pytest.raises(SandboxError, match="disk full"):
        write_mesh(path, v, t, uvs=uv)
    monkeypatch.undo()
    assert path.read_bytes() == b"old contents"
    assert [p.name for p in tmp_path.iterdir()] == [path.name]


def test_read_mesh_other_formats(tmp_path):
    box = trimesh.creation.box((0.3, 0.5, 0.2))
    box.export(tmp_path / "box.stl")
    v, t = read_mesh(tmp_path / "box.stl")
    assert v.shape == (8, 3) and t.shape == (12, 3)  # STL corners merged
    scene = trimesh.Scene()
    scene.add_geometry(box, node_name="a")
    scene.add_geometry(
        box, node_name="b", transform=trimesh.transformations.translation_matrix([2, 0, 0])
    )
    scene.export(tmp_path / "two.glb")
    v, t = read_mesh(tmp_path / "two.glb")
    assert t.shape == (24, 3)
    np.testing.assert_allclose(v.max(axis=0), [2.15, 0.25, 0.1])
    (tmp_path / "quad.obj").write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    v, t = read_mesh(tmp_path / "quad.obj")
    assert v.shape == (4, 3) and t.shape == (2, 3)


@pytest.mark.parametrize(
    ("name", "content", "words"),
    [
        ("missing.obj", None, "not found"),
        ("empty.ply", b"", "empty"),
        ("garbage.ply", b"this is not a ply file\n" * 5, "could not read"),
        ("garbage.glb", b"xx", "could not read"),
        ("points.obj", b"v 0 0 0\nv 1 0 0\n", "no triangles"),
        ("text.obj", b"hello world\n", "no triangles"),
        ("mesh.txt", b"v 0 0 0\n", "format"),
    ],
)
def test_read_mesh_errors(tmp_path, name, content, words):
    path = tmp_path / name
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(SandboxError) as err:
        read_mesh(path)
    assert str(path) in str(err.value) and words in str(err.value)


# ---------------------------------------------------------------------------------------
# rendering, numpy backend


def test_sphere_render_is_not_blank_and_centred(tmp_path):
    v, t = sphere(centre=(3.0, 1.5, -2.0), radius=0.4)
    path = render_png(
        tmp_path / "s.png",
        [{"vertices": v, "triangles": t, "color": (0.8, 0.3, 0.2)}],
        width=200,
        height=160,
        backend="numpy",
    )
    img = iio.imread(path)
    assert img.shape == (160, 200, 3)
    assert not image_is_blank(img, (1, 1, 1))
    assert image_is_blank(img[:3, :3], (1, 1, 1))  # corners are background
    assert_centred(img)
    x0, x1, y0, y1 = non_background_box(img)
    assert y1 - y0 + 1 >= 0.85 * 160  # the camera frames the object
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 20  # shaded, not flat
    assert [p.name for p in tmp_path.iterdir()] == ["s.png"]


def test_style_margin_and_ambient():
    """RenderStyle: a 25 % margin frames the sphere in half the image height instead of
    90 %; without ambient light the darkest lit pixel gets darker."""
    from sandbox.render.view import RenderStyle

    v, t = sphere(radius=0.4)
    meshes = [{"vertices": v, "triangles": t, "color": (0.8, 0.8, 0.8)}]
    plain = render_image(meshes, width=160, height=160, backend="numpy")
    wide = render_image(meshes, width=160, height=160, backend="numpy",
                        style=RenderStyle(margin=0.25))  # fmt: skip
    _, _, y0, y1 = non_background_box(plain)
    _, _, w0, w1 = non_background_box(wide)
    assert y1 - y0 + 1 == pytest.approx(0.9 * 160, abs=2)
    assert w1 - w0 + 1 == pytest.approx(0.5 * 160, abs=2)
    dark = render_image(meshes, width=160, height=160, backend="numpy",
                        style=RenderStyle(ambient=0.0))  # fmt: skip
    assert dark.min() < plain.min()


def asymmetric_scene():
    body_v, body_t = sphere(radius=0.5, subdivisions=2)
    arm = trimesh.creation.box((0.6, 0.15, 0.15))
    arm.apply_translation([0.6, 0.2, 0.0])  # sticks out toward +X only
    return [
        {"vertices": body_v, "triangles": body_t, "color": (0.7, 0.7, 0.7)},
        {"vertices": arm.vertices, "triangles": arm.faces, "color": (0.2, 0.3, 0.9)},
    ]


def test_front_and_back_views_differ_for_asymmetric_object():
    img = render_image(asymmetric_scene(), views=("front", "back", "side"), width=120, height=100)
    assert img.shape == (100, 360, 3)
    front, back, side = img[:, :120], img[:, 120:240], img[:, 240:]
    assert not np.array_equal(front, back)
    blue = (front[:, :, 2].astype(int) - front[:, :, 0]) > 60
    assert blue[:, 60:].sum() > 50 and blue[:, :60].sum() == 0  # +X is right in front
    blue = (back[:, :, 2].astype(int) - back[:, :, 0]) > 60
    assert blue[:, :60].sum() > 50 and blue[:, 60:].sum() == 0  # and left from the back
    assert not image_is_blank(side)


def test_lines_are_drawn_in_their_colour_and_hidden_behind_the_body():
    v, t = sphere(radius=0.5, subdivisions=2)
    front_line = {"points": [[-0.8, 0.0, 0.6], [0.8, 0.1, 0.6]], "color": (0.0, 1.0, 0.0)}
    hidden_line = {"points": [[-0.2, -0.3, -0.7], [0.2, -0.3, -0.7]], "color": (1.0, 0.0, 1.0)}
    img = render_image(
        [{"vertices": v, "triangles": t, "color": (0.5, 0.5, 0.5)}],
        lines=[front_line, hidden_line],
        views=("front", "back"),
        width=150,
        height=150,
    )
    front, back = img[:, :150], img[:, 150:]
    assert (front == [0, 255, 0]).all(axis=2).sum() > 150 * 2  # at least ~2 px thick
    assert not has_color(front, (255, 0, 255))
    assert has_color(back, (255, 0, 255))


def test_lines_only_and_custom_background():
    img = render_image(
        [],
        lines=[{"points": np.c_[np.cos(np.arange(9)), np.sin(np.arange(9)), np.zeros(9)]}],
        width=64,
        height=64,
        background=(0.0, 0.0, 0.2),
    )
    assert has_color(img, (0, 0, 0))  # default line colour
    assert (img[0, 0] == [0, 0, 51]).all()
    assert not image_is_blank(img, (0.0, 0.0, 0.2))
    assert image_is_blank(np.zeros((4, 4, 3), np.uint8) + [0, 0, 51], (0.0, 0.0, 0.2))


def test_image_is_blank_variants(tmp_path):
    white = np.full((10, 12, 3), 255, np.uint8)
    assert image_is_blank(white) and image_is_blank(white, (1, 1, 1))
    assert not image_is_blank(white, (0, 0, 0))
    dotted = white.copy()
    dotted[4, 5] = [254, 255, 255]
    assert not image_is_blank(dotted)
    rgba = np.dstack([white, np.zeros((10, 12), np.uint8)])
    assert image_is_blank(rgba, (1, 1, 1))
    iio.imwrite(tmp_path / "w.png", white)
    assert image_is_blank(tmp_path / "w.png", (1, 1, 1))
    assert image_is_blank(np.ones((3, 3)), (1, 1, 1))


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"views": ("top",)}, "unknown view"),
        ({"views": ()}, "no views"),
        ({"backend": "opengl"}, "backend"),
        ({"width": 0}, "width"),
        ({"background": (2, 0, 0)}, "0..1"),
        ({"meshes": []}, "nothing to render"),
        ({"meshes": [{"vertices": np.zeros((3, 2)), "triangles": [[0, 1, 2]]}]}, "meshes[0]"),
        ({"meshes": [{"vertices": np.zeros((3, 3)), "triangles": [[0, 1, 3]]}]}, "range"),
        ({"lines": [{"points": [[0, 0, np.nan]]}]}, "lines[0]"),
    ],
)
def test_render_png_errors_leave_no_file(tmp_path, kwargs, words):
    v, t = sphere(subdivisions=1)
    args = {"meshes": [{"vertices": v, "triangles": t}], "width": 32, "height": 32}
    args.update(kwargs)
    path = tmp_path / "x.png"
    with pytest.raises(SandboxError) as err:
        render_png(path, args.pop("meshes"), **args)
    assert words in str(err.value)
    assert list(tmp_path.iterdir()) == []


def test_render_png_needs_png_suffix(tmp_path):
    v, t = sphere(subdivisions=1)
    with pytest.raises(SandboxError, match="png"):
        render_png(tmp_path / "x.jpg", [{"vertices": v, "triangles": t}])


def test_backend_choice_and_environment(monkeypatch):
    monkeypatch.delenv(ENV_BACKEND, raising=False)
    assert resolve_backend() == "open3d"  # the project renderer; numpy is the fallback
    assert resolve_backend("open3d") == "open3d"
    monkeypatch.setenv(ENV_BACKEND, "open3d")
    assert resolve_backend("auto") == "open3d"
    assert resolve_backend("numpy") == "numpy"  # an explicit choice wins
    monkeypatch.setenv(ENV_BACKEND, "bogus")
    with pytest.raises(SandboxError, match=ENV_BACKEND):
        resolve_backend()
    with pytest.raises(SandboxError, match="unknown render backend"):
        resolve_backend("vulkan")


def test_numpy_backend_renders_20k_triangles_quickly():
    v, t = sphere(subdivisions=5)  # 20480 triangles
    assert len(t) == 20480
    meshes = [{"vertices": v, "triangles": t, "color": (0.6, 0.6, 0.8)}]
    start = time.perf_counter()
    img = render_image(meshes, width=640, height=640, backend="numpy")
    elapsed = time.perf_counter() - start
    assert not image_is_blank(img, (1, 1, 1))
    assert elapsed < 5.0  # ~0.3 s on a 2-core machine; generous for loaded CI


# ---------------------------------------------------------------------------------------
# rendering, open3d backend


@pytest.fixture(scope="module")
def open3d_images():
    """Front and back views from both backends, rendered once."""
    pytest.importorskip("open3d")
    meshes = asymmetric_scene()
    lines = [{"points": [[-0.8, 0.0, 0.6], [0.8, 0.1, 0.6]], "color": (0.0, 1.0, 0.0)}]
    kw = {"lines": lines, "views": ("front", "back"), "width": 160, "height": 160}
    try:
        o3d_img = render_image(meshes, backend="open3d", **kw)
    except SandboxError as exc:
        if "unavailable" in str(exc):  # no EGL / OpenGL context on this machine
            pytest.skip(str(exc))
        raise
    return o3d_img, render_image(meshes, backend="numpy", **kw)


def test_open3d_backend_matches_numpy(open3d_images):
    o3d_img, np_img = open3d_images
    assert o3d_img.shape == np_img.shape == (160, 320, 3)
    front, back = o3d_img[:, :160], o3d_img[:, 160:]
    for tile in (front, back):
        assert not image_is_blank(tile, (1, 1, 1))
        assert (tile[0, 0] == 255).all()  # the background is exact
        assert_centred(tile)
    assert not np.array_equal(front, back)
    assert has_color(front, (0, 255, 0))
    differ = np.abs(o3d_img.astype(int) - np_img).max(axis=2) > 16
    assert differ.mean() < 0.02  # same camera and shading; only edge pixels may differ


def test_open3d_backend_reuses_its_window_and_changes_size(open3d_images):
    v, t = sphere(subdivisions=2)
    meshes = [{"vertices": v, "triangles": t, "color": (0.2, 0.6, 0.3)}]
    for size in ((96, 64), (96, 64), (50, 70)):
        img = render_image(meshes, width=size[0], height=size[1], backend="open3d")
        assert img.shape == (size[1], size[0], 3)
        assert_centred(img)


def test_open3d_backend_without_opengl_fails_cleanly(open3d_images, tmp_path):
    """No EGL driver and no display: a SandboxError, not a crash of the process."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["__EGL_VENDOR_LIBRARY_FILENAMES"] = str(tmp_path / "none.json")
    code = textwrap.dedent(
        """
        from sandbox.errors import SandboxError
        from sandbox.render import render_image
        try:
            render_image([{"vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
                           "triangles": [[0, 1, 2]]}], backend="open3d")
        except SandboxError as exc:
            print("SANDBOX-ERROR", exc)
        """
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "SANDBOX-ERROR open3d render backend unavailable" in proc.stdout
