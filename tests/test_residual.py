"""The equilibrium residual (sandbox/sim/residual.py) and the seams' dashpots."""

import numpy as np
import pytest

from sandbox.scene.build import build_scene
from sandbox.scene.spec import scene_from_dict
from sandbox.sim.residual import scene_residual


def flat_sheet_on_box(height_m: float, friction: float = 0.4):
    """A 10 x 10 cm jersey sheet lying flat (unstressed), ``height_m`` above a box's top."""
    data = {
        "scene": {"name": "sheet_on_box"},
        "simulation": {"damping_per_s": 2.0},
        "collision": {"thickness_m": 0.002, "friction_static": friction,
                      "friction_kinetic": 0.5 * friction},
        "cloth": [{"name": "sheet", "size_m": [0.1, 0.1], "edge_length_m": 0.02,
                   "material": "jersey", "origin_m": [-0.05, height_m, 0.05],
                   "rotation_deg": [-90.0, 0.0, 0.0]}],
        "collider": [{"name": "box", "shape": "box", "center_m": [0.0, -0.1, 0.0],
                      "size_m": [0.4, 0.2, 0.4]}],
    }  # fmt: skip
    return build_scene(scene_from_dict(data, source="sheet_on_box.toml"))


def test_a_sheet_in_free_fall_has_a_residual_of_its_weight():
    """No stress, no support: each vertex's net force is its weight (ratio 1)."""
    r = scene_residual(flat_sheet_on_box(0.1))
    assert r["residual_max_over_weight"] == pytest.approx(1.0, rel=1e-3)
    assert r["residual_mean_over_weight"] == pytest.approx(1.0, rel=1e-3)
    assert r["residual_contact_vertices"] == 0


def test_a_sheet_lying_on_a_box_is_at_rest():
    """Within the contact thickness of the box's top, gravity presses every vertex into
    the box, whose reaction cancels it."""
    sc = flat_sheet_on_box(0.002)
    r = scene_residual(sc)
    assert r["residual_max_over_weight"] < 1e-3
    assert r["residual_contact_vertices"] == sc.model.particle_count


def test_friction_holds_a_tilted_sheet_only_inside_its_cone():
    """On a slope of angle a, friction holds the weight's tangential part while
    tan a <= μ_s; beyond, the excess is left: sin a − μ cos a of the weight."""
    from sandbox.sim.residual import _supported

    a = np.radians(30.0)
    n = np.array([[-np.sin(a), np.cos(a), 0.0]])  # the slope's normal
    f = np.array([[0.0, -1.0, 0.0]])  # the weight, 1 N
    one = np.array([1])
    assert _supported(f, n, n, one, 0.6)[0] == pytest.approx(0.0, abs=1e-12)  # tan 30° < 0.6
    left = _supported(f, n, n, one, 0.3)[0]
    assert left == pytest.approx(np.sin(a) - 0.3 * np.cos(a), rel=1e-9)


def test_a_vertex_in_a_crease_leans_on_both_faces():
    from sandbox.sim.residual import _supported

    n1 = np.array([[1.0, 0.0, 0.0]])
    n2 = np.array([[0.0, 1.0, 0.0]])
    f = np.array([[-2.0, -3.0, 0.0]])  # into both faces
    assert _supported(f, n1, n2, np.array([2]), 0.0)[0] == pytest.approx(0.0, abs=1e-12)
    assert _supported(f, n1, n2, np.array([1]), 0.0)[0] == pytest.approx(3.0)  # one face only


SEWN_RINGING = {
    "scene": {"name": "two_panels"},
    "simulation": {"gravity_m_s2": [0, 0, 0], "damping_per_s": 0.0},
    "cloth": [
        {"name": "left", "size_m": [0.1, 0.1], "edge_length_m": 0.02, "material": "jersey",
         "origin_m": [-0.1, 0, 0]},
        {"name": "right", "size_m": [0.1, 0.1], "edge_length_m": 0.02, "material": "jersey",
         "origin_m": [0.1, 0, 0], "rotation_deg": [0, 180, 0]},
    ],
    "seam": [{"name": "middle", "a": [{"cloth": "left", "edge": 1}],
              "b": [{"cloth": "right", "edge": 1}]}],
}  # fmt: skip


def _ringing(zeta: float) -> float:
    """The seam pairs' largest relative speed [m/s] after 0.2 s, started closed with the
    pairs moving apart at 1 m/s."""
    data = {**SEWN_RINGING, "simulation": {**SEWN_RINGING["simulation"],
                                           "seam_damping_ratio": zeta}}  # fmt: skip
    sc = build_scene(scene_from_dict(data, source="sewn.toml"))
    pairs = sc.model.seam_pairs_np
    x = sc.state.positions().astype(np.float64)
    x[pairs[:, 1]] = x[pairs[:, 0]]  # sewn shut
    v = np.zeros_like(x)
    v[pairs[:, 0], 2] = 0.5
    v[pairs[:, 1], 2] = -0.5
    sc.state.set(x, v)
    sc.solver.advance(sc.state, sc.control, sc.dt_s, 6 * sc.steps_per_frame)
    u = sc.state.velocities()
    return float(np.linalg.norm(u[pairs[:, 0]] - u[pairs[:, 1]], axis=1).max())


def test_seam_dashpots_stop_a_seam_ringing():
    undamped, damped = _ringing(0.0), _ringing(0.3)
    assert undamped > 0.05  # an undamped seam pair still rings
    assert damped < 0.1 * undamped
    assert np.isfinite(damped)


def test_the_seam_damping_ratio_is_checked():
    from sandbox.errors import SandboxError

    data = {**SEWN_RINGING, "simulation": {"seam_damping_ratio": 2.0}}
    with pytest.raises(SandboxError, match="seam_damping_ratio"):
        scene_from_dict(data, source="sewn.toml")


def test_the_residual_stop_waits_while_it_falls_and_not_on_a_plateau(monkeypatch):
    from sandbox.scene import run
    from sandbox.sim import residual

    values = iter([3.0, 2.0, 1.0, 0.9, 0.8, 0.79, 0.79, 0.79, 0.79, 0.1])
    monkeypatch.setattr(residual, "scene_residual",
                        lambda scene: {"residual_mean_over_weight": next(values)})  # fmt: skip
    checks: list = []
    got = [run._at_rest(None, 0.25, checks) for _ in range(8)]
    assert got[:7] == [False] * 7  # falling, then too few checks to call it a plateau
    assert got[7] is None  # the last three no more than 10 % below the best before
    assert run._at_rest(None, 0.25, checks) is None
    assert run._at_rest(None, 0.25, checks) is True
