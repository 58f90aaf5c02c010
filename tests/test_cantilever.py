"""The heavy-elastica cantilever (validation.md §1-2) and bending at any resolution."""

import math

import pytest

from sandbox.pattern.mesh2d import mesh_polygon
from sandbox.sim.hinges import bending_calibration, find_hinges
from sandbox.validate.cantilever import run_cantilever
from sandbox.validate.elastica import TABLE, chord_angle_deg, tip


@pytest.mark.parametrize("lam", sorted(TABLE))
def test_reference_solver_reproduces_the_validation_table(lam):
    drop, reach = tip(lam)
    assert drop == pytest.approx(TABLE[lam][0], abs=6e-6)
    assert reach == pytest.approx(TABLE[lam][1], abs=6e-6)


def test_astm_angle_is_the_exact_elastica_angle_at_lambda_8():
    assert chord_angle_deg(*tip(8.0)) == pytest.approx(41.487, abs=1e-3)


@pytest.mark.slow
def test_cantilever_lambda_8_gives_the_astm_chord_angle():
    """λ = 8 (c = l/2): the chord makes 41.5° with the horizontal, within 0.5°."""
    run = run_cantilever(8.0, 0.0025)
    assert run.converged
    assert run.chord_angle_deg == pytest.approx(41.487, abs=0.5), run
    assert run.tip_error_pct_L < 1.0


@pytest.mark.slow
def test_cantilever_error_falls_with_the_mesh_size():
    coarse = run_cantilever(4.0, 0.005)
    fine = run_cantilever(4.0, 0.0025)
    assert fine.tip_error_pct_L < coarse.tip_error_pct_L
    assert fine.tip_error_pct_L < 1.5


def test_bending_calibration_does_not_depend_on_resolution():
    """The hinge weight l²/(A0+A1) and the measured factor make B mesh-size independent."""
    outline = [[0, 0], [0.3, 0], [0.3, 0.2], [0, 0.2]]
    factors = []
    for h in (0.02, 0.01):
        p, t = mesh_polygon(outline, h)
        factors.append(bending_calibration(p, t, find_hinges(t)))
    assert factors[0] == pytest.approx(factors[1], rel=0.08), factors
    assert all(0.7 < f < 1.5 and math.isfinite(f) for f in factors)
