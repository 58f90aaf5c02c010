"""Implicit (backward) Euler for stiff cloth, solved by Newton with Jacobi-preconditioned CG.

Each step of ``h`` [s] minimises the incremental potential (Baraff and Witkin 1998 in its
optimisation form, e.g. Martin et al. 2011; Gast et al. 2015)

    E(x) = Σ_i m_i/(2h²) |x_i − x̂_i|² + Σ_i γ m_i/(2h) |x_i − x_n,i|² + U(x),
    x̂ = x_n + h v_n + h² g,

where U is the same energy as the explicit solver (Eq. 7 membrane, bending, seams) and γ is
``control.damping_per_s`` (the explicit solver's −γ m v force, taken at v_n+1; γ = 0 leaves
backward Euler's own numerical damping only). ∇E = 0 is exactly backward Euler:
m (x − x̂)/h² = F(x) − γ m v_n+1, with v_n+1 = (x − x_n)/h.

Newton: at iterate x solve (M(1/h² + γ/h) + H) Δx = −∇E by conjugate gradients with a 3x3
block-Jacobi preconditioner, to a relative residual ``cg_tol``; H is the per-element
positive semi-definite Hessian of :mod:`sandbox.sim.hessians`, so the system is SPD. A
backtracking line search on E makes every Newton step decrease the energy (Armijo). The
iteration stops when the estimated distance to the solution of this step,
|Δx_k|_∞ / (1 − ρ) with ρ = |Δx_k|_∞ / |Δx_k−1|_∞ the observed contraction
(:func:`newton_error_estimate`), is below

    tol = tol_m_s · h + rel_tol · max_i |x_i − x_n,i|

an absolute velocity tolerance (default 1e-4 m/s: 1.7 µm at h = 1/60 s) plus, optionally
(``rel_tol``, default 0), a fraction of the largest motion in the step. Loose tolerances
fake damping: Newton stopped early leaves every step short of its solution in the same
(slow) direction, so a creeping cloth lags. Measured on the cantilever (docs/implicit.md):
1e-3 m/s, or 1e-4 m/s + 1 % of the motion, took 11x and 4x more steps to settle.
A step that reaches ``max_newton``
iterations first is counted as unconverged in :meth:`stats` (never silently).

Contact with the body is part of E (:meth:`ImplicitEulerSolver._contact_terms`): at the
start of a step each vertex near a body gets the plane of its nearest body face and, in a
concave crease, a second one (``BodyCollider.contact_planes``), and E gains a penalty
½ k φ² where φ = n·x − offset < 0 (inside the thickness) and a smoothed Coulomb friction
μ λ f(|u|) on the step's tangential motion u (Li et al. 2020, IPC's friction potential;
λ the penalty's force at the current Newton iterate, held during its line search). The
planes stay fixed during the step. In the solve, cloth slides along the body: a seam pulled
around the neck closes instead of stopping where its straight path enters the body. Then,
as a safety net, v_n+1 = (x − x_n)/h is revised by each collider's ``respond`` and
x_n+1 = x_n + h v_n+1, as the explicit solver does after its velocity update.

The matrix is never assembled: per element the solver keeps the small Hessian (the 6x6
membrane Hessian in F = [F_u, F_v] as three 3x3 blocks, the bending gradient and scale,
the seam 3x3 block) and the product is gathered per vertex through the model's incidence
lists, as the explicit solver gathers forces (no atomics, deterministic sums). One CG
iteration is one kernel launch.
"""

import math
import time

import numpy as np
import taichi as ti

from sandbox import runtime
from sandbox.sim import forces, hessians
from sandbox.sim.model import Control, Model, State  # noqa: F401 (used in annotations)

# On the CPU, up to this many particles the whole CG loop runs in one serial kernel launch
# (no launch and read-back per iteration); above it each iteration is one parallel launch.
FUSED_PARTICLE_LIMIT = 3000
NO_STEP = 2**31 - 1
REAL = ti.f64
"""The solver's own precision, whatever Taichi's default float: with float32 positions a
stiff membrane's strain (x_j − x_i, |F_u| − 1) drowns in round-off (the residual force of
denim x100 stayed at ~20x the vertex weight), so Newton could not reach its tolerance. The
state is read and written in the default float; everything in between is float64."""
ARMIJO = 1e-4
CONTACT_STIFFNESS = 1e3
"""Body contact penalty stiffness as a multiple of a vertex's m/h² [1]: a vertex pressed on
the body by a hundred times its weight sinks 0.27 mm into the thickness at 1/60 s. Adding
10 or 100 times the stiffness of the seams and triangles pulling on the vertex (so that a
seam being sewn cannot pull it deep into the body) makes Newton's line search halve its
steps 20-150 times a step and the sewing of the A-line skirt diverge; deeper pulls are
left to the contact response after the solve."""
CONTACT_REACH_M = 2e-2
"""A vertex gets a contact plane for the step when a body face is within this distance [m]
plus twice its predicted motion (|x̂ − x_n|) of its start."""
LIFT_MAX_M = 0.03
"""The longest lift [m] out of the body after a solve (``_front_of_planes``); a longer one
means planes that do not bound the body near the vertex, and it is not made."""
LIFT_MIN_SIN2 = 0.25
"""A crease's two planes are both used for a lift only when sin² of the angle between their
normals exceeds this (30° to 150°): the line where nearly parallel or opposite planes meet
is far away (with 1e-9 the vest's and the T-shirt's triangles stretch to 3.2 times their
length in the gallery)."""
PLANE_BAND_M = 1e-9
"""A vertex within this distance [m] of a contact plane, or behind it, has the plane's
penalty in its Newton matrix; one farther in front does not, and a Newton step that would
carry it through the plane stops it on the plane (``_stop_at_planes``)."""
FRICTION_SLIP_M_S = 1e-3
"""Friction's smoothing speed ε_v [m/s]: below it the friction force grows linearly with
the tangential speed (sticking creeps at most this fast), above it it is μ λ (Coulomb)."""


@ti.data_oriented
class ImplicitEulerSolver:
    """Backward Euler with Newton-PCG; same public interface as SymplecticEulerSolver.

    Args:
        model: the cloth model.
        tol_m_s: absolute part of the Newton tolerance, as a velocity [m/s].
        rel_tol: relative part: a fraction of the largest vertex motion of the step (0: off).
        cg_tol: CG stops when |r| <= cg_tol |r_0| (2-norm of the force residual).
        compression_stiffness: keep the (negative) geometric stiffness of compressed
            warp/weft columns in the Newton matrix and truncate CG at negative curvature.
            Off by default: measured slower on a falling stiff sheet (docs/implicit.md).
        max_newton: Newton iterations per step before the step is flagged unconverged.
        max_cg: CG iterations per Newton iteration.
        linear_solver: how each Newton system is solved. ``"direct"``: assembled and
            factorised by sparse LU, the factors reused as CG's preconditioner while they
            work (:mod:`sandbox.sim.sparse`); ``"cg"``: matrix-free CG with the block-Jacobi
            preconditioner, all in Taichi kernels (what a GPU runs); ``"auto"``: direct on
            the CPU, cg elsewhere or with ``compression_stiffness`` (whose matrix can be
            indefinite).
    """

    def __init__(
        self,
        model: Model,
        *,
        tol_m_s: float = 1e-4,
        cg_tol: float = 1e-1,
        max_newton: int = 50,
        max_cg: int = 2000,
        compression_stiffness: bool = False,
        rel_tol: float = 0.0,
        linear_solver: str = "auto",
    ):
        self.model = model
        self.fused = runtime.arch() == "cpu" and model.particle_count <= FUSED_PARTICLE_LIMIT
        # small meshes: every loop serial (no thread-pool launch, atomics become plain adds)
        self.serial = self.fused
        self.tol_m_s = float(tol_m_s)
        self.rel_tol = float(rel_tol)
        self.cg_tol = float(cg_tol)
        self.max_newton = int(max_newton)
        self.max_cg = int(max_cg)
        self.compression_stiffness = bool(compression_stiffness)
        self.linear_solver = resolve_linear_solver(linear_solver, self.compression_stiffness)
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
        self.self_collider = model.self_collider  # None switches the passes off (sewing)
        self.sc_x = self.sc_v = None  # state-precision copies for a self-collision pass
        self.pattern = self.factor = self.dx_np = None
        self._no_dx = np.zeros((1, 3))
        if self.linear_solver == "direct":
            self._init_direct()
        self.reset_watch()
        self.reset_stats()
        self.last: dict = {}

    # ------------------------------------------------------------------ public API
    def step(self, state_in: State, state_out: State, control: Control, dt: float, index=0):
        """Advance one backward Euler step of ``dt`` [s] from ``state_in`` into ``state_out``.

        ``state_out`` may be ``state_in``. ``dt <= 0`` copies the state (and compiles the
        kernels, as ``run_scene``'s warm-up expects).
        """
        if dt <= 0.0:
            self._warm_up(state_in, control)
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
        for _ in range(self.max_newton):
            e0 = float(self._grad_hess()[0])
            newton += 1
            cg_total += self._solve()
            direct = self.pattern is not None  # then Δx comes from dx_np
            step_norm, max_move, _slope = self._post_solve(self._dx_source(), direct)
            tol = self.tol_m_s * dt + self.rel_tol * max_move
            error = newton_error_estimate(step_norm, previous, tol)
            previous = step_norm
            if error <= tol:
                self._trial(1.0)
                self._accept()
                converged = True
                break
            line_search_cuts += self._line_search(e0)
        res = float(self._grad_hess()[1])  # residual at the accepted point, for the stats
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
        t["max_residual_force_over_weight"] = max(t["max_residual_force_over_weight"], res)

    def advance(self, state: State, control: Control, dt: float, steps: int, first_index=0):
        """Advance ``state`` in place by ``steps`` steps of ``dt`` [s]."""
        for k in range(steps):
            self.step(state, state, control, dt, first_index + k)

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
        return {**self.totals, "tol_m_s": self.tol_m_s, "rel_tol": self.rel_tol,
                "cg_tol": self.cg_tol, "linear_solver": self.linear_solver,
                "factorisations": factorisations, "last": dict(self.last)}  # fmt: skip

    def internal_energy(self, state: State) -> float:
        """U = Σ (U_u + U_v + U_s) + Σ U_b + Σ U_seam of Eq. 7 [J]."""
        self.energy_t[None] = 0.0
        self._internal_energy_kernel(state.x)
        return float(self.energy_t[None])

    def system_product(self, y):
        """(M (1/h² + γ/h) + H) y for y numpy (n, 3), with the Hessians of the last Newton
        evaluation (the end of the last step). For tests and diagnostics."""
        n = self.model.particle_count
        self.p.from_numpy(np.asarray(y, dtype=np.float64))
        self._apply_kernel()
        return self.ap.to_numpy()[:n].astype(np.float64)

    # ------------------------------------------------------------------ Newton pieces
    def _solve(self) -> int:
        """CG on (M c + H) Δx = −∇E; returns the iterations used."""
        if self.pattern is not None:
            return self._solve_direct()
        self._cg_init()
        rr0 = float(self.rr[None])
        if rr0 <= 0.0:
            return 0
        target = self.cg_tol * self.cg_tol * rr0
        if self.fused:
            return int(self._cg_loop(self.max_cg, target))
        for k in range(1, self.max_cg + 1):
            self._cg_iter()
            if float(self.rr[None]) <= target or self.negative[None]:
                return k
        return self.max_cg

    def _init_direct(self) -> None:
        """Fields for the assembled matrix (``linear_solver="direct"``)."""
        from sandbox.sim import sparse

        m = self.model
        self.pattern = sparse.BlockPattern(m)
        self.factor = sparse.FactorisedSolver()
        # numpy arrays the assembly kernel writes into directly (no copies, no extra launch)
        self.blocks = np.zeros((self.pattern.max_blocks(), 3, 3))
        self.grad_np = np.zeros((max(1, m.particle_count), 3))
        self.dx_np = np.zeros((max(1, m.particle_count), 3))
        self.tri_block = sparse.index_field(self.pattern.tri_block)
        self.hinge_block = sparse.index_field(self.pattern.hinge_block)
        self.diag_block = sparse.index_field(self.pattern.diag_block)
        self.seam_block = None
        if m.has_seams:
            self.seam_block = ti.field(ti.i32, shape=(m.seam_capacity, 4))
        self._load_block_indices()

    def _load_block_indices(self) -> None:
        """Load the pattern's block indices after a change (the vertex order changes too)."""
        p = self.pattern
        for field, index in ((self.tri_block, p.tri_block), (self.hinge_block, p.hinge_block),
                             (self.diag_block, p.diag_block)):  # fmt: skip
            if len(index):
                field.from_numpy(np.ascontiguousarray(index, dtype=np.int32))
        if self.seam_block is None:
            return
        pad = np.zeros((self.model.seam_capacity, 4), np.int32)
        pad[: len(p.seam_block)] = p.seam_block
        self.seam_block.from_numpy(pad)

    def _assemble_into_numpy(self) -> None:
        """blocks := A's 3x3 blocks and grad_np := ∇E at the current iterate (numpy)."""
        self.blocks.fill(0.0)
        self._assemble(self.blocks, self.grad_np)

    def _dx_source(self):
        return self.dx_np if self.dx_np is not None else self._no_dx

    def _solve_direct(self) -> int:
        """Assemble A = M c + H, solve A Δx = −∇E with the (re)used factors."""
        n = self.model.particle_count
        if self.pattern.update():  # seams sewn or cut since the last solve
            self._load_block_indices()
            self.factor.invalidate()
        self._assemble_into_numpy()
        b = self.pattern.permute(-self.grad_np[:n])
        dx, iterations = self.factor.solve(self.pattern, self.blocks, b)
        self.dx_np[:n] = self.pattern.unpermute(dx)  # _post_solve loads it into self.dx
        return iterations

    def _line_search(self, e0: float) -> int:
        """Backtracking on E along Δx from E = ``e0`` (Armijo, on the slope of the step
        actually taken: a vertex stopped at a contact plane moves less); returns the number
        of halvings."""
        alpha, cuts = 1.0, 0
        eps = 1e-12 * abs(e0)  # round-off allowance (E, x and the gradient are float64)
        while True:
            e, moved_slope = self._trial(alpha)
            if e <= e0 + ARMIJO * moved_slope + eps or cuts >= 30:
                break
            alpha *= 0.5
            cuts += 1
        self._accept()
        return cuts

    def _initial_guess(self) -> None:
        """Start from x̂ = x_n + h v_n + h² g or from x_n + h v_n, whichever has the lower E.

        x̂ is exact in free flight; x_n + h v_n does not pull a hanging stiff sheet by h² g
        against its pins (a residual 100x smaller in the first Newton iteration).
        """
        e_hat = self._trial_gravity(1.0)
        if self._trial_gravity(0.0) > e_hat:
            self._trial_gravity(1.0)
        self._accept()

    def _warm_up(self, state: State, control: Control) -> None:
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

    @ti.func
    def _corner(self, t, c):
        """(c_u, c_v) of corner c of triangle t: F_u = Σ_c c_u x_c, F_v = Σ_c c_v x_c."""
        r = self.model.tri_rest_inv[t]
        cu = -(r[0, 0] + r[1, 0])
        cv = -(r[0, 1] + r[1, 1])
        if c == 1:
            cu, cv = r[0, 0], r[0, 1]
        elif c == 2:
            cu, cv = r[1, 0], r[1, 1]
        return cu, cv

    @ti.func
    def _inertia(self, i, xi):
        """m/(2h²)|x − x̂|² + γm/(2h)|x − x_n|² of vertex i [J] (0 when pinned)."""
        e = ti.cast(0.0, REAL)
        if self.model.particle_inv_mass[i] > 0.0:
            h = self.h[None]
            m = self.model.particle_mass[i]
            e = 0.5 * m * ((xi - self.xh[i]).norm_sqr() / (h * h)
                           + self.gamma[None] * (xi - self.x0[i]).norm_sqr() / h)  # fmt: skip
        return e

    @ti.func
    def _vertex_energy(self, i, xi):
        """Inertia (:meth:`_inertia`) plus body contact (:meth:`_contact_terms`) [J]."""
        e = self._inertia(i, xi)
        if ti.static(self.has_contact):
            ec, _gc, _hc = self._contact_terms(i, xi)
            e += ec
        return e

    @ti.func
    def _contact_terms(self, i, xi):
        """Body contact of free vertex i at xi: (energy [J], gradient [N], PSD Hessian [N/m]).

        With the step's plane (n, offset) and φ = n·x − offset (< 0: inside the thickness),
        the penalty ½ k φ² (k = CONTACT_STIFFNESS m/h²), and friction μ λ f(|u|) on the
        tangential motion u = (I − n nᵀ)(x − x_n), with λ [N] the penalty's force at the
        end of the step before, held for the whole step (so that Newton minimises one
        energy), or, for a contact that had none then (``c_new``), at each Newton iterate
        (:meth:`_update_contact_force`, held during a line search); and
        f(s) = s²/(2ε) below ε = FRICTION_SLIP_M_S·h, s − ε/2 above: a force μ λ u/ε while
        sticking, μ λ û (Coulomb) while sliding. Both terms are convex in x.
        """
        e = ti.cast(0.0, REAL)
        g = ti.Vector.zero(REAL, 3)
        hess = ti.Matrix.zero(REAL, 3, 3)
        k = self.c_k[i]
        if k > 0.0:
            k2 = self.c_k2[i]  # the second plane of a crease (0: none)
            n2 = self.c_n2[i]
            phi2 = n2.dot(xi) - self.c_o2[i]
            if phi2 < 0.0:
                e += 0.5 * k2 * phi2 * phi2
                g += k2 * phi2 * n2
            if phi2 < PLANE_BAND_M:  # on the plane too (a vertex stopped there)
                hess += k2 * n2.outer_product(n2)
            n = self.c_n[i]
            nn = n.outer_product(n)
            phi = n.dot(xi) - self.c_o[i]
            if phi < 0.0:
                e += 0.5 * k * phi * phi
                g += k * phi * n
            if phi < PLANE_BAND_M:
                hess += k * nn
            f = self.c_mu[i] * self.c_lam[i]
            if f > 0.0:
                u = xi - self.x0[i]
                u -= n.dot(u) * n
                eps = FRICTION_SLIP_M_S * self.h[None]
                s = u.norm()
                tangent = ti.Matrix.identity(REAL, 3) - nn
                if s < eps:
                    e += f * s * s / (2.0 * eps)
                    g += f / eps * u
                    hess += f / eps * tangent
                else:
                    e += f * (s - 0.5 * eps)
                    g += f / s * u
                    hess += f / s * (tangent - (u / s).outer_product(u / s))
        return e, g, hess

    @ti.func
    def _update_contact_force(self, i, xi):
        """λ_i := the penalty's normal force at xi [N] (both planes), for the friction."""
        phi = self.c_n[i].dot(xi) - self.c_o[i]
        phi2 = self.c_n2[i].dot(xi) - self.c_o2[i]
        self.c_lam[i] = self.c_k[i] * ti.max(-phi, 0.0) + self.c_k2[i] * ti.max(-phi2, 0.0)

    @ti.kernel
    def _contact_planes(self):
        """Each free vertex's contact planes for the step (``BodyCollider.contact_planes``:
        the nearest body face's and, in a crease, a second) within CONTACT_REACH_M +
        2|x̂ − x_n| of x_n, from the collider whose nearest face is closest; or none."""
        m = self.model
        h = self.h[None]
        for i in range(m.particle_count):
            self.c_k[i] = 0.0
            self.c_k2[i] = 0.0
            if m.particle_inv_mass[i] > 0.0:
                xs = ti.cast(self.x0[i], float)
                reach = ti.cast(CONTACT_REACH_M + 2.0 * (self.xh[i] - self.x0[i]).norm(), float)
                best = ti.cast(1e30, float)
                for c in ti.static(m.colliders):
                    count, n, o, n2, o2 = c.contact_planes(xs, reach)
                    if count > 0 and n.dot(xs) - o < best:
                        best = n.dot(xs) - o
                        k = CONTACT_STIFFNESS * m.particle_mass[i] / (h * h)
                        # a vertex that starts inside the thickness may not go deeper this
                        # step, but is not pushed out by the penalty either (no shock from
                        # a stiff penalty): the contact response after the solve does that,
                        # and _lift_out for a vertex that starts inside the body
                        self.c_n[i] = ti.cast(n, REAL)
                        self.c_o[i] = ti.min(ti.cast(o, REAL), self.c_n[i].dot(self.x0[i]))
                        self.c_n2[i] = ti.cast(n2, REAL)
                        self.c_o2[i] = ti.min(ti.cast(o2, REAL), self.c_n2[i].dot(self.x0[i]))
                        self.c_t[i] = ti.cast(o, REAL)
                        self.c_t2[i] = ti.cast(o2, REAL)
                        # behind the face itself (o includes the thickness)
                        self.c_in[i] = 1 if best < -c.thickness[None] else 0
                        self.c_mu[i] = ti.cast(c.mu_s[None], REAL)
                        self.c_k[i] = k
                        self.c_k2[i] = k if count == 2 else 0.0
            if self.c_k[i] == 0.0:
                self.c_lam[i] = 0.0
                self.c_in[i] = 0
            if (self.x0[i] - self.x_end[i]).norm() > 0.0:  # not where the last step left it
                self.c_lam[i] = 0.0
            self.c_new[i] = 1 if self.c_lam[i] == 0.0 else 0

    @ti.func
    def _elastic_energy(self, x, acc):
        """acc[None] += U(x) [J] (float64 sum)."""
        m = self.model
        ti.loop_config(serialize=self.serial)
        for t in range(m.tri_count):
            i = m.tri_indices[t]
            f_u, f_v = forces.deformation_columns(x[i[0]], x[i[1]], x[i[2]], m.tri_rest_inv[t])
            k = m.tri_stiffness[t]
            u = forces.eq7_membrane_energy(f_u, f_v, m.tri_rest_area[t], k[0], k[1], k[2])
            acc[None] += ti.cast(u, ti.f64)
        if ti.static(m.hinge_count > 0):
            ti.loop_config(serialize=self.serial)
            for h in range(m.hinge_count):
                j = m.hinge_indices[h]
                th = forces.dihedral_angle(x[j[0]], x[j[1]], x[j[2]], x[j[3]])
                d = th - m.hinge_rest_angle[h]
                acc[None] += ti.cast(0.5 * m.hinge_stiffness[h] * d * d, ti.f64)
        if ti.static(m.has_seams):
            ti.loop_config(serialize=self.serial)
            for q in range(m.seam_active[None]):
                s = (x[m.seam_pairs[q][0]] - x[m.seam_pairs[q][1]]).norm() - m.seam_rest[q]
                acc[None] += ti.cast(0.5 * m.seam_stiffness[q] * s * s, ti.f64)

    @ti.kernel
    def _internal_energy_kernel(self, x: ti.template()):
        self.energy_t[None] = 0.0
        self._elastic_energy(x, self.energy_t)

    @ti.kernel
    def _grad_hess(self) -> ti.types.vector(2, ti.f64):
        """∇E, per-element Hessians, block-Jacobi preconditioner and E at self.x; the
        normal force λ of a contact that had none at the start of the step (``c_new``) is
        first taken at self.x (:meth:`_update_contact_force`).

        Returns (E [J], the largest force residual over the vertex weight)."""
        m = self.model
        x = ti.static(self.x)
        self.energy[None] = 0.0
        self.max_res[None] = 0.0
        ti.loop_config(serialize=self.serial)
        for t in range(m.tri_count):
            i = m.tri_indices[t]
            f_u, f_v = forces.deformation_columns(x[i[0]], x[i[1]], x[i[2]], m.tri_rest_inv[t])
            k = m.tri_stiffness[t]
            a = m.tri_rest_area[t]
            self.t_gu[t], self.t_gv[t] = hessians.membrane_gradient_f(f_u, f_v, a, k[0], k[1], k[2])
            h_uu, h_uv, h_vv = hessians.membrane_hessian_f(f_u, f_v, a, k[0], k[1], k[2])
            self.t_puu[t] = h_uu
            self.t_pvv[t] = h_vv
            if ti.static(self.compression_stiffness):
                h_uu += hessians.stretch_compression_term(f_u, a, k[0])
                h_vv += hessians.stretch_compression_term(f_v, a, k[1])
            self.t_huu[t] = h_uu
            self.t_huv[t] = h_uv
            self.t_hvv[t] = h_vv
        if ti.static(m.hinge_count > 0):
            ti.loop_config(serialize=self.serial)
            for h in range(m.hinge_count):
                j = m.hinge_indices[h]
                th, g0, g1, g2, g3 = forces.dihedral_angle_gradient(
                    x[j[0]], x[j[1]], x[j[2]], x[j[3]]
                )
                self.h_k[h] = m.hinge_stiffness[h]
                self.h_s[h] = m.hinge_stiffness[h] * (th - m.hinge_rest_angle[h])
                self.h_grad[4 * h] = g0
                self.h_grad[4 * h + 1] = g1
                self.h_grad[4 * h + 2] = g2
                self.h_grad[4 * h + 3] = g3
        if ti.static(m.has_seams):
            ti.loop_config(serialize=self.serial)
            for q in range(m.seam_active[None]):
                d = x[m.seam_pairs[q][0]] - x[m.seam_pairs[q][1]]
                r = m.seam_rest[q]
                k = m.seam_stiffness[q]
                g = k * d
                if r > 0.0:
                    length = d.norm()
                    g = ti.Vector.zero(REAL, 3)
                    if length > 1e-12:
                        g = k * (length - r) / length * d
                self.s_grad[q] = g
                self.s_hess[q] = hessians.seam_spring_hessian(d, r, k)
        self._elastic_energy(x, self.energy)
        h = self.h[None]
        c_mass = 1.0 / (h * h) + self.gamma[None] / h
        ti.loop_config(serialize=self.serial)
        for i in range(m.particle_count):
            g = ti.Vector.zero(REAL, 3)
            d = ti.Matrix.zero(REAL, 3, 3)
            for s in range(m.vert_tri_start[i], m.vert_tri_start[i + 1]):
                slot = m.vert_tri_slot[s]
                t = slot // 3
                cu, cv = self._corner(t, slot % 3)
                g += cu * self.t_gu[t] + cv * self.t_gv[t]
                huv = self.t_huv[t]
                d += cu * cu * self.t_puu[t] + cu * cv * (huv + huv.transpose())
                d += cv * cv * self.t_pvv[t]
            if ti.static(m.hinge_count > 0):
                for s in range(m.vert_hinge_start[i], m.vert_hinge_start[i + 1]):
                    slot = m.vert_hinge_slot[s]
                    gh = self.h_grad[slot]
                    g += self.h_s[slot // 4] * gh
                    d += hessians.hinge_hessian_block(self.h_k[slot // 4], gh, gh)
            if ti.static(m.has_seams):
                for s in range(m.vert_seam_start[i], m.vert_seam_start[i + 1]):
                    slot = m.vert_seam_slot[s]
                    sign = 1.0 - 2.0 * (slot % 2)
                    g += sign * self.s_grad[slot // 2]
                    d += self.s_hess[slot // 2]
            mi = m.particle_mass[i]
            if m.particle_inv_mass[i] > 0.0:
                xi = x[i]
                g += mi * ((xi - self.xh[i]) / (h * h) + self.gamma[None] * (xi - self.x0[i]) / h)
                d += mi * c_mass * ti.Matrix.identity(REAL, 3)
                if ti.static(self.has_contact):
                    if self.c_new[i]:
                        self._update_contact_force(i, xi)
                    _, gc, hc = self._contact_terms(i, xi)
                    g += gc
                    d += hc
                    self.c_hess[i] = hc
                self.grad[i] = g
                self.pinv[i] = d.inverse()
                self.energy[None] += ti.cast(self._vertex_energy(i, xi), ti.f64)
                ti.atomic_max(self.max_res[None], g.norm() / (mi * 9.80665))
            else:
                self.grad[i] = ti.Vector.zero(REAL, 3)
                self.pinv[i] = ti.Matrix.zero(REAL, 3, 3)
        return ti.Vector([self.energy[None], ti.cast(self.max_res[None], ti.f64)], ti.f64)

    @ti.kernel
    def _cg_init(self):
        self.rz[None] = 0.0
        self.rr[None] = 0.0
        self.negative[None] = 0
        self.cg_k[None] = 0
        for i in range(self.model.particle_count):
            self.dx[i] = ti.Vector.zero(REAL, 3)
            r = -self.grad[i]
            z = self.pinv[i] @ r
            self.r[i] = r
            self.z[i] = z
            self.p[i] = z
            self.rz[None] += ti.cast(r.dot(z), ti.f64)
            self.rr[None] += ti.cast(r.dot(r), ti.f64)

    @ti.func
    def _apply(self, p, out, pap):
        """out = (M (1/h² + γ/h) + H) p, zero on pinned vertices; pap[None] = p·out."""
        m = self.model
        for t in range(m.tri_count):
            i = m.tri_indices[t]
            yu = ti.Vector.zero(REAL, 3)
            yv = ti.Vector.zero(REAL, 3)
            for c in ti.static(range(3)):
                cu, cv = self._corner(t, c)
                yu += cu * p[i[c]]
                yv += cv * p[i[c]]
            huv = self.t_huv[t]
            self.t_zu[t] = self.t_huu[t] @ yu + huv @ yv
            self.t_zv[t] = huv.transpose() @ yu + self.t_hvv[t] @ yv
        if ti.static(m.hinge_count > 0):
            for h in range(m.hinge_count):
                j = m.hinge_indices[h]
                s = ti.cast(0.0, REAL)
                for k in ti.static(range(4)):
                    s += self.h_grad[4 * h + k].dot(p[j[k]])
                self.h_z[h] = self.h_k[h] * s
        if ti.static(m.has_seams):
            for q in range(m.seam_active[None]):
                self.s_z[q] = self.s_hess[q] @ (p[m.seam_pairs[q][0]] - p[m.seam_pairs[q][1]])
        hh = self.h[None]
        c_mass = 1.0 / (hh * hh) + self.gamma[None] / hh
        pap[None] = 0.0
        for i in range(m.particle_count):
            y = ti.Vector.zero(REAL, 3)
            if m.particle_inv_mass[i] > 0.0:
                y = m.particle_mass[i] * c_mass * p[i]
                if ti.static(self.has_contact):
                    y += self.c_hess[i] @ p[i]
                for s in range(m.vert_tri_start[i], m.vert_tri_start[i + 1]):
                    slot = m.vert_tri_slot[s]
                    t = slot // 3
                    cu, cv = self._corner(t, slot % 3)
                    y += cu * self.t_zu[t] + cv * self.t_zv[t]
                if ti.static(m.hinge_count > 0):
                    for s in range(m.vert_hinge_start[i], m.vert_hinge_start[i + 1]):
                        slot = m.vert_hinge_slot[s]
                        y += self.h_z[slot // 4] * self.h_grad[slot]
                if ti.static(m.has_seams):
                    for s in range(m.vert_seam_start[i], m.vert_seam_start[i + 1]):
                        slot = m.vert_seam_slot[s]
                        y += (1.0 - 2.0 * (slot % 2)) * self.s_z[slot // 2]
            out[i] = y
            pap[None] += ti.cast(p[i].dot(y), ti.f64)

    @ti.kernel
    def _assemble(self, blocks: ti.types.ndarray(), grad: ti.types.ndarray()):
        """blocks (nb, 3, 3) += the 3x3 blocks of M (1/h² + γ/h) + H (pattern of
        ``self.pattern``; pass zeros) and grad (n, 3) := ∇E.

        The same element Hessians as :meth:`_apply`: triangle corners (a, b) couple through
        c_u,a c_u,b H_uu + c_u,a c_v,b H_uv + c_v,a c_u,b H_uvᵀ + c_v,a c_v,b H_vv, hinge
        vertices through E_b g_a g_bᵀ, seam ends through ±S. Pinned vertices get identity.
        """
        m = self.model
        ti.loop_config(serialize=self.serial)
        for t in range(m.tri_count):
            i = m.tri_indices[t]
            huu, huv, hvv = self.t_huu[t], self.t_huv[t], self.t_hvv[t]
            for a in ti.static(range(3)):
                cua, cva = self._corner(t, a)
                for b in ti.static(range(3)):
                    cub, cvb = self._corner(t, b)
                    if m.particle_inv_mass[i[a]] > 0.0 and m.particle_inv_mass[i[b]] > 0.0:
                        blk = cua * (cub * huu + cvb * huv) + cva * (cub * huv.transpose()
                                                                     + cvb * hvv)  # fmt: skip
                        self._add_block(blocks, self.tri_block[t, 3 * a + b], blk)
        if ti.static(m.hinge_count > 0):
            ti.loop_config(serialize=self.serial)
            for h in range(m.hinge_count):
                j = m.hinge_indices[h]
                for a in ti.static(range(4)):
                    for b in ti.static(range(4)):
                        if m.particle_inv_mass[j[a]] > 0.0 and m.particle_inv_mass[j[b]] > 0.0:
                            ga = self.h_grad[4 * h + a]
                            gb = self.h_grad[4 * h + b]
                            blk = self.h_k[h] * ga.outer_product(gb)
                            self._add_block(blocks, self.hinge_block[h, 4 * a + b], blk)
        if ti.static(m.has_seams):
            ti.loop_config(serialize=self.serial)
            for q in range(m.seam_active[None]):
                p = m.seam_pairs[q]
                s_h = self.s_hess[q]
                for a in ti.static(range(2)):
                    for b in ti.static(range(2)):
                        if m.particle_inv_mass[p[a]] > 0.0 and m.particle_inv_mass[p[b]] > 0.0:
                            sign = 1.0 if a == b else -1.0
                            self._add_block(blocks, self.seam_block[q, 2 * a + b], sign * s_h)
        hh = self.h[None]
        c_mass = 1.0 / (hh * hh) + self.gamma[None] / hh
        ti.loop_config(serialize=self.serial)
        for i in range(m.particle_count):
            d = ti.Matrix.identity(REAL, 3)
            if m.particle_inv_mass[i] > 0.0:
                d = m.particle_mass[i] * c_mass * ti.Matrix.identity(REAL, 3)
                if ti.static(self.has_contact):
                    d += self.c_hess[i]
            self._add_block(blocks, self.diag_block[i], d)
            for c in ti.static(range(3)):
                grad[i, c] = self.grad[i][c]

    @ti.func
    def _add_block(self, blocks: ti.template(), k, blk):
        for r, c in ti.static(ti.ndrange(3, 3)):
            blocks[k, r, c] += blk[r, c]

    def assembled_matrix(self):
        """The Newton matrix of the last evaluation as scipy CSC (3n x 3n); for tests.

        Only with ``linear_solver="direct"``."""
        if self.pattern.update():
            self._load_block_indices()
        self._assemble_into_numpy()
        p = self.pattern  # back from the band order to vertex order
        scalar = (3 * p.position[:, None] + np.arange(3)).ravel()
        return p.matrix(self.blocks)[scalar][:, scalar].tocsc()

    @ti.kernel
    def _apply_kernel(self):
        self._apply(self.p, self.ap, self.pap)

    @ti.kernel
    def _cg_iter(self):
        """One preconditioned CG iteration; its loops run in parallel."""
        self._cg_body()

    @ti.kernel
    def _cg_loop(self, max_cg: ti.i32, target: ti.f64) -> ti.i32:
        """CG iterations until |r|² <= target, all in one launch (serial loops)."""
        k = 0
        while k < max_cg and self.rr[None] > target and self.negative[None] == 0:
            self._cg_body()
            k += 1
        return k

    @ti.func
    def _cg_body(self):
        """One preconditioned CG iteration (Hestenes-Stiefel form), truncated at negative
        curvature (p·Ap <= 0, possible with the compression term): then it stops and keeps
        Δx, or takes the preconditioned steepest descent direction if that was the first
        iteration (Nocedal and Wright, Newton-CG). Either is a descent direction."""
        self._apply(self.p, self.ap, self.pap)
        if self.pap[None] <= 0.0:
            self.negative[None] = 1
        self.alpha[None] = ti.cast(self.rz[None] / ti.max(self.pap[None], 1e-300), REAL)
        self.rz_new[None] = 0.0
        if self.negative[None] == 0:
            self.rr[None] = 0.0
        for i in range(self.model.particle_count):
            if self.negative[None] == 0:
                a = self.alpha[None]
                self.dx[i] += a * self.p[i]
                r = self.r[i] - a * self.ap[i]
                z = self.pinv[i] @ r
                self.r[i] = r
                self.z[i] = z
                self.rz_new[None] += ti.cast(r.dot(z), ti.f64)
                self.rr[None] += ti.cast(r.dot(r), ti.f64)
            elif self.cg_k[None] == 0:
                self.dx[i] = self.p[i]
        if self.negative[None] == 0:
            self.beta[None] = ti.cast(self.rz_new[None] / ti.max(self.rz[None], 1e-300), REAL)
            self.rz[None] = self.rz_new[None]
            self.cg_k[None] += 1
        for i in range(self.model.particle_count):
            if self.negative[None] == 0:
                self.p[i] = self.z[i] + self.beta[None] * self.p[i]

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

    @ti.func
    def _stop_at_planes(self, i, d):
        """Vertex i's step d [m], changed so that it ends on a contact plane that it would
        otherwise pass through from in front (farther than PLANE_BAND_M): the part of the
        step beyond the plane is taken off along the plane's normal, so the vertex keeps
        its motion along the plane. Where that would put it behind a crease's other plane,
        the step is shortened instead, to end on the first plane it meets.

        The penalty has no stiffness in front of its plane, so Newton's step does not see
        it coming: without this, one vertex carried deep into the penalty made the line
        search halve the step of the whole garment, 2-3 times per iteration while a garment
        settles on the body. On the plane, the vertex has the penalty's stiffness in the
        next iteration (PLANE_BAND_M) and finds its depth by Newton's method.
        """
        out = d
        if self.c_k[i] > 0.0:
            xi = self.x[i]
            n = self.c_n[i]
            phi = n.dot(xi) - self.c_o[i]
            t = ti.cast(1.0, REAL)  # the shortened step, for a crease
            if phi > PLANE_BAND_M and phi + n.dot(d) < 0.0:
                out -= (phi + n.dot(d)) * n
                t = phi / (-n.dot(d))
            if self.c_k2[i] > 0.0:
                n2 = self.c_n2[i]
                phi2 = n2.dot(xi) - self.c_o2[i]
                if phi2 > PLANE_BAND_M and phi2 + n2.dot(out) < 0.0:
                    if phi2 + n2.dot(d) < 0.0:
                        t = ti.min(t, phi2 / (-n2.dot(d)))
                    out -= (phi2 + n2.dot(out)) * n2
                    if phi > PLANE_BAND_M and phi + n.dot(out) < -PLANE_BAND_M:
                        out = t * d  # back behind the first plane: stop at the first
        return out

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
            self.vel[i] = v

    @ti.func
    def _lift_out(self, i, xi):
        """xi moved in front of its contact planes if vertex i started the step inside the
        body; ``c_push[i]`` := the outward velocity [m/s] that the way out added beyond the
        vertex's own (its start velocity's).

        The penalty's plane holds such a vertex where it starts, and the response after the
        solve only acts within the thickness: a vertex that the self-collision pass pushed
        2.9 mm into the sleeveless blouse's armpit sank to 13.6 mm (each step's plane began
        where the membrane's pull had left it). Nor can the penalty pull it out: at 3 cm the
        membrane pulling a vertex across the armpit is stiffer than m/h² x
        CONTACT_STIFFNESS (planes that ask such vertices out at 0.1 m/s leave two of them
        12.7 mm inside). Only vertices that start inside the body are lifted,
        so a vertex sliding off the edge of its face's plane is not. The way out moves the
        vertex but is not kept as velocity (``_drift``): no launch, as in the explicit
        solver's ``respond_split``.
        """
        push = ti.Vector.zero(REAL, 3)
        if self.c_in[i]:
            xi = self._front_of_planes(i, xi)
            h = self.h[None]
            n = self.c_n[i]
            own = ti.max((self.xh[i] - self.x0[i]).dot(n) / h, 0.0)
            out = (xi - self.x0[i]).dot(n) / h - own
            if out > 0.0:
                push = out * n
        self.c_push[i] = push
        return xi

    @ti.func
    def _front_of_planes(self, i, x):
        """A point in front of vertex i's contact planes (n·y >= offset for both), near x:
        x itself, else its projection on plane 1, else on plane 2, else the point of the
        line where both meet that is nearest to x (both only at LIFT_MIN_SIN2, and no
        move longer than LIFT_MAX_M)."""
        n1, t1 = self.c_n[i], self.c_t[i]
        n2, t2 = self.c_n2[i], self.c_t2[i]
        two = self.c_k2[i] > 0.0
        p1 = n1.dot(x) - t1
        p2 = n2.dot(x) - t2 if two else ti.cast(0.0, REAL)
        y = x
        if p1 < 0.0 or p2 < 0.0:
            y1 = x - ti.min(p1, 0.0) * n1  # plane 1 only
            y2 = x - ti.min(p2, 0.0) * n2  # plane 2 only
            ok1 = (not two) or n2.dot(y1) - t2 >= -1e-12
            ok2 = n1.dot(y2) - t1 >= -1e-12
            if p1 < 0.0 and ok1:
                y = y1
            elif p2 < 0.0 and ok2:
                y = y2
            else:  # both active: y = x + a n1 + b n2 on both planes
                c = n1.dot(n2)
                det = 1.0 - c * c
                y = y1
                if det > LIFT_MIN_SIN2:
                    a = (-p1 + c * p2) / det
                    b = (-p2 + c * p1) / det
                    y = x + a * n1 + b * n2
            if (y - x).norm() > LIFT_MAX_M:  # a plane far off (a thin part's other side)
                y = x
        return y

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


LINEAR_SOLVERS = ("auto", "direct", "cg")


def resolve_linear_solver(name: str, compression_stiffness: bool = False) -> str:
    """``"direct"`` or ``"cg"`` for the ``linear_solver`` argument (see the class)."""
    from sandbox.errors import SandboxError

    if name not in LINEAR_SOLVERS:
        raise SandboxError(f"linear_solver must be one of {', '.join(LINEAR_SOLVERS)}, "
                           f"got {name!r}")  # fmt: skip
    if name == "auto":
        return "direct" if runtime.arch() == "cpu" and not compression_stiffness else "cg"
    if name == "direct" and compression_stiffness:
        raise SandboxError("linear_solver 'direct' needs a positive definite matrix: "
                           "turn compression_stiffness off or use 'cg'")  # fmt: skip
    return name


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
