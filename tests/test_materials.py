"""Materials: Wang 2011 conversion, presets, direction-dependent bending, spec errors."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from sandbox.errors import SandboxError
from sandbox.sim import materials as mat
from sandbox.sim.materials import (
    Material,
    bend_rigidity_at,
    from_wang2011,
    get_material,
    list_presets,
    material_from_spec,
    materials_table_markdown,
    scale,
    wang2011_arcsim_coefficients,
    wang2011_names,
)

REPO = Path(__file__).resolve().parents[1]
PACKAGED = REPO / "sandbox" / "data" / "fabrics_wang2011.json"
SUMMARY = json.loads(PACKAGED.read_text(encoding="utf-8"))["fabrics_small_strain_summary"]
WHERE = "scene.toml: cloth[0].material"
EVERYDAY = ["cotton", "silk", "denim", "jersey", "knit", "polyester"]
REL = 1e-6


def test_packaged_data_is_the_shared_copy():
    shared = Path("/work/shared/data/fabrics_wang2011.json")
    if not shared.exists():
        pytest.skip("shared data directory not present")
    assert PACKAGED.read_bytes() == shared.read_bytes()


def test_ten_fabrics():
    assert wang2011_names() == list(SUMMARY)
    assert len(wang2011_names()) == 10


@pytest.mark.parametrize("name", list(SUMMARY))
def test_arcsim_coefficients_match_summary(name):
    k = wang2011_arcsim_coefficients(name)
    s = SUMMARY[name]
    for key, value in s["k_small_strain_N_per_m"].items():
        assert k[key] == pytest.approx(value, rel=REL, abs=1e-9)
    for deg in (0, 45, 90):
        assert k[f"ke_edge_{deg}deg"] == pytest.approx(
            s["bending_ke_at_zero_curv_Nm"][f"edge_{deg}deg"], rel=REL
        )


@pytest.mark.parametrize("name", list(SUMMARY))
def test_conversion_matches_summary(name):
    m = from_wang2011(name)
    s = SUMMARY[name]
    assert m.name == name
    assert m.density_kg_m2 == pytest.approx(s["density_kg_m2"], rel=REL)
    assert m.stretch_u_N_m == pytest.approx(s["uniaxial_Y_u_N_per_m"], rel=REL)
    assert m.stretch_v_N_m == pytest.approx(s["uniaxial_Y_v_N_per_m"], rel=REL)
    assert m.shear_N_m == pytest.approx(s["shear_modulus_G_N_per_m"], rel=REL)
    b_edge0, b_edge45, b_edge90 = s["B_equiv_equilateral_Nm"]
    # ARCSim rows are hinge-EDGE directions: edge along u (0°) bends about u, i.e. the
    # curvature runs along v -> weft strip; edge along v (90°) -> warp strip.
    assert m.bend_weft_Nm == pytest.approx(b_edge0, rel=REL)
    assert m.bend_bias_Nm == pytest.approx(b_edge45, rel=REL)
    assert m.bend_warp_Nm == pytest.approx(b_edge90, rel=REL)
    c_edge0, c_edge45, c_edge90 = s["bending_length_equiv_cm"]
    c_warp, c_weft, c_bias = (100 * c for c in m.bending_lengths_m())
    assert (c_weft, c_bias, c_warp) == pytest.approx((c_edge0, c_edge45, c_edge90), rel=REL)


def test_conversion_by_hand_gray_interlock():
    # row 0 = [16.593832, -14.69599, 34.477123, 36.860302]: k1 < 0 is clamped to 0.
    m = from_wang2011("gray-interlock")
    assert m.stretch_u_N_m == pytest.approx(2 * 16.593832)
    assert m.stretch_v_N_m == pytest.approx(2 * 34.477123)
    assert m.shear_N_m == pytest.approx(2 * 36.860302 / 4)


def test_uniaxial_stiffness_is_free_contraction_minimum():
    # E_u is ARCSim's energy minimised over the lateral strain (k1 large for this one).
    k = wang2011_arcsim_coefficients("tango-red-jet-set")
    eps_u = 1e-3
    ev = np.linspace(-2e-3, 2e-3, 400001)
    energy = 0.5 * (k["k0_uu"] * eps_u**2 + 2 * k["k1_uv"] * eps_u * ev + k["k2_vv"] * ev**2)
    e_u = 2 * energy.min() / eps_u**2
    assert e_u == pytest.approx(from_wang2011("tango-red-jet-set").stretch_u_N_m, rel=1e-5)


def test_preset_lists():
    names = list_presets()
    for n in [*EVERYDAY, *SUMMARY]:
        assert n in names
    assert len(names) == len(set(names))


@pytest.mark.parametrize("name", [*EVERYDAY, "sweater", "ponte", "swimwear", "blanket"])
def test_everyday_presets_plausible(name):
    m = get_material(name)
    assert m.name == name
    assert 0.05 <= m.density_kg_m2 <= 0.5
    for b in (m.bend_warp_Nm, m.bend_weft_Nm, m.bend_bias_Nm):
        c = (b / (m.density_kg_m2 * 9.80665)) ** (1 / 3)
        assert 0.005 <= c <= 0.04
    assert min(m.stretch_u_N_m, m.stretch_v_N_m, m.shear_N_m) > 0
    assert m.source
    wang = mat.EVERYDAY_PRESETS[name][0]
    assert wang in m.source
    base = from_wang2011(wang)
    assert m.stretch_u_N_m == base.stretch_u_N_m and m.bend_warp_Nm == base.bend_warp_Nm


def test_silk_is_the_lightest_most_flexible():
    silk = get_material("silk")
    wang = [from_wang2011(n) for n in wang2011_names()]
    assert silk.density_kg_m2 == min(m.density_kg_m2 for m in wang)
    mean_b = [(m.bend_warp_Nm + m.bend_weft_Nm + m.bend_bias_Nm) / 3 for m in wang]
    assert (silk.bend_warp_Nm + silk.bend_weft_Nm + silk.bend_bias_Nm) / 3 == min(mean_b)


def test_get_material_normalises_names():
    assert get_material("Royal_Target") == get_material("royal-target")
    assert get_material(" Silk ").name == "silk"


def test_bend_rigidity_at_directions():
    m = Material("t", 0.2, 1.0, 1.0, 1.0, 3e-6, 2e-6, 7e-6, "test")
    assert bend_rigidity_at(m, math.pi / 2) == pytest.approx(3e-6)
    assert bend_rigidity_at(m, 0.0) == pytest.approx(2e-6)
    assert bend_rigidity_at(m, math.pi / 4) == pytest.approx(7e-6)
    assert m.bend_for_hinge_angle(math.pi / 4) == pytest.approx(7e-6)
    assert isinstance(bend_rigidity_at(m, 0.3), float)


@pytest.mark.parametrize("name", list(SUMMARY))
def test_bend_rigidity_at_presets(name):
    m = get_material(name)
    phi = np.array([0.0, np.pi / 4, np.pi / 2, 3 * np.pi / 4, np.pi, -np.pi / 2])
    b = bend_rigidity_at(m, phi)
    assert b.shape == phi.shape
    expected = [m.bend_weft_Nm, m.bend_bias_Nm, m.bend_warp_Nm]
    np.testing.assert_allclose(b, [*expected, m.bend_bias_Nm, m.bend_weft_Nm, m.bend_warp_Nm])
    # smooth, period π, mirror-symmetric, positive everywhere
    t = np.linspace(-np.pi, np.pi, 2001)
    np.testing.assert_allclose(bend_rigidity_at(m, t), bend_rigidity_at(m, t + np.pi))
    np.testing.assert_allclose(bend_rigidity_at(m, t), bend_rigidity_at(m, -t))
    assert bend_rigidity_at(m, t).min() > 0


def test_edge_vector_angle_sign_does_not_matter():
    m = get_material("denim")
    du, dv = np.array([1.0, -1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0, -1.0])
    b = bend_rigidity_at(m, np.arctan2(dv, du))
    np.testing.assert_allclose(b, [m.bend_weft_Nm] * 2 + [m.bend_warp_Nm] * 2)


def test_bend_rigidity_clamped_at_zero_for_extreme_anisotropy():
    m = Material("t", 0.2, 1.0, 1.0, 1.0, 1e-6, 0.0, 0.0, "test")
    assert bend_rigidity_at(m, np.linspace(0, np.pi, 181)).min() == 0.0


def test_spec_preset_name_and_overrides():
    assert material_from_spec("denim", where=WHERE) == get_material("denim")
    m = material_from_spec({"preset": "denim", "bend_Nm": 0, "name": "floppy"}, where=WHERE)
    assert m.name == "floppy"
    assert m.bend_warp_Nm == m.bend_weft_Nm == m.bend_bias_Nm == 0.0
    assert m.stretch_u_N_m == get_material("denim").stretch_u_N_m
    assert WHERE in m.source
    m = material_from_spec({"preset": "denim", "bend_warp_Nm": 1e-5}, where=WHERE)
    assert m.bend_warp_Nm == 1e-5 and m.bend_weft_Nm == get_material("denim").bend_weft_Nm


def test_spec_full_custom():
    spec = {
        "density_kg_m2": 0.15,
        "stretch_u_N_m": 500,
        "stretch_v_N_m": 400.0,
        "shear_N_m": 10,
        "bend_warp_Nm": 5e-6,
        "bend_weft_Nm": 4e-6,
        "bend_bias_Nm": 3e-6,
    }
    m = material_from_spec(spec, where=WHERE)
    assert m.name == "custom"
    assert isinstance(m.stretch_u_N_m, float) and m.stretch_u_N_m == 500.0
    assert (m.bend_warp_Nm, m.bend_weft_Nm, m.bend_bias_Nm) == (5e-6, 4e-6, 3e-6)
    spec2 = {k: v for k, v in spec.items() if not k.startswith("bend_")} | {"bend_Nm": 2e-6}
    assert material_from_spec(spec2, where=WHERE).bend_bias_Nm == 2e-6


@pytest.mark.parametrize(
    "spec, key",
    [
        ({"preset": "cotton", "bend": 1e-6}, "bend"),
        ({"preset": "cotton", "shear_N_m": float("nan")}, "shear_N_m"),
        ({"preset": "cotton", "stretch_u_N_m": float("inf")}, "stretch_u_N_m"),
        ({"preset": "cotton", "stretch_v_N_m": -1.0}, "stretch_v_N_m"),
        ({"preset": "cotton", "bend_weft_Nm": "stiff"}, "bend_weft_Nm"),
        ({"preset": "cotton", "bend_bias_Nm": True}, "bend_bias_Nm"),
        ({"preset": "cotton", "density_kg_m2": 0}, "density_kg_m2"),
        ({"preset": "cotton", "density_kg_m2": -0.1}, "density_kg_m2"),
        ({"preset": "cotton", "bend_Nm": 1e-6, "bend_warp_Nm": 1e-6}, "bend_warp_Nm"),
        ({"preset": "velvet"}, "velvet"),
        ({"preset": 3}, "preset"),
        ({"preset": "cotton", "name": ""}, "name"),
        ({"density_kg_m2": 0.2, "stretch_u_N_m": 1.0}, "stretch_v_N_m"),
        ({"density_kg_m2": 0.2, "stretch_u_N_m": 1.0}, "bend_Nm"),
        ("velvet", "velvet"),
        (42, "int"),
    ],
)
def test_spec_errors_name_where_and_key(spec, key):
    with pytest.raises(SandboxError) as info:
        material_from_spec(spec, where=WHERE)
    msg = str(info.value)
    assert msg.startswith(WHERE)
    assert key in msg


def test_unknown_preset_lists_known_names():
    with pytest.raises(SandboxError) as info:
        get_material("velvet")
    msg = str(info.value)
    assert "velvet" in msg
    for n in ("cotton", "silk", "royal-target"):
        assert n in msg


def test_material_rejects_bad_values_directly():
    with pytest.raises(SandboxError, match="shear_N_m"):
        Material("bad", 0.2, 1.0, 1.0, float("nan"), 0.0, 0.0, 0.0, "test")
    with pytest.raises(SandboxError, match="density_kg_m2"):
        Material("bad", 0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, "test")


def test_scale():
    m = get_material("jersey")
    s = scale(m, stretch=2.0, bend=0.5)
    assert s.stretch_u_N_m == 2 * m.stretch_u_N_m and s.shear_N_m == 2 * m.shear_N_m
    assert s.bend_bias_Nm == 0.5 * m.bend_bias_Nm and s.density_kg_m2 == m.density_kg_m2
    with pytest.raises(SandboxError, match="bend"):
        scale(m, bend=-1.0)


def test_table_lists_every_preset_and_doc_is_current():
    table = materials_table_markdown()
    rows = [r for r in table.splitlines() if r.startswith("| ") and "preset" not in r]
    assert [r.split("|")[1].strip() for r in rows] == list_presets()
    doc = (REPO / "docs" / "fabrics.md").read_text(encoding="utf-8")
    assert mat.replace_table(doc, table) == doc, "regenerate: python -m sandbox.sim.materials"
