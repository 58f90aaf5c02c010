"""The implicit step's line search and Newton stopping rule.

A backtracking line search on E makes every Newton step decrease the energy (Armijo),
along the step actually taken (a vertex stopped at a contact plane moves less). The
iteration stops when the estimated distance to the solution of this step,
|Δx_k|_∞ / (1 − ρ) with ρ = |Δx_k|_∞ / |Δx_k−1|_∞ the observed contraction
(:func:`newton_error_estimate`), is below ``tol_m_s·h + rel_tol·max_i |x_i − x_n,i|``.

A mixin of :class:`sandbox.sim.implicit.ImplicitEulerSolver` (its fields and settings).
"""

import math

import taichi as ti

from sandbox.sim.implicit_config import REAL


class LineSearch:
    """Initial guess, trial points, Armijo backtracking and acceptance."""

    def _initial_guess(self) -> None:
        """Start from x̂ = x_n + h v_n + h² g or from x_n + h v_n, whichever has the lower E.

        x̂ is exact in free flight; x_n + h v_n does not pull a hanging stiff sheet by h² g
        against its pins (a residual 100x smaller in the first Newton iteration).
        """
        e_hat = self._trial_gravity(1.0)
        if self._trial_gravity(0.0) > e_hat:
            self._trial_gravity(1.0)
        self._accept()

    def _line_search(self, e0: float) -> int:
        """Backtracking on E along Δx from E = ``e0`` (Armijo, on the slope of the step
        actually taken: a vertex stopped at a contact plane moves less); returns the number
        of halvings."""
        alpha, cuts = 1.0, 0
        eps = 1e-12 * abs(e0)  # round-off allowance (E, x and the gradient are float64)
        while True:
            e, moved_slope = self._trial(alpha)
            if e <= e0 + self.config.armijo * moved_slope + eps or cuts >= 30:
                break
            alpha *= 0.5
            cuts += 1
        self._accept()
        return cuts

    @ti.kernel
    def _post_solve(self, dx_in: ti.types.ndarray(), load: ti.template()) -> ti.types.vector(
        3, ti.f64
    ):
        """(max|Δx| [m], max|x − x_n| [m], ∇E·Δx [J]) after a solve; with ``load``, Δx is
        first read from ``dx_in`` (n, 3) (the direct solver's numpy result)."""
        self.max_dx[None] = 0.0
        self.max_move[None] = 0.0
        self.slope[None] = 0.0
        ti.loop_config(serialize=self.serial)
        for i in range(self.model.particle_count):
            if ti.static(load):
                self.dx[i] = ti.Vector([dx_in[i, 0], dx_in[i, 1], dx_in[i, 2]], REAL)
            ti.atomic_max(self.max_dx[None], self.dx[i].norm())
            ti.atomic_max(self.max_move[None], (self.x[i] - self.x0[i]).norm())
            self.slope[None] += ti.cast(self.grad[i].dot(self.dx[i]), ti.f64)
        dx_max = ti.cast(self.max_dx[None], ti.f64)
        move_max = ti.cast(self.max_move[None], ti.f64)
        return ti.Vector([dx_max, move_max, self.slope[None]], ti.f64)

    @ti.kernel
    def _trial(self, alpha: float) -> ti.types.vector(2, ti.f64):
        """xt = x + α Δx, each vertex's step stopped where it would pass through a contact
        plane it is in front of (:meth:`_stop_at_planes`); returns (E(xt) [J],
        ∇E·(xt − x) [J])."""
        self.slope_t[None] = 0.0
        ti.loop_config(serialize=self.serial)
        for i in range(self.model.particle_count):
            d = alpha * self.dx[i]
            if ti.static(self.has_contact):
                d = self._stop_at_planes(i, d)
            self.xt[i] = self.x[i] + d
            self.slope_t[None] += ti.cast(self.grad[i].dot(d), ti.f64)
        self.energy_t[None] = 0.0
        self._elastic_energy(self.xt, self.energy_t)
        ti.loop_config(serialize=self.serial)
        for i in range(self.model.particle_count):
            self.energy_t[None] += ti.cast(self._vertex_energy(i, self.xt[i]), ti.f64)
        return ti.Vector([self.energy_t[None], self.slope_t[None]], ti.f64)

    @ti.kernel
    def _trial_gravity(self, w: float) -> ti.f64:
        """xt = x_n + h v_n + w (x̂ − x_n − h v_n) on free vertices (dx holds h v_n)."""
        ti.loop_config(serialize=self.serial)
        for i in range(self.model.particle_count):
            self.xt[i] = self.x0[i]
            if self.model.particle_inv_mass[i] > 0.0:
                self.xt[i] = self.x0[i] + self.dx[i] + w * (self.xh[i] - self.x0[i] - self.dx[i])
        self.energy_t[None] = 0.0
        self._elastic_energy(self.xt, self.energy_t)
        ti.loop_config(serialize=self.serial)
        for i in range(self.model.particle_count):
            self.energy_t[None] += ti.cast(self._vertex_energy(i, self.xt[i]), ti.f64)
        return self.energy_t[None]

    @ti.kernel
    def _accept(self):
        ti.loop_config(serialize=self.serial)
        for i in range(self.model.particle_count):
            self.x[i] = self.xt[i]


def newton_error_estimate(step: float, previous: float, tol: float) -> float:
    """Distance [m] from the iterate to the solution, estimated from two Newton steps.

    With the contraction ρ = |Δx_k|/|Δx_k−1| the remaining error is about |Δx_k|/(1 − ρ)
    (|Δx_k| when Newton converges quadratically, ρ → 0). A step that did not contract
    (ρ >= 1) gives no estimate: infinity, so slow or stalled iterations never pass for
    converged because their steps happen to be small. The first step of a solve
    (``previous`` infinite) has no ρ: it passes only if it is below tol/1000 (the start was
    already the answer, as in free flight), so a step normally takes two Newton iterations.
    """
    if not math.isfinite(previous):
        return step if step <= 1e-3 * tol else math.inf
    rho = step / previous if previous > 0.0 else math.inf
    return step / (1.0 - rho) if rho < 1.0 else math.inf
