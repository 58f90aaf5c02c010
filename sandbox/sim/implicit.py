"""Implicit (backward) Euler for stiff cloth, solved by Newton: the launch order of a step.

Each step of ``h`` [s] minimises the incremental potential (Baraff and Witkin 1998 in its
optimisation form, e.g. Martin et al. 2011; Gast et al. 2015)

    E(x) = Σ_i m_i/(2h²) |x_i − x̂_i|² + Σ_i γ m_i/(2h) |x_i − x_n,i|² + U(x),
    x̂ = x_n + h v_n + h² g,

where U is the same energy as the explicit solver (Eq. 7 membrane, bending, seams) and γ is
``control.damping_per_s`` (the explicit solver's −γ m v force, taken at v_n+1; γ = 0 leaves
backward Euler's own numerical damping only). ∇E = 0 is exactly backward Euler:
m (x − x̂)/h² = F(x) − γ m v_n+1, with v_n+1 = (x − x_n)/h.

Newton: at iterate x solve (M(1/h² + γ/h) + H) Δx = −∇E (:mod:`sandbox.sim.implicit_linear`;
E, ∇E and H in :mod:`sandbox.sim.implicit_system`); H is the per-element positive
semi-definite Hessian of :mod:`sandbox.sim.hessians`, so the system is SPD. A backtracking
line search on E (:mod:`sandbox.sim.implicit_line_search`) makes every Newton step decrease
the energy, and the iteration stops when the estimated distance to this step's solution is
below ``tol_m_s·h + rel_tol·max_i |x_i − x_n,i|``. A step that reaches ``max_newton``
iterations first is counted as unconverged in :meth:`ImplicitEulerSolver.stats` (never
silently). The settings are one :class:`~sandbox.sim.implicit_config.ImplicitConfig`.

Contact with the body is part of E (:mod:`sandbox.sim.implicit_contact`). After the solve,
as a safety net, v_n+1 = (x − x_n)/h is revised by each collider's ``respond`` (and the
cloth's self-collision pass, when the scene has one) and x_n+1 = x_n + h v_n+1, as the
explicit solver does after its velocity update.
"""

import math
import time

import numpy as np
import taichi as ti

from sandbox import runtime
from sandbox.sim.implicit_config import REAL, ImplicitConfig, resolve_linear_solver
from sandbox.sim.implicit_contact import BodyContact
from sandbox.sim.implicit_line_search import LineSearch, newton_error_estimate
from sandbox.sim.implicit_linear import LinearSolve
from sandbox.sim.implicit_system import NewtonSystem
from sandbox.sim.integrator import ContactFriction, read_friction, write_friction
from sandbox.sim.model import Control, Model, State  # noqa: F401 (used in annotations)

NO_STEP = 2**31 - 1  # the NaN watch's "none yet"
DEFAULT_CONFIG = ImplicitConfig()


@ti.data_oriented
class ImplicitEulerSolver(NewtonSystem, LinearSolve, LineSearch, BodyContact):
    """Backward Euler with Newton; implements :class:`~sandbox.sim.integrator.Integrator`.

    Args:
        model: the cloth model.
        config: the Newton, line-search and body-contact settings (units and defaults in
            :class:`~sandbox.sim.implicit_config.ImplicitConfig`).
    """

    def __init__(self, model: Model, *, config: ImplicitConfig = DEFAULT_CONFIG):
        self.model = model
        self.config = config
        self.fused = runtime.arch() == "cpu" and model.particle_count <= config.fused_particle_limit
        # small meshes: every loop serial (no thread-pool launch, atomics become plain adds)
        self.serial = self.fused
        self.linear_solver = resolve_linear_solver(config.linear_solver,
                                                   config.compression_stiffness)  # fmt: skip
        n = max(1, model.particle_count)
        m = max(1, model.tri_count)
        vec = lambda k: ti.Vector.field(3, REAL, shape=k)  # noqa: E731
        mat = lambda k: ti.Matrix.field(3, 3, REAL, shape=k)  # noqa: E731
        self.x0, self.xh, self.x, self.xt, self.vel = vec(n), vec(n), vec(n), vec(n), vec(n)
        self.grad, self.dx, self.r, self.z, self.p, self.ap = (vec(n) for _ in range(6))
        self.pinv = mat(n)
        self.t_gu, self.t_gv, self.t_zu, self.t_zv = vec(m), vec(m), vec(m), vec(m)
        self.t_huu, self.t_huv, self.t_hvv = mat(m), mat(m), mat(m)
        self.t_puu, self.t_pvv = mat(m), mat(m)  # PSD blocks, for the preconditioner
        self.h_grad = self.h_k = self.h_s = self.h_z = None
        if model.hinge_count:
            nh = model.hinge_count
            self.h_grad = vec(4 * nh)
            self.h_k = ti.field(REAL, shape=nh)
            self.h_s = ti.field(REAL, shape=nh)
            self.h_z = ti.field(REAL, shape=nh)
        self.s_grad = self.s_hess = self.s_z = None
        if model.has_seams:
            ns = model.seam_capacity
            self.s_grad, self.s_hess, self.s_z = vec(ns), mat(ns), vec(ns)
        # live scalars (0-D fields: no recompilation when they change)
        self.h = ti.field(REAL, shape=())
        self.gamma = ti.field(REAL, shape=())
        self.energy = ti.field(ti.f64, shape=())
        self.energy_t = ti.field(ti.f64, shape=())
        self.rz = ti.field(ti.f64, shape=())
        self.rz_new = ti.field(ti.f64, shape=())
        self.pap = ti.field(ti.f64, shape=())
        self.rr = ti.field(ti.f64, shape=())
        self.slope = ti.field(ti.f64, shape=())
        self.slope_t = ti.field(ti.f64, shape=())  # ∇E·(xt − x) of the last trial [J]
        self.alpha = ti.field(REAL, shape=())
        self.beta = ti.field(REAL, shape=())
        self.max_dx = ti.field(REAL, shape=())
        self.max_res = ti.field(REAL, shape=())
        self.max_move = ti.field(REAL, shape=())
        self.negative = ti.field(ti.i32, shape=())  # CG met negative curvature
        self.cg_k = ti.field(ti.i32, shape=())
        self.bad_step = ti.field(ti.i32, shape=())
        self.bad_vertex = ti.field(ti.i32, shape=())
        self.c_n = self.c_o = self.c_n2 = self.c_o2 = self.c_k = self.c_k2 = None
        self.c_mu = self.c_lam = self.c_hess = None
        self.has_contact = bool(model.colliders)
        if self.has_contact:  # body contact in the step energy (only for scenes with bodies)
            self.c_n, self.c_n2, self.c_hess = vec(n), vec(n), mat(n)
            self.c_o, self.c_o2, self.c_k, self.c_k2, self.c_mu, self.c_lam = (
                ti.field(REAL, shape=n) for _ in range(6))  # fmt: skip
            # the planes' own offsets (without the start clamp), whether the vertex
            # started the step inside the body, and the push that lifted it out [m/s]
            self.c_t, self.c_t2 = ti.field(REAL, shape=n), ti.field(REAL, shape=n)
            self.c_in = ti.field(ti.i32, shape=n)
            self.c_push = vec(n)
            # 1: the contact had no normal force at the start of the step, so its friction
            # takes λ at each Newton iterate; 0: λ of the step before, held (one energy)
            self.c_new = ti.field(ti.i32, shape=n)
            # where the last step left each vertex: a state that does not continue it (a
            # reset, a vertex moved by hand or by the untangling) gets no held λ
            self.x_end = vec(n)
            # the planes found by the last query (_find_planes): how many, from which
            # collider, where and how far it looked [m], and the bodies' generation then
            self.c_count, self.c_col = ti.field(ti.i32, shape=n), ti.field(ti.i32, shape=n)
            self.c_at = vec(n)
            self.c_reach, self.c_creach = ti.field(REAL, shape=n), ti.field(REAL, shape=n)
            self.c_gen = ti.field(ti.i32, shape=())
            self.c_kscale = ti.field(REAL, shape=n)  # the penalty's stiffening (x1 at start)
            self.c_kscale.fill(1.0)
            self.c_gen[None] = -1  # no query yet
        self.self_collider = model.self_collider  # None switches the passes off (sewing)
        self.sc_x = self.sc_v = None  # state-precision copies for a self-collision pass
        self.pattern = self.factor = self.dx_np = None
        self._no_dx = np.zeros((1, 3))
        if self.linear_solver == "direct":
            self._init_direct()
        self.reset_watch()
        self.reset_stats()
        self.last: dict = {}

    def step(self, state_in: State, state_out: State, control: Control, dt: float, index=0):
        """Advance one backward Euler step of ``dt`` [s] from ``state_in`` into ``state_out``.

        ``state_out`` may be ``state_in``. ``dt <= 0`` copies the state (and compiles the
        kernels, as :meth:`warm_up`).
        """
        if dt <= 0.0:
            self.warm_up(state_in, control)
            if state_out is not state_in:
                self._copy(state_in.x, state_in.v, state_out.x, state_out.v)
            return
        t0 = time.perf_counter()
        self._begin(state_in.x, state_in.v, control.gravity, control.damping_per_s, dt)
        if self.has_contact:
            self._contact_planes()
        self._initial_guess()
        newton = cg_total = 0
        converged = False
        step_norm = error = tol = math.inf
        line_search_cuts = 0
        previous = math.inf
        for _ in range(self.config.max_newton):
            e0 = float(self._grad_hess()[0])
            newton += 1
            cg_total += self._solve()
            direct = self.pattern is not None  # then Δx comes from dx_np
            step_norm, max_move, _slope = self._post_solve(self._dx_source(), direct)
            tol = self.config.tol_m_s * dt + self.config.rel_tol * max_move
            error = newton_error_estimate(step_norm, previous, tol)
            previous = step_norm
            if error <= tol:
                self._trial(1.0)
                self._accept()
                converged = True
                break
            line_search_cuts += self._line_search(e0)
        # the residual at the accepted point, for the stats (one more gradient evaluation)
        res = float(self._grad_hess()[1]) if self.config.step_residual else math.nan
        self._finish(state_out.x, state_out.v, index)
        self.last = {
            "newton_iterations": newton,
            "cg_iterations": cg_total,
            "final_step_m": step_norm,
            "final_step_m_s": step_norm / dt,
            "error_estimate_m": error,
            "tolerance_m": tol,
            "residual_force_over_weight": res,
            "line_search_halvings": line_search_cuts,
            "converged": converged,
            "wall_s": time.perf_counter() - t0,
        }
        t = self.totals
        t["steps"] += 1
        t["newton_iterations"] += newton
        t["cg_iterations"] += cg_total
        t["unconverged_steps"] += 0 if converged else 1
        t["line_search_halvings"] += line_search_cuts
        t["max_newton_iterations"] = max(t["max_newton_iterations"], newton)
        t["max_final_step_m_s"] = max(t["max_final_step_m_s"], step_norm / dt)
        t["max_error_estimate_m_s"] = max(t["max_error_estimate_m_s"], error / dt)
        t["max_error_over_tolerance"] = max(t["max_error_over_tolerance"], error / tol)
        if self.config.step_residual:
            t["max_residual_force_over_weight"] = max(t["max_residual_force_over_weight"], res)

    def advance(self, state: State, control: Control, dt: float, steps: int, first_index=0):
        """Advance ``state`` in place by ``steps`` steps of ``dt`` [s]."""
        for k in range(steps):
            self.step(state, state, control, dt, first_index + k)

    def warm_up(self, state: State, control: Control) -> None:
        """Compile every kernel a step of this model can reach; the state is not changed."""
        self._begin(state.x, state.v, control.gravity, control.damping_per_s, 1.0)
        if self.has_contact:
            self._contact_planes()
        self._trial_gravity(0.0)
        self._grad_hess()
        self._cg_init()
        self._cg_iter()
        self._cg_loop(1, 0.0)
        self._post_solve(self._dx_source(), self.pattern is not None)
        self._trial(0.0)
        self._internal_energy_kernel(state.x)
        if self.pattern is not None:
            self._assemble(self.blocks, self.grad_np)

    def reset_watch(self) -> None:
        self.bad_step[None] = NO_STEP
        self.bad_vertex[None] = NO_STEP

    def first_bad(self) -> tuple[int, int] | None:
        """(step, vertex) of the first non-finite position since the last reset, or None."""
        s = int(self.bad_step[None])
        return None if s == NO_STEP else (s, int(self.bad_vertex[None]))

    def reset_stats(self) -> None:
        self.totals = {
            "steps": 0,
            "newton_iterations": 0,
            "cg_iterations": 0,
            "unconverged_steps": 0,
            "line_search_halvings": 0,
            "max_newton_iterations": 0,
            "max_final_step_m_s": 0.0,
            "max_error_estimate_m_s": 0.0,
            "max_error_over_tolerance": 0.0,
            "max_residual_force_over_weight": 0.0,
        }

    def stats(self) -> dict:
        """Totals since the last :meth:`reset_stats` and the last step's figures (``last``).

        Per step: Newton iterations, CG iterations (summed over Newton), the last Newton
        step max|Δx| [m] and over h [m/s], the error estimate and the tolerance [m], the
        largest force residual of backward Euler at the accepted point over the vertex
        weight |∇E_i|/(m_i·9.80665), line-search halvings, converged (estimate <= tolerance).
        Totals keep the worst error/tolerance ratio over all steps. With the direct linear
        solver, "CG iterations" count 1 per exact solve plus the preconditioned iterations
        on reused factors, and ``factorisations`` counts the LU factorisations.
        """
        factorisations = self.factor.factorisations if self.factor is not None else 0
        c = self.config
        return {**self.totals, "tol_m_s": c.tol_m_s, "rel_tol": c.rel_tol,
                "cg_tol": c.cg_tol, "linear_solver": self.linear_solver,
                "factorisations": factorisations, "last": dict(self.last)}  # fmt: skip

    def internal_energy(self, state: State) -> float:
        """U = Σ (U_u + U_v + U_s) + Σ U_b + Σ U_seam of Eq. 7 [J]."""
        self.energy_t[None] = 0.0
        self._internal_energy_kernel(state.x)
        return float(self.energy_t[None])

    def set_speed_limit(self, limit_m_s: float) -> None:
        """Accepted and ignored: backward Euler needs no speed cap.

        The explicit solver caps speeds while sewing because a seam closing across
        centimetres would fling a stiff panel in one explicit step. Here each step minimises
        E, whose inertia term m/(2h²)|x − x̂|² and backward Euler's own numerical damping
        keep a closing seam's motion bounded, and a cap applied after the solve would leave
        v_n+1 inconsistent with the minimiser x (the step would no longer be backward
        Euler)."""

    def friction(self) -> ContactFriction:
        return read_friction(self.model, self.self_collider)

    def set_friction(self, friction: ContactFriction) -> None:
        write_friction(self.model, self.self_collider, friction)

    # ------------------------------------------------------------------ kernels
    @ti.kernel
    def _copy(self, xi: ti.template(), vi: ti.template(), xo: ti.template(), vo: ti.template()):
        ti.loop_config(serialize=self.serial)
        for i in range(self.model.particle_count):
            xo[i] = xi[i]
            vo[i] = vi[i]

    @ti.kernel
    def _begin(self, x_in: ti.template(), v_in: ti.template(), gravity: ti.template(),
               damping: ti.template(), dt: ti.f64):  # fmt: skip
        self.h[None] = dt
        self.gamma[None] = damping[None]
        h = self.h[None]
        ti.loop_config(serialize=self.serial)
        for i in range(self.model.particle_count):
            self.x0[i] = x_in[i]
            self.xh[i] = x_in[i] + h * v_in[i] + h * h * gravity[None]
            self.x[i] = x_in[i]  # pinned vertices stay
            self.dx[i] = ti.Vector.zero(REAL, 3)
            if self.model.particle_inv_mass[i] > 0.0:
                self.dx[i] = h * v_in[i]  # x_n + h v_n; _trial(1) adds h² g on top

    def _finish(self, x_out, v_out, index: int) -> None:
        """v_n+1 = (x − x_n)/h, contact revises it, x_n+1 = x_n + h v_n+1."""
        self._velocities()
        sc = self.self_collider
        if sc is not None:  # the cloth's self-collision pass, when the scene has one
            if self.sc_x is None:  # it works on state-precision fields
                n = max(1, self.model.particle_count)
                self.sc_x = ti.Vector.field(3, float, shape=n)
                self.sc_v = ti.Vector.field(3, float, shape=n)
            self._to_state_precision(self.sc_x, self.sc_v)
            sc.resolve(self.sc_x, self.sc_v, float(self.h[None]))
            self._from_state_precision(self.sc_v)
        self._drift(x_out, v_out, index)

    @ti.kernel
    def _to_state_precision(self, x: ti.template(), v: ti.template()):
        for i in range(self.model.particle_count):
            x[i] = ti.cast(self.x0[i], float)
            v[i] = ti.cast(self.vel[i], float)

    @ti.kernel
    def _from_state_precision(self, v: ti.template()):
        for i in range(self.model.particle_count):
            self.vel[i] = v[i]

    @ti.kernel
    def _velocities(self):
        """vel := v_n+1, revised by each body collider (§2.5) from x_n, as Eq. 2's solver does."""
        m = self.model
        h = self.h[None]
        for i in range(m.particle_count):
            v = ti.Vector.zero(REAL, 3)
            if m.particle_inv_mass[i] > 0.0:
                xi = self.x[i]
                if ti.static(self.has_contact):  # the contact force, for next step's start
                    self._update_contact_force(i, xi)
                    xi = self._lift_out(i, xi)
                v = (xi - self.x0[i]) / h
                if ti.static(len(m.colliders) > 0):
                    # the colliders work in the state's precision (as in the explicit solver)
                    xs = ti.cast(self.x0[i], float)
                    vs = ti.cast(v, float)
                    hs = ti.cast(h, float)
                    for c in ti.static(m.colliders):
                        vs = c.respond(xs, vs, hs)
                    v = ti.cast(vs, REAL)
                if ti.static(self.has_contact):
                    v = self._out_of_crease(i, v)
            self.vel[i] = v

    @ti.kernel
    def _drift(self, x_out: ti.template(), v_out: ti.template(), index: ti.i32):
        m = self.model
        h = self.h[None]
        for i in range(m.particle_count):
            v = self.vel[i]
            x_new = self.x0[i] + h * v
            if ti.static(self.has_contact):
                v -= self.c_push[i]  # the lift out of the body moves, it does not launch
            if not (ti.abs(x_new).max() < 1e30):  # catches NaN and infinity
                ti.atomic_min(self.bad_step[None], index)
                ti.atomic_min(self.bad_vertex[None], i)
            x_out[i] = ti.cast(x_new, float)
            v_out[i] = ti.cast(v, float)
            if ti.static(self.has_contact):
                self.x_end[i] = ti.cast(x_out[i], REAL)
