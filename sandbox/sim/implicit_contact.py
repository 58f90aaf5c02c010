"""Body contact in the implicit step's energy: contact planes, penalty, friction, lift-out.

At the start of a step each vertex near a body gets the plane of its nearest body face and,
in a concave crease, a second one (``BodyCollider.contact_planes``), and E gains a penalty
½ k φ² where φ = n·x − offset < 0 (inside the thickness) and a smoothed Coulomb friction
μ λ f(|u|) on the step's tangential motion u (Li et al. 2020, IPC's friction potential;
λ the penalty's force at the current Newton iterate, held during its line search). The
planes stay fixed during the step. In the solve, cloth slides along the body: a seam pulled
around the neck closes instead of stopping where its straight path enters the body.

A mixin of :class:`sandbox.sim.implicit.ImplicitEulerSolver`: it works on the solver's
fields (``c_*``, ``x``, ``x0``, ``xh``) and reads its settings from ``self.config``
(:class:`~sandbox.sim.implicit_config.ImplicitConfig`).
"""

import taichi as ti

from sandbox.sim.implicit_config import REAL


class BodyContact:
    """Contact planes, their penalty and friction terms, and the lift out of the body."""

    @ti.kernel
    def _contact_planes(self):
        """Each free vertex's contact planes for the step (``BodyCollider.contact_planes``:
        the nearest body face's within ``contact_reach_m`` + 2|x̂ − x_n| of x_n and, in a
        crease, a second within ``crease_reach_m`` + 2|x̂ − x_n|), from the collider whose
        nearest face is closest; or none.

        A vertex keeps the planes it found at an earlier step while it has moved less than
        ``plane_reuse_m`` since and the bodies have not changed (``BodyCollider.generation``):
        the query looked twice ``plane_reuse_m`` farther than asked, so a face it did not
        find is still out of reach. Cloth at rest on the body then queries nothing."""
        m = self.model
        h = self.h[None]
        generation = 0
        for c in ti.static(m.colliders):
            generation += c.generation[None]
        fresh = generation != self.c_gen[None]
        margin = ti.cast(self.config.plane_reuse_m, REAL)
        for i in range(m.particle_count):
            held = self.c_k[i] > 0.0  # in contact at the step before
            self.c_k[i] = 0.0
            self.c_k2[i] = 0.0
            if m.particle_inv_mass[i] > 0.0:
                motion = 2.0 * (self.xh[i] - self.x0[i]).norm()
                reach = self.config.contact_reach_m + motion
                crease = self.config.crease_reach_m + motion
                moved = (self.x0[i] - self.c_at[i]).norm()
                held2 = held
                if (fresh or moved > margin or reach + moved > self.c_reach[i]
                        or crease + moved > self.c_creach[i]):  # fmt: skip
                    n1, t1, n2, t2 = self.c_n[i], self.c_t[i], self.c_n2[i], self.c_t2[i]
                    self._find_planes(i, reach + 2.0 * margin, crease + 2.0 * margin)
                    # a plane found again keeps its offset (its face, not the query, counts)
                    held = held and not fresh and self._same_plane(n1, t1, self.c_n[i], self.c_t[i])
                    held2 = held2 and not fresh and self._same_plane(n2, t2, self.c_n2[i],
                                                                     self.c_t2[i])  # fmt: skip
                count = self.c_count[i]
                if count == 0:
                    self.c_kscale[i] = 1.0
                if count > 0:
                    self._anchor_planes(i, held, held2)
                    thickness = ti.cast(0.0, REAL)
                    for ci, c in ti.static(enumerate(m.colliders)):
                        if self.c_col[i] == ci:
                            thickness = ti.cast(c.thickness[None], REAL)
                            self.c_mu[i] = ti.cast(c.mu_s[None], REAL)
                    # behind the face itself (the offset includes the thickness)
                    depth = self.c_t[i] - self.c_n[i].dot(self.x0[i])
                    self.c_in[i] = 1 if depth > thickness else 0
                    if self.c_in[i] == 1:  # the penalty let it through: stiffer from now on
                        self.c_kscale[i] = ti.min(2.0 * self.c_kscale[i],
                                                  self.config.contact_stiffening_max)  # fmt: skip
                    k = (self.config.contact_stiffness * self.c_kscale[i] * m.particle_mass[i]
                         / (h * h))  # fmt: skip
                    self.c_k[i] = k
                    self.c_k2[i] = k if count == 2 else 0.0
            if self.c_k[i] == 0.0:
                self.c_lam[i] = 0.0
                self.c_in[i] = 0
            if (self.x0[i] - self.x_end[i]).norm() > 0.0:  # not where the last step left it
                self.c_lam[i] = 0.0
            self.c_new[i] = 1 if self.c_lam[i] == 0.0 else 0
        self.c_gen[None] = generation

    @ti.func
    def _same_plane(self, n_a, t_a, n_b, t_b):
        """Whether two contact planes (unit normal, offset [m]) are one (to 1 µm)."""
        return (n_a - n_b).norm() < 1e-6 and ti.abs(t_a - t_b) < 1e-6

    @ti.func
    def _anchor_planes(self, i, held, held2):
        """Vertex i's penalty offsets for the step: a vertex that starts inside the
        thickness may not go deeper, but is not pushed out by the penalty either (no shock
        from a stiff penalty; the contact response after the solve does that, and
        :meth:`_lift_out` for a vertex that starts inside the body). So the offset is the
        plane's own (``c_t``) or the vertex's start, whichever is deeper, and it goes no
        deeper than the step before while the vertex keeps that plane (``held``, ``held2``
        for the crease's second): a cloth pulled into the body (a seam over the shoulder)
        then rests at the depth its pull balances instead of sinking by that depth every
        step until it is behind the face and lifted out again (measured: the 3 cm T-shirt's
        shoulder seam moved 2 mm every six frames at rest)."""
        start1 = self.c_n[i].dot(self.x0[i])
        start2 = self.c_n2[i].dot(self.x0[i])
        if held:
            start1 = ti.max(start1, self.c_o[i])
        if held2:
            start2 = ti.max(start2, self.c_o2[i])
        self.c_o[i] = ti.min(self.c_t[i], start1)
        self.c_o2[i] = ti.min(self.c_t2[i], start2)

    @ti.func
    def _find_planes(self, i, reach, crease):
        """Query the bodies for vertex i's planes from x_n (within ``reach`` and, for a
        crease's second plane, ``crease`` [m]) and keep them with where and how far it
        looked."""
        m = self.model
        xs = ti.cast(self.x0[i], float)
        best = ti.cast(1e30, float)
        self.c_count[i] = 0
        for ci, c in ti.static(enumerate(m.colliders)):
            count, n, o, n2, o2 = c.contact_planes(xs, ti.cast(reach, float),
                                                   ti.cast(crease, float))  # fmt: skip
            if count > 0 and n.dot(xs) - o < best:
                best = n.dot(xs) - o
                self.c_count[i] = count
                self.c_col[i] = ci
                self.c_n[i] = ti.cast(n, REAL)
                self.c_n2[i] = ti.cast(n2, REAL)
                self.c_t[i] = ti.cast(o, REAL)
                self.c_t2[i] = ti.cast(o2, REAL)
        self.c_at[i] = self.x0[i]
        self.c_reach[i] = reach
        self.c_creach[i] = crease

    @ti.func
    def _contact_terms(self, i, xi):
        """Body contact of free vertex i at xi: (energy [J], gradient [N], PSD Hessian [N/m]).

        With the step's plane (n, offset) and φ = n·x − offset (< 0: inside the thickness),
        the penalty ½ k φ² (k = ``contact_stiffness`` m/h²), and friction μ λ f(|u|) on the
        tangential motion u = (I − n nᵀ)(x − x_n), with λ [N] the penalty's force at the
        end of the step before, held for the whole step (so that Newton minimises one
        energy), or, for a contact that had none then (``c_new``), at each Newton iterate
        (:meth:`_update_contact_force`, held during a line search); and
        f(s) = s²/(2ε) below ε = ``friction_slip_m_s``·h, s − ε/2 above: a force μ λ u/ε while
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
            if phi2 < self.config.plane_band_m:  # on the plane too (a vertex stopped there)
                hess += k2 * n2.outer_product(n2)
            n = self.c_n[i]
            nn = n.outer_product(n)
            phi = n.dot(xi) - self.c_o[i]
            if phi < 0.0:
                e += 0.5 * k * phi * phi
                g += k * phi * n
            if phi < self.config.plane_band_m:
                hess += k * nn
            f = self.c_mu[i] * self.c_lam[i]
            if f > 0.0:
                u = xi - self.x0[i]
                u -= n.dot(u) * n
                eps = self.config.friction_slip_m_s * self.h[None]
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

    @ti.func
    def _stop_at_planes(self, i, d):
        """Vertex i's step d [m], changed so that it ends on a contact plane that it would
        otherwise pass through from in front (farther than ``plane_band_m``): the part of the
        step beyond the plane is taken off along the plane's normal, so the vertex keeps
        its motion along the plane. Where that would put it behind a crease's other plane,
        the step is shortened instead, to end on the first plane it meets.

        The penalty has no stiffness in front of its plane, so Newton's step does not see
        it coming: without this, one vertex carried deep into the penalty made the line
        search halve the step of the whole garment, 2-3 times per iteration while a garment
        settles on the body. On the plane, the vertex has the penalty's stiffness in the
        next iteration (``plane_band_m``) and finds its depth by Newton's method.
        """
        out = d
        if self.c_k[i] > 0.0:
            xi = self.x[i]
            n = self.c_n[i]
            phi = n.dot(xi) - self.c_o[i]
            t = ti.cast(1.0, REAL)  # the shortened step, for a crease
            if phi > self.config.plane_band_m and phi + n.dot(d) < 0.0:
                out -= (phi + n.dot(d)) * n
                t = phi / (-n.dot(d))
            if self.c_k2[i] > 0.0:
                n2 = self.c_n2[i]
                phi2 = n2.dot(xi) - self.c_o2[i]
                if phi2 > self.config.plane_band_m and phi2 + n2.dot(out) < 0.0:
                    if phi2 + n2.dot(d) < 0.0:
                        t = ti.min(t, phi2 / (-n2.dot(d)))
                    out -= (phi2 + n2.dot(out)) * n2
                    band = ti.static(self.config.plane_band_m)
                    if phi > band and phi + n.dot(out) < -band:
                        out = t * d  # back behind the first plane: stop at the first
        return out

    @ti.func
    def _out_of_crease(self, i, v):
        """Vertex i's velocity v [m/s] after the colliders' response, changed so that a
        vertex in a concave crease (two planes) ends in front of both (:meth:`_front_of_planes`);
        the change moves it but is not kept as velocity (``c_push``, as :meth:`_lift_out`).

        The response pushes a vertex out of its nearest face's thickness alone, which can
        put it inside the other face's: in the T-shirt's armpit at 1.5 cm the nearest face
        alternated and a vertex jumped 1.6 mm between the two every step, for ever."""
        out = v
        if self.c_k2[i] > 0.0:
            h = self.h[None]
            x_new = self.x0[i] + h * v
            y = self._front_of_planes(i, x_new)
            out = (y - self.x0[i]) / h
            self.c_push[i] += out - v
        return out

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
        ``contact_stiffness``; with planes that asked such vertices out at 0.1 m/s two of them
        stayed 12.7 mm inside (3 Dec 2026). Only vertices that start inside the body are lifted,
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
        line where both meet that is nearest to x (both only at ``lift_min_sin2``, and no
        move longer than ``lift_max_m``)."""
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
                if det > self.config.lift_min_sin2:
                    a = (-p1 + c * p2) / det
                    b = (-p2 + c * p1) / det
                    y = x + a * n1 + b * n2
            # a plane far off (a thin part's other side)
            if (y - x).norm() > self.config.lift_max_m:
                y = x
        return y
