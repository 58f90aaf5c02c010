"""Eq. 2 (symplectic Euler), the stop rule and the two launch paths."""

import numpy as np
import pytest

from sandbox.scene.build import build_scene
from sandbox.scene.run import run_scene
from sandbox.sim.solver import SymplecticEulerSolver
from sandbox.sim.stop import DisplacementMonitor, StopRule
from tests.helpers import sheet_spec


def free_sheet(**cloth):
    spec = sheet_spec(
        simulation={"damping_per_s": 0.0, "gravity_m_s2": [0.0, 0.0, 0.0]},
        cloth=dict({"pins": [], "rotation_deg": [0.0, 0.0, 0.0]}, **cloth),
    )
    return build_scene(spec)


def kinetic(scene):
    v = scene.state.velocities()
    return 0.5 * float(np.sum(scene.model.mass_np[:, None] * v * v))


@pytest.mark.slow
def test_free_flight_conserves_linear_momentum():
    scene = free_sheet(velocity_m_s=[0.3, -0.1, 0.2])
    rng = np.random.default_rng(3)
    scene.state.set(
        scene.state.positions() + rng.normal(0, 0.001, (scene.model.particle_count, 3)),
        scene.state.velocities() + rng.normal(0, 0.05, (scene.model.particle_count, 3)),
    )
    m = scene.model.mass_np[:, None]
    p0 = np.sum(m * scene.state.velocities(), axis=0)
    scene.solver.advance(scene.state, scene.control, scene.dt_s, 2000)
    p1 = np.sum(m * scene.state.velocities(), axis=0)
    np.testing.assert_allclose(p1, p0, atol=1e-12 * scene.model.mass_np.sum() + 1e-12)
    assert np.isfinite(scene.state.positions()).all()


@pytest.mark.slow
def test_undamped_oscillation_keeps_its_energy_bounded():
    """Symplectic Euler: energy oscillates around its initial value and does not drift."""
    scene = free_sheet(material="denim")
    x0 = scene.state.positions()
    centre = x0.mean(axis=0)
    scene.state.set(centre + (x0 - centre) * np.array([1.01, 0.995, 1.0]))  # small stretch
    energies = []
    for _ in range(400):
        scene.solver.advance(scene.state, scene.control, scene.dt_s, 20)
        energies.append(kinetic(scene) + scene.solver.internal_energy(scene.state))
    e = np.array(energies)
    e0 = energies[0]
    assert np.abs(e - e0).max() / e0 < 0.05
    first, last = e[:100].mean(), e[-100:].mean()
    assert abs(last - first) / e0 < 0.01  # no drift over 8000 steps


def test_speed_limit_caps_every_particle_and_is_off_by_default():
    """The sewing phase's speed limit: a falling sheet keeps at most the limit, no more."""
    scene = free_sheet(velocity_m_s=[0.0, -3.0, 0.0])
    assert scene.solver.speed_limit[None] == 0.0
    scene.solver.advance(scene.state, scene.control, scene.dt_s, 10)
    np.testing.assert_allclose(np.linalg.norm(scene.state.velocities(), axis=1), 3.0, rtol=1e-6)
    scene.solver.speed_limit[None] = 0.5
    x0 = scene.state.positions()
    scene.solver.advance(scene.state, scene.control, scene.dt_s, 10)
    speed = np.linalg.norm(scene.state.velocities(), axis=1)
    np.testing.assert_allclose(speed, 0.5, rtol=1e-6)
    moved = np.linalg.norm(scene.state.positions() - x0, axis=1)
    np.testing.assert_allclose(moved, 0.5 * 10 * scene.dt_s, rtol=1e-6)


@pytest.mark.slow
def test_parallel_step_and_fused_advance_agree():
    a = build_scene(sheet_spec())
    b = build_scene(sheet_spec())
    a.solver.advance(a.state, a.control, a.dt_s, 50)  # fused (small mesh)
    for k in range(50):
        b.solver.step(b.state, b.state, b.control, b.dt_s, k)  # one parallel launch each
    np.testing.assert_allclose(a.state.positions(), b.state.positions(), atol=1e-12)


def test_step_writes_into_a_separate_state():
    scene = build_scene(sheet_spec())
    out = scene.model.state()
    scene.solver.step(scene.state, out, scene.control, scene.dt_s)
    free = ~scene.model.pinned_np
    assert np.abs(out.positions()[free] - scene.state.positions()[free]).max() > 0
    assert np.abs(out.velocities()[free, 1]).max() > 0  # gravity acted


@pytest.mark.slow
def test_stop_rule_fires_on_a_settled_sheet_and_not_on_a_swinging_one():
    settled = run_scene(build_scene(sheet_spec(stop={"time_limit_s": 10.0})), progress=False)
    assert settled.converged and settled.reason == "stop rule"
    assert settled.metrics["max_displacement_m"] < 1.5e-3
    assert settled.metrics["mean_displacement_m"] < 1e-4

    swinging = build_scene(
        sheet_spec(simulation={"damping_per_s": 0.0}, stop={"time_limit_s": 1.0})
    )
    result = run_scene(swinging, progress=False)
    assert not result.converged and result.reason == "time limit"


def test_stop_rule_is_measured_over_a_frame_not_a_step():
    scene = build_scene(sheet_spec(simulation={"damping_per_s": 0.0}))
    monitor = DisplacementMonitor(scene.model)
    monitor.reset(scene.state)
    scene.solver.advance(scene.state, scene.control, scene.dt_s, 1)
    one_step, _ = monitor.measure(scene.state)
    scene.solver.advance(scene.state, scene.control, scene.dt_s, scene.steps_per_frame)
    one_frame, _ = monitor.measure(scene.state)
    assert one_frame > 10 * one_step
    rule = StopRule(1.5e-3, 1e-4, frames=2)
    assert not rule.update(1e-4, 1e-5) and rule.update(1e-4, 1e-5)
    assert not rule.update(2e-3, 1e-5)


@pytest.mark.slow
@pytest.mark.parametrize("limit", [0, 10**9])
def test_both_launch_paths_run_a_scene(limit):
    scene = build_scene(sheet_spec(stop={"time_limit_s": 0.2}))
    scene.solver = SymplecticEulerSolver(scene.model, fused_particle_limit=limit)
    r = run_scene(scene, progress=False)
    assert r.metrics["steps"] > 0 and np.isfinite(r.positions).all()
