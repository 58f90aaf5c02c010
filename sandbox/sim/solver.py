"""Symplectic Euler solver (paper Eq. 2): the launch order of one time step.

One step, as the paper's Fig. 4(a):
  1. forces F(t_n): membrane (Eq. 6-8), bending (Eq. 7-8), gravity, damping;
  2. v(t_n+1) = v(t_n) + dt F(t_n)/m                      (explicit, Eq. 2 first line)
  3. contact handlers revise v(t_n+1): each body collider per vertex, then the cloth's
     self-collision passes over vertex pairs (only in scenes that have them)
  4. x(t_n+1) = x(t_n) + dt v(t_n+1)                       (implicit in v, Eq. 2 second line)

Damping is mass-proportional viscous damping F_damp = −γ m v(t_n), with γ [1/s] in
``control.damping_per_s``; γ = 0 switches it off and leaves the plain symplectic scheme.

Forces are computed per element into per-corner slots, then gathered per particle through
the model's incidence lists: no atomic adds, so the parallel loops scale across cores.
``step`` runs one step per kernel launch, in parallel. ``advance`` runs many steps in one
launch, serially, which is faster for small meshes where launch overhead dominates; both
use the same per-element functions.
"""

import numpy as np
import taichi as ti

from sandbox import runtime
from sandbox.collision.self_contact_config import RESOLVED
from sandbox.sim import forces
from sandbox.sim.integrator import ContactFriction, read_friction, write_friction
from sandbox.sim.model import Control, Model, State  # noqa: F401 (used in annotations)

# On the CPU, up to this many particles ``advance`` fuses steps into one serial kernel
# launch, which saves the parallel path's launch and thread start-up per step. Measured on
# 2 cores (2026-12-01, benchmarks/bench_step.py, M vertex-steps/s serial fused vs
# parallel): 2.3k vertices 7.5 vs 5.6, 4.5k 7.4 vs 8.2, 9k 7.3 vs 8.2, 18k 7.2 vs 11.8.
# The crossover moves with the machine's load; on a
# GPU every step is a parallel launch.
FUSED_PARTICLE_LIMIT = 4000
# The seam hold (SymplecticEulerSolver._seam_hold): a stitch is caught once its gap is
# within this many hold distances, then drawn in at this speed [m/s] to the hold distance:
# 1 cm/s closes a 3 mm gap in 0.2 s, with impulses far below the cloth's own speeds.
HOLD_CATCH = 3.0
HOLD_DRAW_M_S = 0.01
NO_STEP = 2**31 - 1


@ti.data_oriented
class SymplecticEulerSolver:
    """Explicit cloth solver; owns its per-element force slots and the NaN watch.

    Implements :class:`~sandbox.sim.integrator.Integrator`."""

    def __init__(self, model: Model, *, fused_particle_limit: int = FUSED_PARTICLE_LIMIT):
        self.model = model
        self.fused_particle_limit = int(fused_particle_limit)
        """On the CPU, models of up to this many particles without self-collision advance in
        one serial kernel launch (:data:`FUSED_PARTICLE_LIMIT`; -1: never)."""
        self.force = ti.Vector.field(3, float, shape=max(1, model.particle_count))
        self.tri_force = ti.Vector.field(3, float, shape=max(1, 3 * model.tri_count))
        self.hinge_force = None
        if model.hinge_count:
            self.hinge_force = ti.Vector.field(3, float, shape=4 * model.hinge_count)
        self.seam_force = self.seam_dv = None
        if model.has_seams:
            self.seam_force = ti.Vector.field(3, float, shape=2 * model.seam_capacity)
            self.seam_dv = ti.Vector.field(3, float, shape=2 * model.seam_capacity)
        self.self_collider = model.self_collider
        # the face pass: closed bodies' vertices against cloth triangles (only with bodies)
        self.face_bodies = [c for c in model.colliders if getattr(c, "face_pass", False)]
        self.has_faces = bool(self.face_bodies) and model.tri_count > 0
        self.face_dv = self.face_lift = self.face_count = None
        # the bodies' outward push of this step [m/s]: it moves a vertex, it is not kept
        self.has_bodies = len(model.colliders) > 0
        self.push = None
        if self.has_bodies:
            self.push = ti.Vector.field(3, float, shape=max(1, model.particle_count))
        if self.has_faces:
            self.face_dv = ti.Vector.field(3, float, shape=max(1, model.particle_count))
            self.face_lift = ti.Vector.field(3, float, shape=max(1, model.particle_count))
            self.face_count = ti.field(ti.i32, shape=max(1, model.particle_count))
        self.speed_limit = ti.field(float, shape=())
        """Largest speed [m/s] a particle keeps after its velocity update (0: no limit, the
        default, the paper's scheme); set by :meth:`set_speed_limit`."""
        self.bad_step = ti.field(ti.i32, shape=())
        self.bad_vertex = ti.field(ti.i32, shape=())
        self.energy = ti.field(ti.f64, shape=())
        self.reset_watch()

    # ------------------------------------------------------------------ public API
    def step(self, state_in: State, state_out: State, control: Control, dt: float, index=0):
        """Advance one step of ``dt`` [s] from ``state_in`` into ``state_out``.

        ``state_out`` may be ``state_in`` (in place). ``index`` is the global step number,
        recorded if this step produces a non-finite position.
        """
        sc = self.self_collider
        if sc is not None:
            # kick and the contact passes' preparation; the list rebuilt if needed; the
            # passes, and the drift in the same launch when they resolved the step (the
            # usual case). Otherwise the collider's fallbacks run, then the drift.
            build = self._kick_kernel(state_in.x, state_in.v, state_out.v, control.gravity,
                                      control.damping_per_s, dt)  # fmt: skip
            sc.build_list(state_in.x, state_out.v, dt, build)
            status = self._passes_drift_kernel(state_in.x, state_out.v, state_out.x, dt, index)
            if status != RESOLVED:
                sc.resolve(state_in.x, state_out.v, dt, status)
                self._drift_kernel(state_in.x, state_out.v, state_out.x, dt, index)
            return
        self._step_kernel(
            state_in.x, state_in.v, state_out.x, state_out.v, control.gravity,
            control.damping_per_s, dt, index,
        )  # fmt: skip

    def advance(self, state: State, control: Control, dt: float, steps: int, first_index=0):
        """Advance ``state`` in place by ``steps`` steps of ``dt`` [s]."""
        fused = runtime.arch() == "cpu" and self.model.particle_count <= self.fused_particle_limit
        if fused and self.self_collider is None:
            self._fused_kernel(
                state.x, state.v, control.gravity, control.damping_per_s, dt, steps, first_index
            )
        else:  # self-collision needs its passes between the two halves of each step
            for k in range(steps):
                self.step(state, state, control, dt, first_index + k)

    def warm_up(self, state: State, control: Control) -> None:
        """Compile every kernel a run of this model can reach, at the start of a run (a
        zero step changes nothing)."""
        self.advance(state, control, 0.0, 1)
        if self.self_collider is not None:
            self.self_collider.warm_up(state.x, state.v)
            self._drift_kernel(state.x, state.v, state.x, 0.0, 0)

    def reset_watch(self) -> None:
        self.bad_step[None] = NO_STEP
        self.bad_vertex[None] = NO_STEP

    def first_bad(self) -> tuple[int, int] | None:
        """(step, vertex) of the first non-finite position since the last reset, or None."""
        s = int(self.bad_step[None])
        return None if s == NO_STEP else (s, int(self.bad_vertex[None]))

    def stats(self) -> dict:
        """No counters: an explicit step has no iterations to count."""
        return {}

    def reset_stats(self) -> None:
        """Nothing to reset (see :meth:`stats`)."""

    def set_speed_limit(self, limit_m_s: float) -> None:
        """Cap each particle's speed after its velocity update at ``limit_m_s`` [m/s] (0: no
        cap). Not physics: the sewing phase sets it so that a seam closing across
        centimetres cannot fling a stiff panel in one explicit step."""
        self.speed_limit[None] = limit_m_s

    def friction(self) -> ContactFriction:
        return read_friction(self.model, self.self_collider)

    def set_friction(self, friction: ContactFriction) -> None:
        write_friction(self.model, self.self_collider, friction)

    def compute_forces(self, state: State, control: Control):
        """F(t_n) [N] per particle, numpy (n, 3): internal + gravity + damping forces."""
        self._forces_kernel(state.x, state.v, control.gravity, control.damping_per_s)
        return self.force.to_numpy()[: self.model.particle_count]

    def static_forces(self, x, gravity) -> np.ndarray:
        """The forces of the cloth at rest at positions ``x`` (a Taichi vector field, e.g.
        ``state.x``) [N], numpy (n, 3): membrane (Eq. 6-8), bending (Eq. 7-8), seams and
        ``gravity`` (a 0-D vector field [m/s^2]) times the mass; no damping of any kind, which
        vanishes at rest. Pinned particles get their forces too."""
        self._static_forces_kernel(x, gravity)
        return self.force.to_numpy()[: self.model.particle_count].astype("float64")

    def internal_energy(self, state: State) -> float:
        """U = Σ (U_u + U_v + U_s) + Σ U_b of Eq. 7 [J]."""
        self.energy[None] = 0.0
        self._energy_kernel(state.x)
        return float(self.energy[None])

    # ------------------------------------------------------------------ kernels
    @ti.kernel
    def _step_kernel(
        self, x_in: ti.template(), v_in: ti.template(), x_out: ti.template(),
        v_out: ti.template(), gravity: ti.template(), damping: ti.template(), dt: float,
        index: ti.i32,
    ):  # fmt: skip
        self._element_forces(x_in, v_in)
        self._kick_drift(x_in, v_in, x_out, v_out, gravity, damping, dt, index)

    @ti.kernel
    def _fused_kernel(
        self, x: ti.template(), v: ti.template(), gravity: ti.template(),
        damping: ti.template(), dt: float, steps: ti.i32, first_index: ti.i32,
    ):  # fmt: skip
        ti.loop_config(serialize=True)
        for k in range(steps):
            self._element_forces(x, v)
            self._kick_drift(x, v, x, v, gravity, damping, dt, first_index + k)

    @ti.kernel
    def _kick_kernel(
        self, x_in: ti.template(), v_in: ti.template(), v_out: ti.template(),
        gravity: ti.template(), damping: ti.template(), dt: float,
    ) -> ti.i32:  # fmt: skip
        """Forces and v(t+dt) with the bodies, then self-collision's ``prepare``: returns
        whether its list needs a rebuild (1) or a refresh (2)."""
        self._element_forces(x_in, v_in)
        self._kick(x_in, v_in, v_out, gravity, damping, dt)
        self.self_collider.prepare(x_in, v_out, dt)
        return self.self_collider.needs_build[None]

    @ti.kernel
    def _passes_drift_kernel(
        self, x_in: ti.template(), v: ti.template(), x_out: ti.template(), dt: float,
        index: ti.i32,
    ) -> ti.i32:  # fmt: skip
        """Self-collision's passes, then the drift only if they resolved the step (the
        drift loop's range is 0 otherwise: a loop under an ``if`` would run serially)."""
        status = self.self_collider.passes(x_in, v, dt)
        count = self.model.particle_count if status == RESOLVED else 0
        self._drift(x_in, v, x_out, dt, index, count)
        return status

    @ti.kernel
    def _drift_kernel(
        self, x_in: ti.template(), v: ti.template(), x_out: ti.template(), dt: float,
        index: ti.i32,
    ):  # fmt: skip
        self._drift(x_in, v, x_out, dt, index, self.model.particle_count)

    @ti.kernel
    def _forces_kernel(
        self, x: ti.template(), v: ti.template(), gravity: ti.template(), damping: ti.template()
    ):
        self._element_forces(x, v)
        for i in range(self.model.particle_count):
            m = self.model.particle_mass[i]
            f = self._gathered_force(i) + m * gravity[None] - damping[None] * m * v[i]
            self.force[i] = f

    @ti.kernel
    def _static_forces_kernel(self, x: ti.template(), gravity: ti.template()):
        self._membrane_forces(x, x, False)
        self._bending_forces(x)
        self._seam_forces(x)
        for i in range(self.model.particle_count):
            self.force[i] = self._gathered_force(i) + self.model.particle_mass[i] * gravity[None]

    @ti.kernel
    def _energy_kernel(self, x: ti.template()):
        m = self.model
        for t in range(m.tri_count):
            i = m.tri_indices[t]
            f_u, f_v = forces.deformation_columns(x[i[0]], x[i[1]], x[i[2]], m.tri_rest_inv[t])
            k = m.tri_stiffness[t]
            e = forces.eq7_membrane_energy(f_u, f_v, m.tri_rest_area[t], k[0], k[1], k[2])
            self.energy[None] += ti.cast(e, ti.f64)
        if ti.static(m.hinge_count > 0):
            for h in range(m.hinge_count):
                j = m.hinge_indices[h]
                th = forces.dihedral_angle(x[j[0]], x[j[1]], x[j[2]], x[j[3]])
                d = th - m.hinge_rest_angle[h]
                self.energy[None] += ti.cast(0.5 * m.hinge_stiffness[h] * d * d, ti.f64)
        if ti.static(m.has_seams):
            for q in range(m.seam_active[None]):
                e = (x[m.seam_pairs[q][0]] - x[m.seam_pairs[q][1]]).norm() - m.seam_rest[q]
                self.energy[None] += ti.cast(0.5 * m.seam_stiffness[q] * e * e, ti.f64)

    # ------------------------------------------------------------------ per-step pieces
    @ti.func
    def _element_forces(self, x, v):
        self._membrane_forces(x, v, True)
        self._bending_forces(x)
        self._seam_forces(x)

    @ti.func
    def _membrane_forces(self, x, v, damped: ti.template()):
        """Eq. 6-8: membrane forces of each triangle, into its three corner slots, plus its
        strain-rate damping where ``model.strain_damping_s`` > 0 and ``damped``."""
        m = self.model
        beta = m.strain_damping_s[None]
        for t in range(m.tri_count):
            i = m.tri_indices[t]
            r = m.tri_rest_inv[t]
            f_u, f_v = forces.deformation_columns(x[i[0]], x[i[1]], x[i[2]], r)
            k = m.tri_stiffness[t]
            g_u, g_v = forces.eq8_membrane_gradient(f_u, f_v, m.tri_rest_area[t], k[0], k[1], k[2])
            if ti.static(damped) and beta > 0.0:
                r_u, r_v = forces.deformation_columns(v[i[0]], v[i[1]], v[i[2]], r)
                d_u, d_v = forces.membrane_damping_gradient(
                    f_u, f_v, r_u, r_v, m.tri_rest_area[t], k[0], k[1], k[2], beta
                )
                g_u += d_u
                g_v += d_v
            # F_u = c_u0 x0 + c_u1 x1 + c_u2 x2 with c_u1 = r00, c_u2 = r10, c_u0 = -(r00 + r10)
            f1 = -(r[0, 0] * g_u + r[0, 1] * g_v)
            f2 = -(r[1, 0] * g_u + r[1, 1] * g_v)
            self.tri_force[3 * t] = -(f1 + f2)
            self.tri_force[3 * t + 1] = f1
            self.tri_force[3 * t + 2] = f2

    @ti.func
    def _bending_forces(self, x):
        """Eq. 7-8: bending U_b = E_b/2 (θ_b − θ_0)^2, F = −E_b (θ_b − θ_0) ∂θ_b/∂x, into
        each hinge's four slots."""
        m = self.model
        if ti.static(m.hinge_count > 0):
            for h in range(m.hinge_count):
                j = m.hinge_indices[h]
                th, g0, g1, g2, g3 = forces.dihedral_angle_gradient(
                    x[j[0]], x[j[1]], x[j[2]], x[j[3]]
                )
                s = -m.hinge_stiffness[h] * (th - m.hinge_rest_angle[h])
                self.hinge_force[4 * h] = s * g0
                self.hinge_force[4 * h + 1] = s * g1
                self.hinge_force[4 * h + 2] = s * g2
                self.hinge_force[4 * h + 3] = s * g3

    @ti.func
    def _seam_forces(self, x):
        """§2.4: seam springs U = k/2 (|x_a − x_b| − r)^2, F_a = −k (|d| − r) d/|d|. Their
        dashpots act in the velocity update (:meth:`_free_velocity`)."""
        m = self.model
        if ti.static(m.has_seams):
            for q in range(m.seam_active[None]):
                a, b = m.seam_pairs[q][0], m.seam_pairs[q][1]
                d = x[a] - x[b]
                r = m.seam_rest[q]
                f = -m.seam_stiffness[q] * d
                if r > 0.0:
                    length = d.norm()
                    f = ti.Vector([0.0, 0.0, 0.0])
                    if length > 1e-12:
                        f = -m.seam_stiffness[q] * (length - r) / length * d
                self.seam_force[2 * q] = f
                self.seam_force[2 * q + 1] = -f

    @ti.func
    def _gathered_force(self, i):
        m = self.model
        f = ti.Vector([0.0, 0.0, 0.0])
        for k in range(m.vert_tri_start[i], m.vert_tri_start[i + 1]):
            f += self.tri_force[m.vert_tri_slot[k]]
        if ti.static(m.hinge_count > 0):
            for k in range(m.vert_hinge_start[i], m.vert_hinge_start[i + 1]):
                f += self.hinge_force[m.vert_hinge_slot[k]]
        if ti.static(m.has_seams):
            for k in range(m.vert_seam_start[i], m.vert_seam_start[i + 1]):
                f += self.seam_force[m.vert_seam_slot[k]]
        return f

    @ti.func
    def _velocity(self, i, x_in, v_in, gravity, damping, dt):
        """v(t+dt) of particle i: Eq. 2's velocity update, then the body colliders.

        Returns ``(v_move, push)``: ``v_move`` moves the particle this step; ``push`` is
        the part of it that only restores the contact thickness, which the particle does
        not keep (:meth:`BodyCollider.respond_split`): it keeps ``v_move − push``.
        """
        return self._contact(i, x_in, self._free_velocity(i, v_in, gravity, damping, dt), dt)

    @ti.func
    def _free_velocity(self, i, v_in, gravity, damping, dt):
        """Eq. 2: v(t+dt) = v(t) + dt F(t)/m, F = F_int + m g − γ m v(t) (0 if pinned);
        then scaled down to :attr:`speed_limit` if one is set and exceeded."""
        m = self.model
        w = m.particle_inv_mass[i]
        v_new = ti.Vector([0.0, 0.0, 0.0])
        if w > 0.0:
            f = self._gathered_force(i)
            v_new = v_in[i] + dt * (f * w + gravity[None] - damping[None] * v_in[i])
            if ti.static(m.has_seams):
                v_new = self._seam_dashpots(i, v_in, v_new, dt)
            limit = self.speed_limit[None]
            if limit > 0.0:
                speed = v_new.norm()
                if speed > limit:
                    v_new *= limit / speed
        return v_new

    @ti.func
    def _seam_dashpots(self, i, v_in, v_new, dt):
        """The dashpots of particle i's seam springs, implicit in its own velocity: each
        spring q to particle j adds F = −c_q (v_i(t+dt) − v_j(t)), c_q = 2 ζ √(k_q μ) with μ
        the pair's reduced mass and ζ = ``model.seam_damping_ratio``, so
        v_i(t+dt) = (v* + Σ κ_q v_j) / (1 + Σ κ_q), κ_q = c_q dt / m_i, where v* is the
        undamped update. A weighted mean of velocities: stable at any step, however stiff
        the seam, and it conserves the pair's momentum up to the partner's lag of one step."""
        m = self.model
        zeta = m.seam_damping_ratio[None]
        out = v_new
        if zeta > 0.0:
            mi = m.particle_mass[i]
            kappa_sum = 0.0
            pull = ti.Vector([0.0, 0.0, 0.0])
            for k in range(m.vert_seam_start[i], m.vert_seam_start[i + 1]):
                slot = m.vert_seam_slot[k]
                q = slot // 2
                if q < m.seam_active[None]:
                    j = m.seam_pairs[q][1 - slot % 2]
                    mj = m.particle_mass[j]
                    mu = mi * mj / ti.max(mi + mj, 1e-30)
                    kappa = 2.0 * zeta * ti.sqrt(ti.max(m.seam_stiffness[q], 0.0) * mu) * dt / mi
                    kappa_sum += kappa
                    pull += kappa * v_in[j]
            out = (v_new + pull) / (1.0 + kappa_sum)
        return out

    @ti.func
    def _seam_hold(self, x, v, dt):
        """Thread holds a sewn stitch: between Eq. 2's velocity update and the contacts,
        the velocities v(t+dt) of a stitch that would open beyond its limit are changed so
        that it opens to the limit exactly. A seam spring as stiff as thread would need a
        step too short to run; this is its limit of infinite stiffness, as a velocity filter
        (as Bridson et al. 2002 limit strain), so the step keeps its size.

        The limit (``model.seam_limit``, per stitch): none while the paper's springs sew the
        stitch; once its gap g is within :data:`HOLD_CATCH` × h (h = ``model.seam_hold_m``)
        the stitch is caught, and each step its limit becomes max(h, min(limit, g) −
        :data:`HOLD_DRAW_M_S` dt): the thread is drawn in to h and never lets the stitch
        reopen. Its gap is the seam's own (:func:`~sandbox.sim.seams.seam_openings`): a
        zero-length spring's length, a spring of rest length r's stretch, or, for a point
        between two of the other line's (two springs from one particle, both r > 0), its
        distance to the point of equal parameter q = (1 − w) x_j + w x_j+1,
        w = r_1 / (r_1 + r_2). With the predicted gap d = p_a − q (p = x + dt v),
        n = d/|d|, inverse masses w_k, weights c_k of the points in q (c_a = 1) and s_k the
        springs particle k is in, the impulse λ = (|d| − limit) / (dt Σ c_k² s_k w_k)
        changes v_a by −w_a λ n and v_k by c_k w_k λ n: momentum is kept, and the change
        only removes the separating speed. All stitches are solved at once (Jacobi): a
        particle in s springs counts with s times its inverse mass in each λ and takes the
        sum of their changes (mass splitting, Tonge et al. 2012), so a shared particle does
        not overshoot. No-op with h = 0.
        """
        m = self.model
        if ti.static(m.has_seams):
            hold = m.seam_hold_m[None]
            count = m.seam_active[None] if hold > 0.0 and dt > 0.0 else 0
            for q in range(count):
                self.seam_dv[2 * q] = ti.Vector([0.0, 0.0, 0.0])
                self.seam_dv[2 * q + 1] = ti.Vector([0.0, 0.0, 0.0])
            for q in range(count):
                a, b = m.seam_pairs[q][0], m.seam_pairs[q][1]
                r = m.seam_rest[q]
                role = 0  # 0: a spring; 1: the first of a point's two; 2: the second
                if r > 0.0 and q + 1 < count:
                    if m.seam_rest[q + 1] > 0.0 and m.seam_pairs[q + 1][0] == a:
                        role = 1
                if role == 0 and r > 0.0 and q > 0:
                    if m.seam_rest[q - 1] > 0.0 and m.seam_pairs[q - 1][0] == a:
                        role = 2
                if role != 2:
                    b2 = b
                    c1, c2 = 1.0, 0.0
                    rest = r
                    if role == 1:
                        b2 = m.seam_pairs[q + 1][1]
                        w = r / (r + m.seam_rest[q + 1])
                        c1, c2 = 1.0 - w, w
                        rest = 0.0
                    gap = (x[a] - c1 * x[b] - c2 * x[b2]).norm() - rest
                    limit = m.seam_limit[q]
                    if limit < 0.0 and gap <= HOLD_CATCH * hold:
                        limit = gap
                    if limit >= 0.0:
                        limit = ti.max(hold, ti.min(limit, gap) - HOLD_DRAW_M_S * dt)
                        m.seam_limit[q] = limit
                        d = (x[a] + dt * v[a]) - c1 * (x[b] + dt * v[b]) - c2 * (x[b2] + dt * v[b2])
                        length = d.norm()
                        wa = m.particle_inv_mass[a]
                        wb, wb2 = m.particle_inv_mass[b], m.particle_inv_mass[b2]
                        inv = (wa * self._seam_share(a) + c1 * c1 * wb * self._seam_share(b)
                               + c2 * c2 * wb2 * self._seam_share(b2))  # fmt: skip
                        if length > rest + limit and inv > 0.0:
                            n = d / length
                            lam = (length - rest - limit) / (dt * inv)
                            self.seam_dv[2 * q] = -wa * lam * n
                            self.seam_dv[2 * q + 1] = c1 * wb * lam * n
                            if role == 1:
                                self.seam_dv[2 * q + 3] = c2 * wb2 * lam * n
            for i in range(m.particle_count if count > 0 else 0):
                for k in range(m.vert_seam_start[i], m.vert_seam_start[i + 1]):
                    v[i] += self.seam_dv[m.vert_seam_slot[k]]

    @ti.func
    def _seam_share(self, i):
        """How many seam springs particle i is in (at least 1): the seam hold splits its
        mass among them."""
        return ti.max(1, self.model.vert_seam_start[i + 1] - self.model.vert_seam_start[i])

    @ti.func
    def _contact(self, i, x_in, v_new, dt):
        """Contact (§2.5): each body collider revises v(t+dt) of particle i before the
        position update. Returns ``(v_move, push)`` as :meth:`_velocity`."""
        m = self.model
        push = ti.Vector([0.0, 0.0, 0.0])
        if m.particle_inv_mass[i] > 0.0:
            for c in ti.static(m.colliders):
                v_move, v_keep = c.respond_split(x_in[i], v_new, dt)
                push += v_move - v_keep
                v_new = v_move
        return v_new, push

    @ti.func
    def _position(self, i, x_in, x_out, v_new, dt, index):
        # Eq. 2: x(t+dt) = x(t) + dt v(t+dt)
        x_new = x_in[i] + dt * v_new
        if not (ti.abs(x_new).max() < 1e30):  # catches NaN and infinity
            ti.atomic_min(self.bad_step[None], index)
            ti.atomic_min(self.bad_vertex[None], i)
        x_out[i] = x_new

    @ti.func
    def _kick_drift(self, x_in, v_in, x_out, v_out, gravity, damping, dt, index):
        """Both halves of Eq. 2 (no self-collision between them): one pass over the
        particles, or three with the face pass of a closed body."""
        if ti.static(self.has_faces):
            self._kick(x_in, v_in, v_out, gravity, damping, dt)
            for i in range(self.model.particle_count):
                self._position(i, x_in, x_out, v_out[i], dt, index)
                v_out[i] -= self.push[i]
        elif ti.static(self.has_bodies or self.model.has_seams):
            # two loops: the force gather and the contact queries, each compiled on its
            # own, run faster than one loop doing both (measured on the draped sheet); the
            # seam hold between them needs every particle's new velocity
            for i in range(self.model.particle_count):
                v_out[i] = self._free_velocity(i, v_in, gravity, damping, dt)
            self._seam_hold(x_in, v_out, dt)
            for i in range(self.model.particle_count):
                v_new, push = self._contact(i, x_in, v_out[i], dt)
                v_out[i] = v_new - push
                self._position(i, x_in, x_out, v_new, dt, index)
        else:
            for i in range(self.model.particle_count):
                v_new, push = self._velocity(i, x_in, v_in, gravity, damping, dt)
                v_out[i] = v_new - push
                self._position(i, x_in, x_out, v_new, dt, index)

    @ti.func
    def _kick(self, x_in, v_in, v_out, gravity, damping, dt):
        for i in range(self.model.particle_count):
            v_out[i] = self._free_velocity(i, v_in, gravity, damping, dt)
        self._seam_hold(x_in, v_out, dt)
        if ti.static(self.has_bodies):  # two loops, as in :meth:`_kick_drift`
            for i in range(self.model.particle_count):
                v_new, push = self._contact(i, x_in, v_out[i], dt)
                v_out[i] = v_new
                self.push[i] = push
        if ti.static(self.has_faces):
            self._face_pass(x_in, v_out, dt)

    @ti.func
    def _face_pass(self, x, v, dt):
        """Closed bodies' vertices against the cloth's triangles (after the vertex tests).

        Each triangle whose predicted position x + dt v lets a body vertex poke through
        (:meth:`BodyCollider.poke`) gets a velocity change Δu at the poking point: depth/dt
        along the normal, which moves the point back to the thickness, plus Coulomb
        friction on its tangential velocity (as in ``respond``); corner k changes by
        w_k / Σw² · Δu, so the point at the weights w changes by exactly Δu. A particle
        shared by several such triangles takes their mean. Pinned particles do not move.

        As in the vertex test (``respond_split``), the outward push moves the triangle this
        step and is not kept: the velocity kept for the next step only loses the point's
        inward normal speed (inelastic contact). Keeping depth/dt would launch the cloth
        off the body every step and keep it moving.
        """
        m = self.model
        for i in range(m.particle_count):
            self.face_dv[i] = ti.Vector([0.0, 0.0, 0.0])
            self.face_lift[i] = ti.Vector([0.0, 0.0, 0.0])
            self.face_count[i] = 0
        if dt > 0.0:
            for t in range(m.tri_count):
                tv = m.tri_indices[t]
                a = x[tv[0]] + dt * v[tv[0]]
                b = x[tv[1]] + dt * v[tv[1]]
                c = x[tv[2]] + dt * v[tv[2]]
                for body in ti.static(self.face_bodies):
                    depth, n, w = body.poke(a, b, c)
                    if depth > 0.0:
                        # the poking point's velocity change: normal, then Coulomb friction
                        dvn = depth / dt
                        u = w[0] * v[tv[0]] + w[1] * v[tv[1]] + w[2] * v[tv[2]]
                        un = u.dot(n)
                        ut = u - un * n
                        ut_len = ut.norm()
                        dv = dvn * n - ut
                        if ut_len > body.mu_s[None] * dvn:
                            dv = dvn * n - body.mu_k[None] * dvn / ut_len * ut
                        # the part of the push the velocity does not keep
                        lift = (dvn - ti.max(-un, 0.0)) * n
                        scale = 1.0 / w.dot(w)
                        for k in ti.static(range(3)):
                            ti.atomic_add(self.face_dv[tv[k]], scale * w[k] * dv)
                            ti.atomic_add(self.face_lift[tv[k]], scale * w[k] * lift)
                            ti.atomic_add(self.face_count[tv[k]], 1)
        for i in range(m.particle_count):
            if self.face_count[i] > 0 and m.particle_inv_mass[i] > 0.0:
                v[i] += self.face_dv[i] / self.face_count[i]
                self.push[i] += self.face_lift[i] / self.face_count[i]

    @ti.func
    def _drift(self, x_in, v, x_out, dt, index, count):
        """Positions of particles 0..count-1 after self-collision, with its separation
        (``corr``, not a velocity)."""
        sc = self.model.self_collider
        for i in range(count):
            self._position(i, x_in, x_out, v[i] + sc.corr[i], dt, index)
            if ti.static(self.has_bodies):
                v[i] -= self.push[i]
