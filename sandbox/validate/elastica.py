"""Reference solution of the heavy elastica (validation.md §1-2).

An inextensible, unshearable strip of length L, clamped horizontally at s = 0 and loaded
by its own weight w per unit length: B θ''(s) = −w (L − s) cos θ(s), θ(0) = 0, θ'(L) = 0.
With σ = s/L and λ = w L³ / B:  θ''(σ) = −λ (1 − σ) cos θ(σ).

``tip(λ)`` solves this by shooting on θ'(0) (scipy's solve_ivp and brentq) and returns the
tip position; ``TABLE`` holds validation.md's values for the test that checks the solver.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

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


def _shoot(kappa0: float, lam: float):
    def rhs(s, y):
        theta, dtheta, _, _ = y
        return [dtheta, -lam * (1.0 - s) * math.cos(theta), math.cos(theta), math.sin(theta)]

    return solve_ivp(rhs, (0.0, 1.0), [0.0, kappa0, 0.0, 0.0], rtol=1e-11, atol=1e-12)


@lru_cache(maxsize=64)
def tip(lam: float) -> tuple[float, float]:
    """Exact tip of the heavy elastica: (drop y/L, horizontal reach x/L), both positive."""
    if lam <= 0:
        return 0.0, 1.0
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
        raise RuntimeError(f"no physical elastica solution found for lambda = {lam}")
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


__all__ = ["TABLE", "tip", "chord_angle_deg", "lam_for", "bend_for", "np"]
