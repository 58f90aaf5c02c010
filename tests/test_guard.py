"""The guard: rollback and smaller dt instead of a blow-up, and advice that follows what it saw."""

import numpy as np
import pytest

from sandbox.scene.build import build_scene
from sandbox.scene.run import SimulationDiverged, run_scene
from sandbox.sim.guard import GuardConfig, GuardStop, StepGuard, max_strain
from tests.helpers import sheet_spec


def _sheet(dt_factor: float, **stop):
    spec = sheet_spec(simulation={"damping_per_s": 2.0}, stop={"time_limit_s": 0.4, **stop})
    limit = build_scene(spec).dt_limit_s
    spec.simulation.dt_s = dt_factor * limit
    return build_scene(spec)


@pytest.mark.slow
def test_a_run_five_times_above_the_stable_step_is_recovered_without_nan():
    scene = _sheet(5.0)
    unguarded = _sheet(5.0)
    with pytest.raises(SimulationDiverged, match=r"diverged at step \d+ near vertex \d+"):
        run_scene(unguarded, progress=False, guard=False)

    seen = []
    result = run_scene(scene, progress=False, on_frame=lambda s, f: seen.append(
        np.isfinite(s.state.positions()).all()))  # fmt: skip
    m = result.metrics
    assert all(seen) and np.isfinite(result.positions).all()
    assert m["guard_fired"] and m["guard_rollbacks"] >= 2
    assert m["guard_final_dt_s"] < m["dt_s"] and m["guard_min_dt_s"] < scene.dt_limit_s * 1.8
    assert m["dt_above_stable_limit"] and "stable limit" in m["dt_warning"]
    assert f"{scene.dt_limit_s:.3g}" in m["dt_warning"]
    assert m["sim_time_s"] == pytest.approx(0.4, abs=1e-9)
    # the recovered drape is a real drape: small strain, the sheet hangs below its pins
    assert max_strain(scene.model, result.positions) < 0.05
    assert m["guard_max_strain"] < 0.05


@pytest.mark.slow
def test_a_stable_run_does_not_fire_the_guard():
    result = run_scene(_sheet(0.9), progress=False)
    m = result.metrics
    assert not m["guard_fired"] and m["guard_rollbacks"] == 0 and m["dt_warning"] is None
    assert m["guard_final_dt_s"] == m["dt_s"]


def test_an_unrecoverable_run_stops_with_step_vertex_and_reason():
    scene = _sheet(400.0)  # far beyond what 2 halvings can rescue
    guard = StepGuard(scene, GuardConfig(max_halvings=2))
    x0 = scene.state.positions()
    with pytest.raises(GuardStop) as info:
        for frame in range(5):
            guard.advance_frame(frame)
    err = info.value
    msg = str(err)
    assert "diverged at step" in msg and f"vertex {err.vertex}" in msg
    assert "shrank dt" in msg and "No mesh was written" in msg
    assert 0 <= err.vertex < scene.model.particle_count and err.step >= 0
    assert guard.rollbacks == 2
    x = scene.state.positions()  # rolled back to the last good (finite) state
    assert np.isfinite(x).all() and np.isfinite(scene.state.velocities()).all()
    assert np.abs(x - x0).max() < 0.5


@pytest.mark.slow
def test_run_scene_turns_an_unrecoverable_run_into_simulation_diverged():
    scene = _sheet(400.0)
    with pytest.raises(SimulationDiverged, match=r"step \d+ near vertex \d+"):
        run_scene(scene, progress=False, guard=GuardConfig(max_halvings=1))


def test_the_advice_follows_what_shrinking_dt_showed():
    """After a few halvings the guard still suggests a shorter step; once a step 8 times
    shorter has failed too, it says the step size is not the cause and names the collider
    the vertex was touching (or that it touched none)."""
    from sandbox.scene.spec import scene_from_dict
    from tests.helpers import sheet_scene

    data = sheet_scene()  # its corner (0, 0) is at (-0.1, 0.3, 0): a ball 1 mm below it
    centre = np.array([-0.1, 0.3 - 0.101, 0.0])
    data["collider"] = [{"name": "ball", "shape": "sphere", "center_m": centre.tolist(),
                         "radius_m": 0.1, "subdivisions": 4}]  # fmt: skip
    scene = build_scene(scene_from_dict(data, source="test.toml"))
    guard = StepGuard(scene, GuardConfig())
    gap = np.linalg.norm(scene.state.positions() - centre, axis=1) - 0.1
    near, far = int(np.argmin(gap)), int(np.argmax(gap))
    assert gap[near] < 0.002 < 0.01 < gap[far]
    short = guard._message(10, near, "the energy rose", scene.dt_s / 2)
    assert "try a smaller dt_s" in short and "ball" not in short
    touching = guard._message(10, near, "the energy rose", scene.dt_s / 16)
    assert "does not come from the step size" in touching and "'ball'" in touching
    assert "try a smaller dt_s" not in touching and "\n" not in touching
    alone = guard._message(10, far, "the energy rose", scene.dt_s / 16)
    assert "touching no collider" in alone


def test_the_summary_line_names_the_self_collision_fail_safes():
    from sandbox.sim.guard import summary_line

    quiet = {"dt_s": 1.2e-4, "guard_rollbacks": 0,
             "self_collision_counts": {"impact_zone_steps": 0, "freeze_steps": 0}}  # fmt: skip
    assert summary_line(quiet) == "guard: no rollbacks, dt 0.12 ms throughout"
    busy = {"dt_s": 1.2e-4, "guard_rollbacks": 0,
            "self_collision_counts": {"impact_zone_steps": 12, "freeze_steps": 1,
                               "frozen_vertices_max": 40}}  # fmt: skip
    assert summary_line(busy) == (
        "guard: no rollbacks, dt 0.12 ms throughout; self-collision: rigid impact zones on 12 "
        "steps, 1 step stopped where zones did not resolve (at most 40 vertices)"
    )
