"""Scenes run coarse to fine (sandbox/scene/multilevel.py): the [multilevel] table, carrying
a shape between two meshes of the same cloth, and a whole run against the direct one."""

import json

import numpy as np
import pytest

from sandbox.errors import SandboxError
from tests.helpers import sheet_spec


def test_the_multilevel_table_is_read_with_its_defaults():
    spec = sheet_spec(multilevel={"coarse_edge_length_m": [0.08, 0.04]})
    ml = spec.multilevel
    assert ml.coarse_edge_length_m == (0.08, 0.04)
    assert ml.coarse_damping_per_s is None
    assert ml.settle_damping_per_s == 60.0
    assert ml.settle_inertia_scale == 4.0
    assert sheet_spec().multilevel is None
    one = sheet_spec(multilevel={"coarse_edge_length_m": 0.05, "coarse_damping_per_s": 0})
    assert one.multilevel.coarse_edge_length_m == (0.05,)
    assert one.multilevel.coarse_damping_per_s == 0.0


@pytest.mark.parametrize(
    "table, words",
    [
        ({"coarse_edge_length_m": [0.04, 0.08]}, "coarsest first"),
        ({"coarse_edge_length_m": []}, "non-empty list"),
        ({"coarse_edge_length_m": -0.05}, "coarse_edge_length_m must be a number > 0"),
        ({"settle_inertia_scale": 0.5}, "settle_inertia_scale must be a number >= 1"),
        ({"settle_damping_per_s": "fast"}, "settle_damping_per_s must be a number"),
        ({"levels": 2}, "unknown key 'levels'"),
    ],
)
def test_a_bad_multilevel_table_names_the_file_the_table_and_the_problem(table, words):
    with pytest.raises(SandboxError) as err:
        sheet_spec(multilevel=table)
    assert "test.toml" in str(err.value) and "[multilevel]" in str(err.value)
    assert words in str(err.value)


def test_a_coarse_level_finer_than_the_cloth_is_refused_when_the_scene_is_read():
    with pytest.raises(SandboxError, match="must all be longer than the cloths' edge"):
        sheet_spec(multilevel={"coarse_edge_length_m": 0.01})


def test_a_flat_cloth_carried_between_its_meshes_lands_on_its_own_rest_shape():
    """The sheet as placed is an affine image of its pattern, which barycentric
    interpolation reproduces: carried from a 5 cm mesh to the 2 cm one, every vertex lands
    where the 2 cm mesh places it (to rounding)."""
    from sandbox.scene.build import build_scene
    from sandbox.scene.multilevel import carry_positions

    fine = build_scene(sheet_spec())
    coarse = build_scene(sheet_spec(cloth={"edge_length_m": 0.05}))
    assert coarse.model.particle_count < fine.model.particle_count / 3
    x = carry_positions(coarse, fine)
    np.testing.assert_allclose(x, fine.state.positions(), atol=1e-9)


SHEET_ON_BALL = """
[scene]
name = "sheet_on_ball"
[simulation]
frame_rate_hz = 60.0
damping_per_s = 2.0
strain_damping_s = 2e-5
[stop]
time_limit_s = 3.0
residual_mean = 0.25
[collision]
thickness_m = 0.004
friction_static = 0.5
friction_kinetic = 0.5
[[cloth]]
name = "sheet"
size_m = [0.4, 0.4]
mesher = "grid"
edge_length_m = 0.02
material = { density_kg_m2 = 0.2, stretch_u_N_m = 2000.0, stretch_v_N_m = 2000.0, \
  shear_N_m = 800.0, bend_Nm = 1e-5 }
origin_m = [-0.2, 0.15, 0.2]
rotation_deg = [-90.0, 0.0, 0.0]
[[collider]]
name = "ball"
shape = "sphere"
center_m = [0.0, 0.0, 0.0]
radius_m = 0.12
"""


@pytest.mark.slow
def test_a_sheet_on_a_ball_rests_coarse_to_fine_where_it_rests_directly(tmp_path):
    """A 40 cm sheet dropped on a ball, run by the CLI coarse to fine (a 5 cm grid, then
    its own 2 cm grid) and with --direct: both at rest by the equilibrium residual, the
    multilevel run's metrics listing both levels. The sheet buckles into folds and friction
    holds them where they formed, so the two runs rest with their folds and corners in
    different places (vertices 3.7 cm apart on average, measured); what both must share is
    the sheet's height on the ball: its mean within 1 cm."""
    from sandbox.cli import main

    scene = tmp_path / "ball.toml"
    scene.write_text(SHEET_ON_BALL + "[multilevel]\ncoarse_edge_length_m = 0.05\n")
    shapes = {}
    for how, extra in (("multilevel", []), ("direct", ["--direct"])):
        out = tmp_path / how
        assert main(["run", str(scene), "--out", str(out), "--no-render", "--quiet", *extra]) == 0
        m = json.loads((out / "metrics.json").read_text())
        assert m["converged"], m["stop_reason"]
        assert m["residual_mean_over_weight"] < 0.25
        shapes[how] = np.array([[float(v) for v in line.split()[1:4]]
                                for line in (out / "mesh.obj").read_text().splitlines()
                                if line.startswith("v ")])  # fmt: skip
        if how == "multilevel":
            assert m["method"] == "coarse_to_fine"
            assert [lv["vertex_count"] for lv in m["levels"]] == [81, 441]
            assert m["total_wall_time_s"] > m["wall_time_s"]
        else:
            assert "levels" not in m
    heights = {how: x[:, 1].mean() for how, x in shapes.items()}
    assert abs(heights["multilevel"] - heights["direct"]) < 0.01


def test_a_coarse_level_short_of_rest_hands_over_to_the_direct_run():
    """A coarsest level stopped by its time limit has no rest shape to carry: the scene
    runs on its own mesh from the start, and its metrics say so."""
    from sandbox.scene.build import build_scene
    from sandbox.scene.multilevel import run_multilevel

    spec = sheet_spec(stop={"time_limit_s": 0.1}, multilevel={"coarse_edge_length_m": 0.05})
    scene, result = run_multilevel(spec, build_scene, progress=False)
    m = result.metrics
    assert m["method"] == "direct (coarse level not at rest)"
    assert [lv["stop_reason"] for lv in m["levels"]] == ["time limit", "time limit"]
    assert scene.model.particle_count == m["levels"][1]["vertex_count"]
    assert m["levels"][0]["vertex_count"] < m["levels"][1]["vertex_count"]
    assert scene.spec.simulation.damping_per_s == spec.simulation.damping_per_s
