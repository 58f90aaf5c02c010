"""The implicit step's energy E, its gradient and Hessian, and the Newton matrix product.

E(x) = Σ_i m_i/(2h²) |x_i − x̂_i|² + Σ_i γ m_i/(2h) |x_i − x_n,i|² + U(x) (+ body contact,
:mod:`sandbox.sim.implicit_contact`). The matrix M (1/h² + γ/h) + H is never assembled for
CG: per element the solver keeps the small Hessian (the 6x6 membrane Hessian in
F = [F_u, F_v] as three 3x3 blocks, the bending gradient and scale, the seam 3x3 block) and
the product is gathered per vertex through the model's incidence lists, as the explicit
solver gathers forces (no atomics, deterministic sums). For the direct solver the same
blocks are added into an assembled block matrix (:meth:`NewtonSystem._assemble`).

A mixin of :class:`sandbox.sim.implicit.ImplicitEulerSolver` (its fields and settings).
"""

import numpy as np
import taichi as ti

from sandbox.sim import forces, hessians
from sandbox.sim.implicit_config import REAL


class NewtonSystem:
    """E, ∇E, the per-element Hessians and the product (M c + H) p."""

    def system_product(self, y):
        """(M (1/h² + γ/h) + H) y for y numpy (n, 3), with the Hessians of the last Newton
        evaluation (the end of the last step). For tests and diagnostics."""
        n = self.model.particle_count
        self.p.from_numpy(np.asarray(y, dtype=np.float64))
        self._apply_kernel()
        return self.ap.to_numpy()[:n].astype(np.float64)

    def assembled_matrix(self):
        """The Newton matrix of the last evaluation as scipy CSC (3n x 3n); for tests.

        Only with ``linear_solver="direct"``."""
        if self.pattern.update():
            self._load_block_indices()
        self._assemble_into_numpy()
        p = self.pattern  # back from the band order to vertex order
        scalar = (3 * p.position[:, None] + np.arange(3)).ravel()
        return p.matrix(self.blocks)[scalar][:, scalar].tocsc()

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

    @ti.func
    def _element_derivatives(self, x):
        """Per element at x: the membrane's gradient and Hessian blocks in F (with their PSD
        parts for the preconditioner), each hinge's angle gradient and scale, each seam's
        gradient and Hessian (parallel loops)."""
        m = self.model
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
            if ti.static(self.config.compression_stiffness):
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
        self._element_derivatives(x)
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
