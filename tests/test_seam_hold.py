"""The solver's seam hold: a sewn stitch opens no further than ``seam_hold_m``."""

import numpy as np
import pytest

from sandbox.errors import SandboxError
from sandbox.scene.build import build_scene
from sandbox.scene.spec import scene_from_dict
from sandbox.sim.seams import seam_openings


def _two_panels(hold_m: float, right_edge_m: float = 0.02, damping: float = 0.0):
    """Two 10 x 10 cm jersey panels sewn along one edge, no gravity; the right panel's
    mesh edge ``right_edge_m`` (unequal edges give points between two of the other side's)."""
    data = {
        "scene": {"name": "two_panels"},
        "simulation": {"gravity_m_s2": [0, 0, 0], "damping_per_s": damping,
                       "seam_hold_m": hold_m},
        "cloth": [
            {"name": "left", "size_m": [0.1, 0.1], "edge_length_m": 0.02,
             "material": "jersey", "origin_m": [-0.1, 0, 0]},
            {"name": "right", "size_m": [0.1, 0.1], "edge_length_m": right_edge_m,
             "material": "jersey", "origin_m": [0.1, 0, 0], "rotation_deg": [0, 180, 0]},
        ],
        "seam": [{"name": "middle", "a": [{"cloth": "left", "edge": 1}],
                  "b": [{"cloth": "right", "edge": 1}]}],
    }  # fmt: skip
    return build_scene(scene_from_dict(data, source="sewn.toml"))


def _pulled_apart(sc, speed_m_s: float = 1.0, open_m: float = 0.0):
    """Close the seam (each point onto its partner on the other side) but for ``open_m``
    [m], then send the two sides apart across the seam at ``speed_m_s``; run 0.2 s.
    Returns the gap after each frame (the largest over the seam) [m] and how much the
    total momentum changed [kg m/s]."""
    pairs, rest = sc.model.seam_pairs_np, sc.model.seam_rest_np
    x = sc.state.positions().astype(np.float64)
    zero = rest == 0
    x[pairs[zero, 1]] = x[pairs[zero, 0]]
    for q in np.flatnonzero(~zero)[::2]:  # a point between two: onto its partner point
        w = rest[q] / (rest[q] + rest[q + 1])
        x[pairs[q, 0]] = (1.0 - w) * x[pairs[q, 1]] + w * x[pairs[q + 1, 1]]
    x[np.unique(pairs[:, 1]), 2] -= open_m
    side = np.zeros(len(x))
    side[np.unique(pairs[:, 0])] = 1.0
    side[np.unique(pairs[:, 1])] = -1.0
    v = np.zeros_like(x)
    v[:, 2] = 0.5 * speed_m_s * side
    sc.state.set(x, v)
    mass = sc.model.particle_mass.to_numpy()[: len(x)]
    start = (mass[:, None] * v).sum(axis=0)
    gaps = []
    for _ in range(6):
        sc.solver.advance(sc.state, sc.control, sc.dt_s, sc.steps_per_frame)
        gaps.append(seam_openings(pairs, rest, sc.state.positions().astype(np.float64)).max())
    return gaps, (mass[:, None] * sc.state.velocities()).sum(axis=0) - start


def test_a_sewn_stitch_opens_no_further_than_the_hold():
    free, _ = _pulled_apart(_two_panels(0.0))
    held, momentum = _pulled_apart(_two_panels(1e-3))
    assert max(free) > 3e-3  # the springs alone let the seam open by millimetres
    assert max(held) <= 1e-3 * 1.02
    assert np.abs(momentum).max() < 1e-9  # the hold's impulses come in equal pairs


def test_a_stitch_caught_open_is_drawn_in_to_the_hold():
    """Caught 2.5 mm open (within 3 holds), pulled apart: it opens no further, and the
    thread draws it in to 1 mm at 1 cm/s (0.15 s)."""
    gaps, _ = _pulled_apart(_two_panels(1e-3), open_m=2.5e-3)
    assert max(gaps) <= 2.5e-3 * 1.01
    assert gaps[-1] <= 1e-3 * 1.02


def test_the_hold_keeps_a_point_between_two_on_the_other_side():
    sc = _two_panels(1e-3, right_edge_m=0.033)
    assert np.any(sc.model.seam_rest_np > 0)  # unequal sides: points between two
    held, momentum = _pulled_apart(sc)
    assert max(held) <= 1e-3 * 1.02
    assert np.abs(momentum).max() < 1e-9


def test_an_open_seam_is_sewn_by_its_springs_alone():
    """A stitch not yet closed is not held: the first steps with and without the hold
    are the same, as the panels start 2 cm apart."""
    runs = []
    for hold in (0.0, 1e-3):
        sc = _two_panels(hold)
        x = sc.state.positions().astype(np.float64)
        x[np.unique(sc.model.seam_pairs_np[:, 1])] += [0.0, 0.0, 0.02]
        sc.state.set(x, np.zeros_like(x))
        sc.solver.advance(sc.state, sc.control, sc.dt_s, 20)
        runs.append(sc.state.positions())
        assert np.all(sc.model.seam_limit.to_numpy() < 0)  # none caught
    assert np.array_equal(runs[0], runs[1])


def test_the_hold_is_checked():
    data = {"scene": {"name": "s"}, "simulation": {"seam_hold_m": -1.0},
            "cloth": [{"name": "c", "size_m": [0.1, 0.1], "edge_length_m": 0.02}]}  # fmt: skip
    with pytest.raises(SandboxError, match="seam_hold_m"):
        scene_from_dict(data, source="s.toml")
    data["simulation"] = {"seam_hold_m": 1e-3, "integrator": "implicit_euler"}
    with pytest.raises(SandboxError, match="seam_hold_m"):
        scene_from_dict(data, source="s.toml")


def test_the_thread_carries_the_pull_of_a_held_stitch_in_the_residual():
    """At a stitch held at its limit the thread pulls the sides together with whatever
    tension the cloth asks; a stitch pushed together, or not yet closed, gets nothing."""
    from sandbox.sim.residual import thread_tension

    sc = _two_panels(1e-3)
    pairs = sc.model.seam_pairs_np
    assert np.all(sc.model.seam_rest_np == 0)
    x = sc.state.positions().astype(np.float64)
    x[pairs[:, 1]] = x[pairs[:, 0]] - [0.0, 0.0, 1e-3]  # a opens 1 mm along +z from b
    f = np.zeros_like(x)
    f[pairs[:, 0], 2], f[pairs[:, 1], 2] = 2.0, -2.0  # pulled apart
    assert np.abs(thread_tension(sc.model, x, f)).max() == pytest.approx(2.0)  # not closed
    sc.model.seam_limit.fill(1e-3)
    assert np.abs(thread_tension(sc.model, x, f)).max() == pytest.approx(0.0, abs=1e-12)
    pushed = thread_tension(sc.model, x, -f)
    assert np.array_equal(pushed, -f)
