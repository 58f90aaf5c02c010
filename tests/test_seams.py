"""Seams as springs (paper §2.4, Fig. 5): direction rule, parametric matching, sewing."""

import numpy as np
import pytest

from sandbox.errors import SandboxError
from sandbox.scene.build import build_scene
from sandbox.scene.run import run_scene
from sandbox.scene.spec import scene_from_dict
from sandbox.sim.seams import (
    SeamLine,
    match_springs,
    merge_lines,
    seam_direction_same,
    seam_openings,
)
from tests.helpers import sheet_spec


def line(ids, ys):
    return SeamLine(np.asarray(ids), np.stack([np.zeros(len(ys)), np.asarray(ys)], 1))


def test_direction_rule_joins_the_closer_ends():
    p1, p2 = np.array([0.0, 0, 0]), np.array([0.0, 1, 0])
    assert seam_direction_same((p1, p2), (np.array([0.1, 0, 0]), np.array([0.1, 1, 0])))
    assert not seam_direction_same((p1, p2), (np.array([0.1, 1, 0]), np.array([0.1, 0, 0])))


def test_matching_points_get_zero_length_springs():
    pairs, rest = match_springs(line([0, 1, 2], [0, 0.5, 1]), line([10, 11, 12], [0, 0.5, 1]))
    assert pairs.tolist() == [[0, 10], [1, 11], [2, 12]]
    np.testing.assert_allclose(rest, 0.0)


def test_points_between_get_two_springs_with_parametric_rest_lengths():
    a = line([0, 1, 2], [0.0, 0.5, 1.0])  # shorter side: t = 0, 0.5, 1
    b = line([10, 11, 12, 13], [0.0, 0.4, 0.8, 1.2])  # s = 0, 1/3, 2/3, 1; length 1.2
    pairs, rest = match_springs(a, b)
    L = 1.0  # the shorter line's length: the longer is gathered to it when sewn
    mid = pairs[:, 0] == 1
    assert sorted(pairs[mid, 1].tolist()) == [11, 12]
    np.testing.assert_allclose(sorted(rest[mid]), sorted([L * (0.5 - 1 / 3), L * (2 / 3 - 0.5)]))
    assert rest[~mid].max() == 0.0  # the ends coincide in parameter
    # sewn, the gathered side's points 11 and 12 stand 1/3 apart: the point between them
    # stays on the line (its rest lengths add up to that), not pushed off it
    assert rest[mid].sum() == pytest.approx(1.0 / 3.0)


def test_the_seam_gap_is_the_distance_to_the_point_of_equal_parameter():
    """The gap is how far apart the two sides are, not the springs' stretch: the other
    line stretched along itself with the point still on it is closed (the springs are
    stretched 10 %); a point 5 mm off the line sideways is 5 mm open."""
    a = line([0, 1, 2], [0.0, 0.5, 1.0])
    b = line([3, 4, 5, 6], [0.0, 1 / 3, 2 / 3, 1.0])
    pairs, rest = match_springs(a, b)
    x = np.zeros((7, 3))
    x[:3, 1] = [0.0, 0.55, 1.1]  # the short side, stretched 10 % with the other
    x[3:, 1] = np.array([0.0, 1 / 3, 2 / 3, 1.0]) * 1.1
    gap = seam_openings(pairs, rest, x)
    stretch = np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1) - rest
    assert stretch.max() > 0.008  # the old measure: 8 mm "open"
    np.testing.assert_allclose(gap, 0.0, atol=1e-12)
    x[1, 0] = 0.005  # the middle point 5 mm off the other line
    gap = seam_openings(pairs, rest, x)
    np.testing.assert_allclose(gap[pairs[:, 0] == 1], 0.005, rtol=1e-9)
    np.testing.assert_allclose(gap[pairs[:, 0] != 1], 0.0, atol=1e-12)


def test_several_edges_are_merged_into_one_line():
    a = merge_lines([(np.array([0, 1, 2]), np.array([[0, 0], [0, 1], [0, 2.0]])),
                     (np.array([2, 3]), np.array([[0, 2.0], [1, 2.0]]))])  # fmt: skip
    assert a.particles.tolist() == [0, 1, 2, 3] and a.length == pytest.approx(3.0)
    np.testing.assert_allclose(a.params, [0, 1 / 3, 2 / 3, 1])


SEWN = {
    "scene": {"name": "two_panels"},
    "simulation": {"gravity_m_s2": [0, 0, 0], "damping_per_s": 5.0},
    "stop": {"time_limit_s": 3.0},
    "cloth": [
        {"name": "left", "size_m": [0.2, 0.3], "edge_length_m": 0.02, "material": "jersey",
         "origin_m": [-0.25, 0, 0]},
        {"name": "right", "size_m": [0.2, 0.3], "edge_length_m": 0.015, "material": "jersey",
         "origin_m": [0.25, 0, 0], "rotation_deg": [0, 180, 0]},
    ],
    "seam": [{"name": "middle", "a": [{"cloth": "left", "edge": 1}],
              "b": [{"cloth": "right", "edge": 1}]}],
}  # fmt: skip


@pytest.mark.slow
def test_two_panels_are_pulled_together_along_the_seam():
    sc = build_scene(scene_from_dict(SEWN, source="sewn.toml"))
    assert sc.model.seam_count > 0
    r = run_scene(sc, progress=False)
    x = r.positions
    assert r.converged
    assert r.metrics["seam_gap_max_m"] < 3e-3  # from a 10 cm gap
    assert np.abs(x[:, 2]).max() < 2e-3  # still flat: the panels were not crumpled
    assert x[:, 0].max() - x[:, 0].min() == pytest.approx(0.4, abs=0.01)


def test_reversed_panel_is_sewn_the_right_way_round():
    data = {**SEWN, "cloth": [dict(c) for c in SEWN["cloth"]]}
    data["cloth"][1]["rotation_deg"] = [180, 180, 0]  # upside down: its edge 1 runs top-down
    data["cloth"][1]["origin_m"] = [0.25, 0.3, 0]
    sc = build_scene(scene_from_dict(data, source="sewn.toml"))
    x = sc.state.positions()
    p = sc.model.seam_pairs_np
    assert np.abs(x[p[:, 0], 1] - x[p[:, 1], 1]).max() < 0.02  # ends joined to the near ends


@pytest.mark.slow
def test_no_seam_fields_without_seams():
    sc = build_scene(sheet_spec())
    assert sc.model.seam_count == 0 and sc.model.seam_pairs is None
    assert (
        sc.solver.seam_force is None
        and "seam_gap_max_m"
        not in run_scene(
            build_scene(sheet_spec(stop={"time_limit_s": 0.1})), progress=False
        ).metrics
    )


@pytest.mark.parametrize(
    "edit, needle",
    [({"cloth": "middle"}, "no cloth named 'middle'"), ({"cloth": "left", "edge": 9}, "edge")],
)
def test_bad_seams_are_named(edit, needle):
    data = {**SEWN, "seam": [{"a": [edit], "b": [{"cloth": "right", "edge": 1}]}]}
    with pytest.raises(SandboxError, match=needle):
        scene_from_dict(data, source="sewn.toml")


@pytest.mark.slow
@pytest.mark.parametrize("integrator", ["symplectic_euler", "implicit_euler"])
def test_seams_can_be_cleared_and_sewn_while_the_model_runs(integrator):
    from sandbox.sim.seams import set_seam_springs

    data = {**SEWN, "simulation": {**SEWN["simulation"], "integrator": integrator}}
    sc = build_scene(scene_from_dict(data, source="sewn.toml"))
    m = sc.model
    pairs, rest, k = m.seam_pairs_np.copy(), m.seam_rest_np.copy(), m.seam_stiffness_np.copy()
    gap0 = np.linalg.norm(np.diff(sc.state.positions()[pairs], axis=1), axis=2).max()
    set_seam_springs(m, np.zeros((0, 2), int), [], [])  # clear: the same kernels, 0 springs
    assert m.seam_count == 0 and m.seam_active[None] == 0
    sc.solver.advance(sc.state, sc.control, sc.dt_s, 4 * sc.steps_per_frame)
    x = sc.state.positions()
    assert np.linalg.norm(np.diff(x[pairs], axis=1), axis=2).max() > 0.9 * gap0  # not pulled
    set_seam_springs(m, pairs, rest, k)  # sew again, live
    r = run_scene(sc, progress=False)
    assert r.metrics["seam_gap_max_m"] < 3e-3
    with pytest.raises(SandboxError, match="capacity"):
        set_seam_springs(m, np.vstack([pairs, pairs[:1]]), np.r_[rest, 0], np.r_[k, 1])
    with pytest.raises(SandboxError, match="itself"):
        set_seam_springs(m, [[3, 3]], [0.0], [1.0])


def test_a_model_with_room_for_seams_runs_with_none_sewn():
    from sandbox.sim.builder import ModelBuilder
    from sandbox.sim.seams import set_seam_springs
    from sandbox.sim.solver import SymplecticEulerSolver

    sc = build_scene(sheet_spec())
    from sandbox.sim.materials import get_material

    b = ModelBuilder()
    m0 = sc.model
    cotton = get_material("cotton")
    b.add_cloth(name="a", pattern_uv=m0.rest_uv_np, triangles=m0.tri_indices_np,
                material=cotton, positions=m0.initial_positions_np)  # fmt: skip
    b.add_cloth(name="b", pattern_uv=m0.rest_uv_np, triangles=m0.tri_indices_np,
                material=cotton, positions=m0.initial_positions_np + [0.0, 0.0, 0.05])  # fmt: skip
    m = b.finalize(seam_capacity=8)
    assert m.has_seams and m.seam_count == 0 and m.seam_capacity == 8
    solver = SymplecticEulerSolver(m)
    state, control = m.state(), m.control(gravity=(0, 0, 0))
    solver.advance(state, control, 1e-4, 10)
    assert np.allclose(state.positions(), m.initial_positions_np, atol=1e-9)  # no force
    n = m0.particle_count
    set_seam_springs(m, [[0, n]], [0.0], [50.0])  # pull vertex 0 of b onto vertex 0 of a
    solver.advance(state, control, 1e-4, 10)
    x = state.positions()
    assert x[0, 2] > 0 and x[n, 2] < 0.05  # towards each other
    moved = (x - m.initial_positions_np)[:, 2]
    assert abs(moved @ m.mass_np) < 1e-15  # the seam's pull conserves momentum
