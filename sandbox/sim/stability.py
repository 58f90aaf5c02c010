"""The explicit step's stability limit measured on the cloth as it lies, not bounded.

Symplectic Euler is stable for dt·ω_max < 2, ω_max² the largest eigenvalue of M⁻¹K (K the
stiffness, the Jacobian of minus the forces). ``stable_dt_estimate``
(:mod:`sandbox.scene.build`) bounds ω_max by per-vertex sums (Gershgorin) on the rest
shape: safe, and about 1.4 times too low on a draped garment. Here ω_max² is measured by
power iteration on M⁻¹K, each product K v a central difference of the solver's own
undamped forces (``static_forces``), at a given state. Power iteration approaches the
largest eigenvalue from below, so the result is scaled by a margin, and a caller keeps the
guard (:mod:`sandbox.sim.guard`) as the safety net for the deformations still to come.
"""

import math

import numpy as np

POWER_ITERATIONS = 40
"""Iterations of the power method: on the 1 cm t-shirt at rest the estimate is within
0.5 % of its 60-iteration value after 30."""
EIGEN_MARGIN = 1.15
"""ω_max² is taken this much above the power method's estimate."""
PROBE_M = 1e-5
"""The largest vertex displacement of a finite-difference probe [m]."""


def measured_stable_dt(solver, state, control, model, *, iterations: int = POWER_ITERATIONS,
                       seed: int = 0) -> float:  # fmt: skip
    """2 / ω_max [s] of the cloth at ``state`` (free particles only), with ω_max² the
    power method's estimate of the largest |eigenvalue| of M⁻¹K times :data:`EIGEN_MARGIN`.
    Leaves the state's positions as they were. ``solver`` needs ``static_forces``."""
    lam = dominant_eigenvalue(solver, state, control, model, iterations=iterations, seed=seed)
    return limit_of(lam)


def limit_of(lam: float) -> float:
    """The explicit stability limit 2 / ω_max [s] for a dominant eigenvalue ``lam`` [1/s²]
    of M⁻¹K (its magnitude, times :data:`EIGEN_MARGIN`)."""
    lam = abs(lam) * EIGEN_MARGIN
    return 2.0 / math.sqrt(lam) if lam > 0 else math.inf


def dominant_eigenvalue(solver, state, control, model, *, iterations: int = POWER_ITERATIONS,
                        seed: int = 0) -> float:  # fmt: skip
    """The power method's estimate of the eigenvalue of M⁻¹K [1/s²] largest in magnitude,
    with its sign, at ``state`` (free particles only; 0 when none is free). Negative: the
    dominant mode is a compression instability (an element squeezed flat), not a
    stiffness. Leaves the state's positions as they were."""
    x0 = state.positions().astype(np.float64)
    v0 = state.velocities()
    n = len(x0)
    mass = model.particle_mass.to_numpy().astype(np.float64)[:n]  # the inertia the solver uses
    free = ~model.pinned_np[:n]
    if not free.any():
        return 0.0
    u = np.random.default_rng(seed).standard_normal(x0.shape)
    u[~free] = 0.0
    lam = 0.0
    try:
        for _ in range(iterations):
            u /= math.sqrt(float((mass[:, None] * u * u).sum()))
            eps = PROBE_M / float(np.abs(u).max())
            state.set(x0 + eps * u, v0)
            f_plus = solver.static_forces(state.x, control.gravity)
            state.set(x0 - eps * u, v0)
            f_minus = solver.static_forces(state.x, control.gravity)
            ku = -(f_plus - f_minus) / (2.0 * eps)
            ku[~free] = 0.0
            lam = float((u * ku).sum()) / float((mass[:, None] * u * u).sum())
            u = ku / mass[:, None]
            if not np.isfinite(u).all() or not np.abs(u).max() > 0:
                break
    finally:
        state.set(x0, v0)
    return lam
