"""Gathered seams (sandbox.pattern.gather): a seam side much longer than the other gets a
rest shape drawn in to the other's length; masses and UVs stay the cut's."""

import numpy as np
import pytest

from sandbox.errors import SandboxError
from sandbox.pattern.gather import GatherSettings, gathered_rest, gathered_sides
from sandbox.pattern.panel_mesh import mesh_pattern
from sandbox.pattern.spec import load_pattern


def rect(w: float, h: float, names=("bottom", "right", "top", "left")) -> dict:
    """A w x h cm panel, its edges named counter-clockwise from the bottom."""
    v = [[0, 0], [w, 0], [w, h], [0, h]]
    edges = [{"name": n, "from": i, "to": (i + 1) % 4} for i, n in enumerate(names)]
    return {"vertices": v, "edges": edges, "grain": [0, 1]}


def two_panels(bodice_cm: float, skirt_cm: float = 24.0):
    """A bodice whose bottom edge is sewn to a skirt's top edge, in cm."""
    d = {"format": "sandbox-pattern/1", "name": "gathered", "units": "cm", "fabric": "cotton",
         "mesh_edge": 2.0,
         "panels": {"bodice": rect(bodice_cm, 30.0), "skirt": rect(skirt_cm, 30.0)},
         "seams": [{"a": [{"panel": "bodice", "edge": "bottom"}],
                    "b": [{"panel": "skirt", "edge": "top"}]}]}  # fmt: skip
    return load_pattern(d)


def areas(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    d1, d2 = p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]]
    return 0.5 * (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])


def test_a_side_30_percent_longer_is_drawn_in_to_the_other():
    pattern = two_panels(31.2)
    (g,) = gathered_sides(pattern)
    assert (g.seam, g.side, g.edges) == (0, "a", (("bodice", 0),))
    assert g.length_m == pytest.approx(0.312) and g.to_m == pytest.approx(0.24)
    assert "gathered from 31.2 to 24.0 cm" in g.describe(pattern)
    meshes = mesh_pattern(pattern, 0.02)
    rest = gathered_rest(meshes, [g], 0.02)
    assert set(rest) == {"bodice"}
    m = meshes["bodice"]
    bottom = m.edge_vertices[0]
    length = np.linalg.norm(np.diff(rest["bodice"][bottom], axis=0), axis=1).sum()
    assert length == pytest.approx(0.24, rel=1e-9)  # the edge is straight: exactly
    # drawn in about its middle, along the edge only
    np.testing.assert_allclose(rest["bodice"][bottom, 1], m.points[bottom, 1], atol=1e-15)
    np.testing.assert_allclose(rest["bodice"][bottom, 0].mean(), m.points[bottom, 0].mean())
    # the band: 4 x the largest move (3.6 cm) = 14.4 cm; beyond it the cut is kept
    moved = np.linalg.norm(rest["bodice"] - m.points, axis=1)
    assert moved[m.points[:, 1] > 0.145].max() == 0.0
    assert moved.max() == pytest.approx(0.036, rel=1e-6)
    a0, a1 = areas(m.points, m.triangles), areas(rest["bodice"], m.triangles)
    assert (a1 / a0).min() > 0.7 and (a1 / a0).max() < 1.05  # none turned over


def test_ease_and_short_edges_are_not_gathered():
    assert gathered_sides(two_panels(26.0)) == []  # 8 %: sleeve-cap ease, not a gather
    assert gathered_sides(two_panels(3.0, 2.4)) == []  # 25 % but 6 mm: a mesh edge's rounding
    # a looser rule finds the 8 %
    assert len(gathered_sides(two_panels(26.0), GatherSettings(min_ratio=1.05))) == 1
    with pytest.raises(SandboxError, match="GatherSettings.min_ratio must be a number > 1"):
        GatherSettings(min_ratio=1.0)


def test_the_model_keeps_the_cuts_mass_and_uvs_and_rests_on_the_gathered_shape():
    from sandbox.sim.builder import ModelBuilder
    from sandbox.sim.materials import get_material

    pattern = two_panels(31.2)
    meshes = mesh_pattern(pattern, 0.02)
    rest = gathered_rest(meshes, gathered_sides(pattern), 0.02)
    m = meshes["bodice"]
    cotton = get_material("cotton")
    models = []
    for r in (None, rest["bodice"]):
        b = ModelBuilder()
        b.add_cloth(name="bodice", pattern_uv=m.points, triangles=m.triangles, material=cotton,
                    rest_uv=r)  # fmt: skip
        models.append(b.finalize(bending=True))
    cut, gathered = models
    mass = [1.0 / md.particle_inv_mass.to_numpy()[: md.particle_count] for md in models]
    np.testing.assert_allclose(mass[0], mass[1], rtol=1e-12)
    assert mass[0].sum() == pytest.approx(cotton.density_kg_m2 * 0.312 * 0.30, rel=1e-9)
    np.testing.assert_array_equal(cut.material_uv_np, gathered.material_uv_np)
    # Eq. 6's rest area: the gathered band is smaller; elsewhere the same
    area = [md.tri_rest_area.to_numpy()[: len(m.triangles)] for md in models]
    assert area[1].sum() < area[0].sum() - 0.5 * 0.072 * 0.05
    with pytest.raises(SandboxError, match="rest coordinates must be finite"):
        ModelBuilder().add_cloth(name="x", pattern_uv=m.points, triangles=m.triangles,
                                 material=cotton, rest_uv=m.points[:-1])  # fmt: skip
