"""The Cusick drape test (validation.md §3): drape coefficient, node counter, the case."""

import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from sandbox.errors import SandboxError
from sandbox.validate.cusick import CusickSettings, distinct_presets, spearman
from sandbox.validate.cusick_measure import (
    count_nodes,
    drape_coefficient_pct,
    shadow_area_m2,
    shadow_mask,
)

D_SPEC, D_DISC = 0.30, 0.18
EXTENT, PIXEL = 0.32, 0.001


def disc_mesh(radius: float, rings: int = 30, segments: int = 180):
    """A flat fan mesh of a disc in the x-z plane: points (n, 2), triangles (m, 3)."""
    pts = [(0.0, 0.0)]
    tris = []
    for i in range(1, rings + 1):
        r = radius * i / rings
        a = np.arange(segments) * 2 * math.pi / segments
        pts += list(zip(r * np.cos(a), r * np.sin(a), strict=True))
    for i in range(rings):
        for j in range(segments):
            k = (j + 1) % segments
            outer = 1 + i * segments
            if i == 0:
                tris.append((0, outer + j, outer + k))
            else:
                inner = 1 + (i - 1) * segments
                tris += [(inner + j, outer + j, outer + k), (inner + j, outer + k, inner + k)]
    return np.array(pts), np.array(tris)


def polygon_area(r, segments):
    return 0.5 * segments * r**2 * math.sin(2 * math.pi / segments)


def test_flat_specimen_gives_100_percent():
    xz, tris = disc_mesh(D_SPEC / 2)
    area = shadow_area_m2(xz, tris, EXTENT, PIXEL)
    exact = polygon_area(D_SPEC / 2, 180)
    assert area == pytest.approx(exact, rel=0.002)
    assert drape_coefficient_pct(area, D_SPEC, D_DISC) == pytest.approx(100.0, abs=0.5)


def test_hanging_cylinder_gives_zero():
    """The disc flat plus the annulus hanging straight down as a vertical cylinder wall: its
    triangles project onto the rim, so the shadow is the disc alone."""
    xz, tris = disc_mesh(D_DISC / 2)
    seg = 180
    a = np.arange(seg) * 2 * math.pi / seg
    rim = np.c_[np.cos(a), np.sin(a)] * D_DISC / 2
    n0 = len(xz)
    xz = np.vstack([xz, rim, rim])  # top and bottom rows of the wall share (x, z)
    wall = [(n0 + j, n0 + seg + j, n0 + (j + 1) % seg) for j in range(seg)]
    tris = np.vstack([tris, wall])
    dc = drape_coefficient_pct(shadow_area_m2(xz, tris, EXTENT, PIXEL), D_SPEC, D_DISC)
    assert dc == pytest.approx(0.0, abs=1.0)


def test_overlapping_folds_count_once_and_a_square_is_exact():
    """Two copies of a 10 x 20 cm rectangle (2 triangles each), one shifted by 5 cm: union
    10 x 25 cm; within 0.5 %."""
    sq = np.array([[-0.05, -0.1], [0.05, -0.1], [0.05, 0.1], [-0.05, 0.1]])
    xz = np.vstack([sq, sq + [0.0, 0.05]])
    tris = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])
    assert shadow_area_m2(xz, tris, EXTENT, PIXEL) == pytest.approx(0.1 * 0.25, rel=0.005)


def test_ellipse_projected_area_within_half_a_percent():
    xz, tris = disc_mesh(1.0, rings=20, segments=240)
    xz = xz * [0.14, 0.08]  # an ellipse of semi-axes 14 and 8 cm
    exact = polygon_area(1.0, 240) * 0.14 * 0.08
    assert shadow_area_m2(xz, tris, EXTENT, PIXEL) == pytest.approx(exact, rel=0.005)
    assert shadow_mask(xz, tris, EXTENT, PIXEL).shape == (320, 320)


@pytest.mark.parametrize("k", range(4, 11))
def test_cosine_hem_has_k_nodes(k):
    rng = np.random.default_rng(k)
    theta = np.sort(rng.uniform(0, 2 * math.pi, 300))
    r = 0.12 + 0.02 * np.cos(k * theta + 0.3)
    assert count_nodes(theta, r, prominence_m=0.005) == k


def test_circle_and_small_ripples_have_no_nodes():
    theta = np.linspace(0, 2 * math.pi, 200, endpoint=False)
    assert count_nodes(theta, np.full_like(theta, 0.15)) == 0
    ripples = 0.15 + 0.001 * np.cos(7 * theta)  # 2 mm peak to trough: below 5 mm prominence
    assert count_nodes(theta, ripples, prominence_m=0.005) == 0


def test_settings_are_frozen_and_quick_is_coarser():
    s = CusickSettings()
    with pytest.raises(AttributeError):
        s.edge_length_m = 0.02
    assert s.quick.edge_length_m > s.edge_length_m
    assert len(s.quick.presets) == 3


def test_the_scene_waits_for_rest_and_can_refine_the_clamp():
    """15 frames under the paper's rule (0.5 s, over half a period of the flaps' swing);
    ``clamp_edge_m`` puts mesh circles at the clamp, 5 and 10 mm outside it."""
    from sandbox.scene.build import mesh_cloth
    from sandbox.sim.materials import get_material
    from sandbox.validate.cusick import cusick_spec

    s = CusickSettings()
    spec = cusick_spec(get_material("jersey"), 0.02, s)
    assert spec.stop.frames == 15 and spec.stop.time_limit_s == 8.0
    assert spec.stop.max_displacement_m == 1.5e-3 and spec.stop.mean_displacement_m == 1e-4
    uv, _ = mesh_cloth(spec.cloths[0])
    fine = cusick_spec(get_material("jersey"), 0.02, replace(s, clamp_edge_m=0.005))
    uv_fine, _ = mesh_cloth(fine.cloths[0])
    r, r_fine = np.hypot(*uv.T), np.hypot(*uv_fine.T)
    for ring in (0.09, 0.095, 0.1):
        on = np.abs(r_fine - ring) < 1e-6
        assert on.sum() >= 2 * math.pi * ring / 0.005 - 1
    assert len(uv_fine) > len(uv) + 300
    assert np.count_nonzero(r_fine <= 0.09 + 1e-6) > np.count_nonzero(r <= 0.09 + 1e-6)
    pinned = {i for p in fine.cloths[0].pins for i in p.vertices}
    assert pinned == set(np.nonzero(r_fine <= 0.09 * (1 + 1e-6))[0].tolist())


def test_unknown_preset_is_a_sandbox_error():
    with pytest.raises(SandboxError, match="unknown material preset 'tweed'"):
        distinct_presets(["cotton", "tweed"])


def test_aliases_run_once():
    groups = dict(distinct_presets(["silk", "tango-red-jet-set", "cotton"]))
    assert groups == {"silk": ["tango-red-jet-set"], "cotton": []}


def test_spearman():
    assert spearman([1, 2, 3, 4], [10, 20, 25, 40]) == pytest.approx(1.0)
    assert math.isnan(spearman([1, 2], [1, 2]))


def test_cli_unknown_preset_is_one_line(capsys):
    from sandbox.cli import main

    assert main(["validate", "cusick", "--presets", "tweed"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and "tweed" in err and "\n" not in err


@pytest.mark.slow
def test_quick_case(tmp_path):
    from sandbox.validate import cusick

    # the suite's float64 runtime: a float32 one would stay for the modules after this
    args = SimpleNamespace(quick=True, presets=None, out=tmp_path, json=True, quiet=True,
                           arch="cpu", float64=True)  # fmt: skip
    assert cusick.main(args) == 0
    import json

    data = json.loads((tmp_path / "cusick.json").read_text())
    runs = data["runs"]
    assert len(runs) == 3
    assert all(0.0 < r["dc_pct"] < 100.0 for r in runs), runs
    stiff = max(runs, key=lambda r: r["bending_length_m"])
    limp = min(runs, key=lambda r: r["bending_length_m"])
    assert stiff["dc_pct"] > limp["dc_pct"]
    assert (tmp_path / "contact_sheet.png").exists() and (tmp_path / "cusick.md").exists()
