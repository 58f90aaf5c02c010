"""The integrator contract (sandbox/sim/integrator.py): both solvers implement it alike."""

import pytest

from sandbox.collision.self_contact_config import SelfContactConfig
from sandbox.scene.build import build_scene
from sandbox.scene.spec import scene_from_dict
from sandbox.sim.implicit import ImplicitEulerSolver
from sandbox.sim.implicit_config import ImplicitConfig, resolve_linear_solver
from sandbox.sim.integrator import ContactFriction, Integrator
from sandbox.sim.solver import SymplecticEulerSolver


def _scene(integrator: str, **configs):
    return build_scene(scene_from_dict({
        "scene": {"name": "integrator-test"},
        "simulation": {"integrator": integrator},
        "cloth": [{"name": "sheet", "size_m": [0.2, 0.2], "edge_length_m": 0.05,
                   "mesher": "grid", "material": "cotton", "origin_m": [-0.1, 0.2, -0.1],
                   "rotation_deg": [90.0, 0.0, 0.0]}],
        "collision": {"friction_static": 0.4, "friction_kinetic": 0.3},
        "collider": [{"name": "ball", "shape": "sphere", "center_m": [0.0, 0.0, 0.0],
                      "radius_m": 0.1, "subdivisions": 2}],
    }, source="test_integrator"), **configs)  # fmt: skip


@pytest.mark.parametrize(
    "integrator, cls",
    [("symplectic_euler", SymplecticEulerSolver), ("implicit_euler", ImplicitEulerSolver)],
)
def test_both_solvers_implement_the_contract(integrator, cls):
    scene = _scene(integrator)
    solver = scene.solver
    assert isinstance(solver, cls) and isinstance(solver, Integrator)
    assert solver.self_collider is scene.model.self_collider is not None
    solver.reset_watch()
    assert solver.first_bad() is None
    solver.reset_stats()
    stats = solver.stats()
    assert isinstance(stats, dict)
    assert (stats == {}) == (cls is SymplecticEulerSolver)  # only Newton has counters

    # friction: read, set every coefficient, put back
    saved = solver.friction()
    assert isinstance(saved, ContactFriction) and len(saved.body) == 1
    assert saved.body[0] == pytest.approx((0.4, 0.3)) and saved.cloth == pytest.approx(0.3)
    solver.set_friction(saved.uniform(0.7))
    changed = solver.friction()
    assert changed.body[0] == pytest.approx((0.7, 0.7)) and changed.cloth == pytest.approx(0.7)
    solver.set_friction(saved)
    assert solver.friction() == saved

    solver.set_speed_limit(0.5)
    if cls is SymplecticEulerSolver:
        assert solver.speed_limit[None] == pytest.approx(0.5)
    solver.set_speed_limit(0.0)


def test_friction_without_a_self_collider_leaves_the_cloth_value_out():
    scene = _scene("symplectic_euler")
    solver = scene.solver
    saved = solver.friction()
    solver.self_collider = None  # as the sewing does without self-collision
    assert solver.friction().cloth is None
    solver.set_friction(saved.uniform(0.1))  # the cloth's μ has nowhere to go: ignored
    solver.self_collider = scene.model.self_collider
    assert solver.friction().cloth == pytest.approx(0.3)
    assert solver.friction().body[0] == pytest.approx((0.1, 0.1))


def test_build_scene_passes_the_solver_settings_on():
    """The typed settings reach the solver and the self-collider; a scene's
    ``linear_solver`` wins over the config's unless it is "auto"."""
    implicit = ImplicitConfig(contact_stiffness=2e3, linear_solver="cg")
    scene = _scene("implicit_euler", implicit=implicit,
                   self_contact=SelfContactConfig(ccd_passes=4))  # fmt: skip
    assert scene.solver.config.contact_stiffness == 2e3
    assert scene.solver.linear_solver == "cg"  # the scene says "auto"
    assert scene.model.self_collider.config.ccd_passes == 4
    spec = scene.spec
    spec.simulation.linear_solver = "direct"
    assert build_scene(spec, implicit=implicit).solver.linear_solver == "direct"
    assert resolve_linear_solver("auto") == "direct"  # on the CPU
    assert _scene("implicit_euler").solver.config == ImplicitConfig()
