"""The heavy-elastica reference for every λ the cantilever can take (0 < λ <= 1e5)."""

import math

import pytest

from sandbox.validate.elastica import (
    LAMBDA_MAX,
    hanging_limit,
    linear_beam,
    solve,
    tip,
    tip_by_shooting,
)

LAMBDAS = [1e-3, 0.1, 1.0, 8.0, 30.0, 100.0, 300.0, 1000.0, 2000.0, 1e4, 1e5]


@pytest.mark.parametrize("lam", LAMBDAS)
def test_solution_balances_the_moment_everywhere(lam):
    s = solve(lam)
    assert s.residual < 1e-8, s
    assert 0 < s.drop < 1 and 0 < s.reach < 1
    assert math.hypot(s.drop, s.reach) <= 1.0  # the chord is no longer than the strip
    assert 0 < s.tip_angle_deg <= 90.0 + 1e-9
    theta, kappa, _, _ = s.curve([0.0, 0.25, 0.5, 0.75, 1.0])
    assert theta[0] == pytest.approx(0.0, abs=1e-12) and kappa[-1] == pytest.approx(0, abs=1e-9)


def test_tip_drops_and_pulls_in_monotonically_with_lambda():
    sols = [solve(lam) for lam in LAMBDAS]
    drops = [s.drop for s in sols]
    reaches = [s.reach for s in sols]
    angles = [s.tip_angle_deg for s in sols]
    assert drops == sorted(drops) and len(set(drops)) == len(drops)
    assert reaches == sorted(reaches, reverse=True) and len(set(reaches)) == len(reaches)
    assert angles == sorted(angles)


def test_small_lambda_is_the_linear_beam():
    """δ/L = λ/8 and θ_tip = λ/6 as λ → 0."""
    s = solve(1e-3)
    assert s.drop == pytest.approx(1e-3 / 8, rel=1e-6)
    assert math.radians(s.tip_angle_deg) == pytest.approx(1e-3 / 6, rel=1e-6)
    assert s.root_curvature == pytest.approx(linear_beam(0.0, 1e-3)[1], rel=1e-6)


@pytest.mark.parametrize("lam", [1.0, 8.0, 30.0])
def test_collocation_agrees_with_shooting(lam):
    drop, reach = tip_by_shooting(lam)
    assert tip(lam) == pytest.approx((drop, reach), abs=1e-6)


def test_large_lambda_hangs_vertically():
    """θ_tip → 90°, and drop, reach and root curvature approach the boundary-layer limit
    with a relative error that shrinks like λ^-1/2."""
    gaps = []
    for lam in (1e3, 1e4, 1e5):
        s = solve(lam)
        assert s.tip_angle_deg == pytest.approx(90.0, abs=1e-4)
        drop, reach, kappa0 = hanging_limit(lam)
        gaps.append(max(abs(s.reach / reach - 1), abs((1 - s.drop) / (1 - drop) - 1),
                        abs(s.root_curvature / kappa0 - 1)))  # fmt: skip
    assert gaps[0] < 0.04 and gaps[2] < 0.004
    assert gaps[1] < gaps[0] / 2.5 and gaps[2] < gaps[1] / 2.5, gaps


@pytest.mark.parametrize("lam", [-1.0, math.nan, math.inf, 2 * LAMBDA_MAX])
def test_lambda_outside_the_range_is_refused(lam):
    with pytest.raises(ValueError, match="lambda"):
        solve(lam)


@pytest.mark.parametrize("lam", ["20000", "0.0001"])
def test_cantilever_refuses_a_lambda_it_cannot_simulate(lam, capsys):
    from sandbox.cli import main

    assert main(["validate", "cantilever", "--quick", "--lambdas", "8", lam]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: --lambdas {lam}:") and "0.001 <= lambda <= 10000" in err
    assert len(err.splitlines()) == 1
