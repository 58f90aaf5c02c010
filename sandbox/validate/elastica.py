"""Reference solution of the heavy elastica (validation.md §1-2).

An inextensible, unshearable strip of length L, clamped horizontally at s = 0 and loaded
by its own weight w per unit length: B θ''(s) = −w (L − s) cos θ(s), θ(0) = 0, θ'(L) = 0.
With σ = s/L and λ = w L³ / B:  θ''(σ) = −λ (1 − σ) cos θ(σ).

``solve(λ)`` solves this boundary-value problem by collocation (scipy's solve_bvp) for any
0 < λ <= ``LAMBDA_MAX``, by continuation in λ: the linear beam is the first guess up to
λ = 1, and each power of two up to λ starts from the solution at the one below it. As λ
grows the strip hangs nearly vertically below a boundary layer at the clamp about λ^-1/2
thick, where shooting on θ'(0) amplifies errors like exp(λ^1/2) and fails between λ = 300
and 500; collocation does not. ``tip(λ)`` returns the tip position. ``tip_by_shooting(λ)``
(solve_ivp and brentq on θ'(0)) is the independent check where it works, and ``TABLE``
holds validation.md's values for the test that checks both.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.integrate import solve_bvp, solve_ivp
from scipy.optimize import brentq

LAMBDA_MAX = 1e5  # the ladder of powers of two up to here takes about 2 s
BVP_TOL = 1e-8  # solve_bvp's relative collocation residual: tips to about 1e-12
BVP_MAX_NODES = 200_000

# validation.md §2 (COMPUTED there with two independent solvers): λ -> (y_tip/L, x_tip/L)
TABLE = {
    0.5: (0.06231, 0.99778),
    1.0: (0.12347, 0.99125),
    2.0: (0.23851, 0.96689),
    4.0: (0.42516, 0.89011),
    8.0: (0.64063, 0.72442),
    10.0: (0.70020, 0.65635),
    20.0: (0.82988, 0.44523),
    30.0: (0.87309, 0.34276),
    50.0: (0.90792, 0.24501),
    100.0: (0.93752, 0.15922),
}


@dataclass(frozen=True)
class ElasticaSolution:
    """The heavy elastica for one λ, in units of L; ``curve(σ)`` gives (θ, θ', x, y)."""

    lam: float
    drop: float  # y_tip / L, positive downwards
    reach: float  # x_tip / L
    tip_angle_deg: float  # θ(1)
    root_curvature: float  # θ'(0) L
    residual: float  # moment-balance residual, relative to the root moment
    nodes: int
    curve: object  # scipy PPoly: σ -> (θ, θ', x, y)


def heavy_elastica_rhs(sigma, state, lam: float):
    """θ'' = −λ (1 − σ) cos θ with x' = cos θ, y' = sin θ; state = (θ, θ', x, y).

    Works on one point (state of shape (4,), for solve_ivp) or many (shape (4, m))."""
    theta, kappa, _, _ = state
    c = np.cos(theta)
    return np.array([kappa, -lam * (1.0 - sigma) * c, c, np.sin(theta)])


def heavy_elastica_jacobian(sigma, state, lam: float):
    """∂(heavy_elastica_rhs)/∂state, shape (4, 4, m), for solve_bvp's Newton iteration."""
    theta = state[0]
    jac = np.zeros((4, 4, theta.size))
    jac[0, 1] = 1.0
    jac[1, 0] = lam * (1.0 - sigma) * np.sin(theta)
    jac[2, 0] = -np.sin(theta)
    jac[3, 0] = np.cos(theta)
    return jac


def clamped_free_bc(at_root, at_tip):
    """θ(0) = 0 (clamped horizontally), x(0) = y(0) = 0, θ'(1) = 0 (no moment at the tip)."""
    return np.array([at_root[0], at_tip[1], at_root[2], at_root[3]])


# ∂(clamped_free_bc)/∂(state at the root), ∂/∂(state at the tip)
_BC_JAC = (np.array([[1.0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 1.0, 0], [0, 0, 0, 1.0]]),
           np.array([[0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0]]))  # fmt: skip


def linear_beam(sigma, lam: float):
    """The small-deflection beam under its own weight: θ = λ/6 (1 − (1 − σ)³), δ_tip = λ/8."""
    theta = lam / 6.0 * (1.0 - (1.0 - sigma) ** 3)
    kappa = lam / 2.0 * (1.0 - sigma) ** 2
    y = lam / 6.0 * (sigma - (1.0 - (1.0 - sigma) ** 4) / 4.0)
    return np.array([theta, kappa, sigma, y])


def hanging_limit(lam: float) -> tuple[float, float, float]:
    """Leading order as λ → ∞: (drop, reach, root curvature) = (1 − (2 − √2)/√λ, √(2/λ), √(2λ)).

    Below a boundary layer at the clamp the strip hangs vertically; in the layer (1 − σ) ≈ 1,
    so θ'² = 2λ (1 − sin θ), and x = ∫ cos θ dθ/θ', L − y = ∫ (1 − sin θ) dθ/θ' over
    0 <= θ <= π/2. The next terms are smaller by a factor O(λ^-1/2): they are 3 % of these
    at λ = 1000 and 0.3 % at λ = 1e5."""
    return 1.0 - (2.0 - math.sqrt(2.0)) / math.sqrt(lam), math.sqrt(2.0 / lam), math.sqrt(2.0 * lam)


def moment_balance_residual(curve, lam: float, sigma) -> float:
    """max |θ'(σ) − λ ∫_σ^1 (x(t) − x(σ)) dt| / θ'(0): the bending moment at σ against the
    moment of the weight beyond σ (B θ' = w ∫ (x(t) − x(s)) dt), an integral form of the
    equation that the collocation does not enforce directly."""
    state = curve(sigma)
    integral = curve.antiderivative()
    beyond = integral(1.0)[2] - integral(sigma)[2] - (1.0 - sigma) * state[2]
    root = abs(float(curve(0.0)[1]))
    return float(np.max(np.abs(state[1] - lam * beyond)) / max(root, 1e-300))


def _collocate(lam: float, sigma, guess):
    sol = solve_bvp(lambda s, y: heavy_elastica_rhs(s, y, lam), clamped_free_bc, sigma, guess,
                    fun_jac=lambda s, y: heavy_elastica_jacobian(s, y, lam),
                    bc_jac=lambda ya, yb: _BC_JAC, tol=BVP_TOL, bc_tol=1e-12,
                    max_nodes=BVP_MAX_NODES)  # fmt: skip
    if not sol.success:
        raise RuntimeError(f"heavy elastica, lambda = {lam:g}: solve_bvp failed: {sol.message}")
    return sol


@lru_cache(maxsize=32)
def _ladder(k: int):
    """The solution at λ = 2**k (k >= 0), continued from 2**(k - 1)."""
    if k == 0:
        sigma = np.linspace(0.0, 1.0, 41)
        return _collocate(1.0, sigma, linear_beam(sigma, 1.0))
    below = _ladder(k - 1)
    return _collocate(2.0**k, below.x, below.y)


def _check_lambda(lam: float) -> float:
    lam = float(lam)
    if not (0.0 < lam <= LAMBDA_MAX):  # also refuses NaN
        raise ValueError(f"heavy elastica: lambda = {lam:g} is outside 0 < lambda <= "
                         f"{LAMBDA_MAX:g}")  # fmt: skip
    return lam


@lru_cache(maxsize=64)
def solve(lam: float) -> ElasticaSolution:
    """The heavy elastica at λ = wL³/B, 0 < λ <= LAMBDA_MAX, by collocation and continuation.

    The answer does not depend on what was solved before: λ <= 1 starts from the linear
    beam, a larger λ from the fixed ladder λ = 1, 2, 4, ... just below it."""
    lam = _check_lambda(lam)
    if lam <= 1.0:
        sigma = np.linspace(0.0, 1.0, 41)
        sol = _collocate(lam, sigma, linear_beam(sigma, lam))
    else:
        k = math.floor(math.log2(lam))
        below = _ladder(k)
        sol = below if 2.0**k == lam else _collocate(lam, below.x, below.y)
    # the residual on the nodes and three points inside every interval
    quarters = sol.x[:-1, None] + np.diff(sol.x)[:, None] * (np.arange(4) / 4.0)
    fine = np.append(quarters.ravel(), 1.0)
    theta_tip, _, reach, drop = sol.sol(1.0)
    return ElasticaSolution(
        lam=lam,
        drop=float(drop),
        reach=float(reach),
        tip_angle_deg=math.degrees(float(theta_tip)),
        root_curvature=float(sol.y[1, 0]),
        residual=moment_balance_residual(sol.sol, lam, fine),
        nodes=len(sol.x),
        curve=sol.sol,
    )


def tip(lam: float) -> tuple[float, float]:
    """Exact tip of the heavy elastica: (drop y/L, horizontal reach x/L), both positive.

    λ = 0 is the straight strip; otherwise 0 < λ <= LAMBDA_MAX (``solve``)."""
    if lam == 0:
        return 0.0, 1.0
    s = solve(float(lam))
    return s.drop, s.reach


def _shoot(kappa0: float, lam: float):
    return solve_ivp(heavy_elastica_rhs, (0.0, 1.0), [0.0, kappa0, 0.0, 0.0], args=(lam,),
                     rtol=1e-11, atol=1e-12)  # fmt: skip


@lru_cache(maxsize=64)
def tip_by_shooting(lam: float) -> tuple[float, float]:
    """The tip by shooting on θ'(0): an independent check of ``solve``, for λ up to about 300.

    Past that the initial-value problem amplifies errors like exp(λ^1/2) and no root with
    0 <= θ <= π/2 along the strip is found: RuntimeError."""
    lam = _check_lambda(lam)
    # θ'(1) as a function of the root curvature θ'(0) < λ/2 (the linear beam's value).
    # Scan for sign changes and keep the physical root: 0 <= θ <= π/2 along the strip.
    f = lambda k: _shoot(k, lam).y[1, -1]  # noqa: E731
    grid = np.linspace(1e-9, lam / 2.0, 41)
    values = [f(k) for k in grid]
    k0 = None
    for j in range(len(grid) - 1):
        if np.isfinite(values[j]) and np.isfinite(values[j + 1]) and values[j] < 0 <= values[j + 1]:
            k = brentq(f, grid[j], grid[j + 1], xtol=1e-13)
            theta = _shoot(k, lam).y[0]
            if theta.min() >= -1e-9 and theta.max() <= math.pi / 2 + 1e-9:
                k0 = k
                break
    if k0 is None:
        raise RuntimeError(f"shooting: no physical elastica solution found for lambda = {lam:g}")
    sol = _shoot(k0, lam)
    return float(sol.y[3, -1]), float(sol.y[2, -1])


def chord_angle_deg(drop: float, reach: float) -> float:
    """Angle of the root-to-tip chord below the horizontal [deg]."""
    return math.degrees(math.atan2(drop, reach))


def lam_for(B_Nm: float, density_kg_m2: float, length_m: float, g: float = 9.80665) -> float:
    """λ = w L³ / B with w = ρ_A g (per unit width)."""
    return density_kg_m2 * g * length_m**3 / B_Nm


def bend_for(lam: float, density_kg_m2: float, length_m: float, g: float = 9.80665) -> float:
    """B [N·m] that gives λ for this strip."""
    return density_kg_m2 * g * length_m**3 / lam


__all__ = ["TABLE", "LAMBDA_MAX", "ElasticaSolution", "solve", "tip", "tip_by_shooting",
           "heavy_elastica_rhs", "linear_beam", "hanging_limit", "moment_balance_residual",
           "chord_angle_deg", "lam_for", "bend_for", "np"]  # fmt: skip
