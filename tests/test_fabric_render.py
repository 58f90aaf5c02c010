"""The fabric's look, strain maps and export: textures follow the grain, Eq. 6 per triangle
against hand-made deformations, glTF and OBJ + MTL read back by trimesh and Open3D."""

import math

import numpy as np
import pytest
import trimesh

from sandbox.render.export import read_glb_garment, write_glb, write_textured_obj
from sandbox.render.fabric import (
    CHECK_M,
    TILE_M,
    fabric_texture,
    sample_texture,
    subdivide,
    textured_mesh,
)
from sandbox.render.offscreen import image_is_blank, render_image
from sandbox.render.strain import strain_figure, strain_scale, triangle_strain
from sandbox.render.studio import main as render_main
from sandbox.sim.builder import ModelBuilder
from sandbox.sim.materials import get_material

BLUE = (0.32, 0.45, 0.75)


def sheet(n=12, size=0.3):
    """A flat square of (n+1)² vertices in the xy plane: positions, triangles, uv."""
    s = np.linspace(0.0, size, n + 1)
    uu, vv = np.meshgrid(s, s, indexing="xy")
    uv = np.stack([uu.ravel(), vv.ravel()], 1)
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    tris = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    x = np.column_stack([uv, np.zeros(len(uv))])
    return x, tris, uv


def test_texture_bands_follow_warp_and_weft():
    tex = fabric_texture(BLUE, px=400)
    assert tex.shape == (400, 400, 3) and tex.dtype == np.uint8
    # at the middle of a check period both bands cross; a quarter in, neither
    mid = (np.array([0.5, 0.5]) * CHECK_M)[None, :]
    plain = (np.array([0.1, 0.1]) * CHECK_M)[None, :]
    warp = (np.array([0.1, 0.5]) * CHECK_M)[None, :]  # on a band along the warp: light
    weft = (np.array([0.5, 0.1]) * CHECK_M)[None, :]  # on a band along the weft: dark
    c = {k: sample_texture(tex, p)[0] for k, p in
         dict(mid=mid, plain=plain, warp=warp, weft=weft).items()}  # fmt: skip
    np.testing.assert_allclose(c["plain"], BLUE, atol=0.02)
    assert c["warp"].sum() > c["plain"].sum() + 0.5
    assert c["weft"].sum() < c["plain"].sum() - 0.2
    # the texture repeats every TILE_M
    np.testing.assert_allclose(sample_texture(tex, warp + TILE_M), c["warp"][None], atol=1e-9)


def area(v, f):
    return (
        0.5
        * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1).sum()
    )


def test_subdivide_keeps_the_surface():
    x, t, uv = sheet(3)
    fv, ft, fuv = subdivide(x, t, uv, 4)
    assert len(ft) == 16 * len(t)
    assert area(fv, ft) == pytest.approx(area(x, t), rel=1e-12)
    np.testing.assert_allclose(fv[:, :2], fuv, atol=1e-12)  # the sheet lies at its rest shape


def test_eq6_per_triangle_against_hand_made_deformations():
    x, t, uv = sheet(4)
    z = np.zeros(len(uv))
    stretched = np.column_stack([1.1 * uv[:, 0], 0.95 * uv[:, 1], z])
    s = triangle_strain(stretched, t, uv)
    np.testing.assert_allclose(s[:, 0], 0.10, atol=1e-12)
    np.testing.assert_allclose(s[:, 1], -0.05, atol=1e-12)
    np.testing.assert_allclose(s[:, 2], 0.0, atol=1e-12)
    gamma = 0.2  # simple shear along the warp: sin(2θ_s) = F_u·F_v / (S_u S_v)
    sheared = np.column_stack([uv[:, 0] + gamma * uv[:, 1], uv[:, 1], z])
    s = triangle_strain(sheared, t, uv)
    np.testing.assert_allclose(s[:, 2], math.asin(gamma / math.sqrt(1 + gamma**2)), atol=1e-12)
    np.testing.assert_allclose(s[:, 1], math.sqrt(1 + gamma**2) - 1.0, atol=1e-12)
    # a rigid motion strains nothing
    c, sn = math.cos(0.7), math.sin(0.7)
    rot = x @ np.array([[c, 0, -sn], [0, 1, 0], [sn, 0, c]]).T + 0.3
    np.testing.assert_allclose(triangle_strain(rot, t, uv), 0.0, atol=1e-12)
    assert strain_scale(np.array([0.0, 0.012, -0.003])) == pytest.approx(0.015)
    assert strain_scale(np.zeros(3)) == pytest.approx(0.01)


def test_material_coordinates_turn_with_the_grain():
    x, t, uv = sheet(2)
    b = ModelBuilder()
    b.add_cloth(name="a", pattern_uv=uv, triangles=t, material=get_material("cotton"))
    b.add_cloth(name="b", pattern_uv=uv, triangles=t, material=get_material("cotton"),
                grain_rad=math.pi / 2)  # fmt: skip
    m = b.finalize()
    n = len(uv)
    np.testing.assert_allclose(m.material_uv_np[:n], uv, atol=1e-12)
    # a warp along the pattern's y: u = y, v = −x
    np.testing.assert_allclose(m.material_uv_np[n:], np.column_stack([uv[:, 1], -uv[:, 0]]),
                               atol=1e-12)  # fmt: skip
    np.testing.assert_allclose(m.rest_uv_np[n:], uv)


def test_textured_render_shows_the_check():
    x, t, uv = sheet(10)
    mesh = textured_mesh(x, t, uv, BLUE, pixel_m=0.3 / 200)
    img = render_image([mesh], views=("front",), width=200, height=200, backend="numpy")
    assert not image_is_blank(img)
    inner = img[40:160, 40:160].reshape(-1, 3).astype(int)
    # light warp bands, dark weft bands and plain cloth between: a spread of brightness
    lum = inner.sum(1)
    assert np.percentile(lum, 95) - np.percentile(lum, 5) > 120


def test_strain_figure_has_three_maps_and_legends():
    x, t, uv = sheet(8)
    pulled = np.column_stack([uv[:, 0] * (1 + 0.2 * uv[:, 1]), uv[:, 1], np.zeros(len(uv))])
    img, summary = strain_figure(pulled, t, uv, size=160, backend="numpy")
    assert img.shape[1] == 3 * 160 and img.shape[0] > 160
    assert set(summary) == {"warp", "weft", "shear"}
    assert summary["warp"]["max_percent"] == pytest.approx(6.0, abs=0.5)
    warp_tile = img[:160, :160].reshape(-1, 3).astype(int)
    reddish = (warp_tile[:, 0] - warp_tile[:, 2]) > 40
    assert reddish.sum() > 100  # stretched triangles drawn red


def test_glb_reads_back_in_trimesh_and_open3d(tmp_path):
    o3d = pytest.importorskip("open3d")
    x, t, uv = sheet(6)
    x = x + np.array([0.0, 1.0, 0.1])
    body = (np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0.0]]), np.array([[0, 1, 2]]))
    path = write_glb(tmp_path / "garment.glb", x, t, uv, BLUE, body=body)
    v2, t2, uv2 = read_glb_garment(path)
    np.testing.assert_allclose(v2, x, atol=1e-6)
    np.testing.assert_allclose(uv2, uv, atol=1e-6)
    np.testing.assert_array_equal(t2, t)
    model = o3d.io.read_triangle_model(str(path))
    garment = next(m for m in model.meshes if m.mesh_name == "garment")
    assert len(garment.mesh.vertices) == len(x)
    corners = np.asarray(garment.mesh.triangle_uvs).reshape(-1, 3, 2)
    got = {tuple(np.round(np.sort(c, axis=0).ravel(), 6)) for c in corners}
    want = {tuple(np.round(np.sort(c, axis=0).ravel(), 6)) for c in uv[t]}
    assert got == want  # the same UVs at every triangle's corners (Open3D reorders vertices)
    material = model.materials[garment.material_idx]
    assert np.asarray(material.albedo_img).shape[:2] == fabric_texture(BLUE).shape[:2]
    assert not list(tmp_path.glob(".*"))  # no temporary left


def test_textured_obj_has_its_material_and_texture(tmp_path):
    x, t, uv = sheet(4)
    paths = write_textured_obj(tmp_path / "garment.obj", x, t, uv, BLUE)
    assert "map_Kd garment_texture.png" in paths["mtl"].read_text()
    assert paths["obj"].read_text().splitlines()[1] == "mtllib garment.mtl"
    mesh = trimesh.load(str(paths["obj"]), process=False, maintain_order=True)
    assert mesh.visual.material.image.size == (2048, 2048)
    np.testing.assert_allclose(mesh.visual.uv, uv, atol=1e-9)
    assert len(mesh.vertices) == len(x)


def test_render_cli_strain_maps(tmp_path, capsys):
    x, t, uv = sheet(6)
    pulled = np.column_stack([1.03 * uv[:, 0], uv[:, 1], np.zeros(len(uv))])
    write_glb(tmp_path / "garment.glb", pulled, t, uv, BLUE)
    code = render_main([str(tmp_path), "--strain", "--views", "front", "--size", "200", "200",
                        "--backend", "numpy"])  # fmt: skip
    assert code == 0 and (tmp_path / "strain_front.png").is_file()
    assert "warp : +3.0 to +3.0 %" in capsys.readouterr().out
    # without the rest shape: a clear error, no traceback
    other = tmp_path / "plain"
    other.mkdir()
    trimesh.Trimesh(x, t).export(other / "garment.obj")
    assert render_main([str(other), "--strain", "--backend", "numpy"]) == 2
    assert "needs the rest shape" in capsys.readouterr().err
