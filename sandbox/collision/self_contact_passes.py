"""The self-collision passes on the candidate pairs: proximity, then continuous collision.

1. **Proximity** (Bridson §7.2): pairs closer than the thickness get an inelastic normal
   impulse, Coulomb friction and a partial separation (a position correction).
2. **Continuous collision** (§6.1, §7.3): each pair is tested along its linear motion, and
   the first contact is answered with the normal velocity change that leaves the pair a
   small gap apart at the end of the step, repeated up to ``ccd_passes`` times.

Impulses are distributed with the pair's barycentric weights and the inverse masses, so
momentum is conserved and pinned vertices never move.

A mixin of :class:`sandbox.collision.self_contact.SelfCollider` (its fields and settings).
"""

import taichi as ti

from sandbox.collision.primitives import (
    coplanar_times,
    point_triangle_closest,
    segment_segment_closest,
)
from sandbox.collision.self_contact_config import KIND_EE, KIND_VT, SCAN_BLOCK


class ContactPasses:
    """Pass 1 (proximity) and pass 2 (continuous collision) over the candidate list."""

    @ti.func
    def _geometry(self, kind, p0, p1, p2, p3):
        """Barycentric weights W (4,) and the vector between the pair's closest points."""
        W = ti.Vector([0.0, 0.0, 0.0, 0.0])
        if kind == KIND_VT:
            w = point_triangle_closest(p0, p1, p2, p3)
            W = ti.Vector([1.0, -w[0], -w[1], -w[2]])
        else:
            s, t = segment_segment_closest(p0, p1, p2, p3)
            W = ti.Vector([1.0 - s, s, -(1.0 - t), -t])
        d = W[0] * p0 + W[1] * p1 + W[2] * p2 + W[3] * p3
        return W, d

    @ti.func
    def _fallback_normal(self, kind, p0, p1, p2, p3):
        n = (p2 - p1).cross(p3 - p1)  # vertex-triangle: the face normal
        if kind == KIND_EE:
            n = (p1 - p0).cross(p3 - p2)
        return n / ti.max(n.norm(), 1e-30)

    @ti.func
    def _apply(self, idx, W, J, v):
        """v_i += W_i m_i^-1 J for the pair's four vertices."""
        for k in ti.static(range(4)):
            v[idx[k]] += W[k] * self.model.particle_inv_mass[idx[k]] * J

    @ti.func
    def _denominator(self, idx, W):
        s = 0.0
        for k in ti.static(range(4)):
            s += W[k] * W[k] * self.model.particle_inv_mass[idx[k]]
        return s

    @ti.func
    def proximity(self, x, v, dt):
        """Pass 1: inelastic impulse, friction and separation for pairs closer than h.

        The pairs' geometry is computed for all of them in parallel; the impulses are then
        applied one pair after the other (each sees the velocities the previous left).
        """
        h = self.thickness[None]
        count = ti.min(self.pair_count[None], self.capacity)
        fresh = self.fresh[None]
        for p in range(count):  # parallel
            idx = self.pair[p]
            kind = self.pair_kind[p]
            near = True
            if fresh == 0:
                # a distance changes by at most how far each side's vertices moved
                m0, m1 = self.moved[idx[0]], self.moved[idx[1]]
                m2, m3 = self.moved[idx[2]], self.moved[idx[3]]
                moved = m0 + ti.max(m1, m2, m3)
                if kind == KIND_EE:
                    moved = ti.max(m0, m1) + ti.max(m2, m3)
                bound = self.pair_dist0[p] - moved
                if bound >= h:  # no impulse; CCD's test takes the bound (conservative)
                    near = False
                    self.pair_dist[p] = bound
            if near:
                W, d = self._geometry(kind, x[idx[0]], x[idx[1]], x[idx[2]], x[idx[3]])
                self.pair_w[p] = W
                self.pair_d[p] = d
                self.pair_dist[p] = d.norm()
                if fresh == 1:
                    self.pair_dist0[p] = d.norm()
        self.fresh[None] = 0
        self._near_list(count, h)
        for _ in range(1):  # serial: impulses of one pair are seen by the next
            for q in range(self.near_count[None]):
                p = self.near[q]
                dist = self.pair_dist[p]
                if dist < h:
                    idx = self.pair[p]
                    W = self.pair_w[p]
                    denom = self._denominator(idx, W)
                    if denom > 0.0:
                        n = self.pair_d[p] / ti.max(dist, 1e-30)
                        if dist <= 1e-6 * h:
                            p0, p1, p2, p3 = x[idx[0]], x[idx[1]], x[idx[2]], x[idx[3]]
                            n = self._fallback_normal(self.pair_kind[p], p0, p1, p2, p3)
                        vr = W[0] * v[idx[0]] + W[1] * v[idx[1]] + W[2] * v[idx[2]]
                        vr += W[3] * v[idx[3]]
                        vn = vr.dot(n)
                        dvn = ti.max(0.0, -vn)  # inelastic: stop the approach
                        vt = vr - vn * n
                        vt_len = vt.norm()
                        dvt = ti.Vector([0.0, 0.0, 0.0])
                        if vt_len > 0.0:  # Coulomb friction from the normal impulse
                            dvt = -ti.min(self.mu[None] * dvn / vt_len, 1.0) * vt
                        self._apply(idx, W, (dvn * n + dvt) / denom, v)
                        if dt > 0.0:
                            extra = self.config.separation_fraction * (h - dist) - dt * ti.max(
                                vn + dvn, 0.0
                            )
                            if extra > 0.0:
                                self._apply(idx, W, extra / dt / denom * n, self.corr)

    @ti.func
    def _near_list(self, count, h):
        """``near`` = the pairs closer than h, in list order (a block-wise compaction:
        count per block in parallel, block offsets serially, then fill in parallel)."""
        blocks = (count + SCAN_BLOCK - 1) // SCAN_BLOCK
        for b in range(blocks):
            total = 0
            for p in range(b * SCAN_BLOCK, ti.min((b + 1) * SCAN_BLOCK, count)):
                if self.pair_dist[p] < h:
                    total += 1
            self.near_block[b] = total
        ti.loop_config(serialize=True)
        for b in range(blocks):
            if b == 0:
                self.near_count[None] = 0
            offset = self.near_count[None]
            self.near_count[None] = offset + self.near_block[b]
            self.near_block[b] = offset
        for b in range(blocks):
            slot = self.near_block[b]
            for p in range(b * SCAN_BLOCK, ti.min((b + 1) * SCAN_BLOCK, count)):
                if self.pair_dist[p] < h:
                    self.near[slot] = p
                    slot += 1

    @ti.func
    def _reach(self, kind, idx, v, dt):
        """How far the pair's two features can approach each other this step [m]: the sum
        of each side's largest displacement dt (v + corr)."""
        u0 = dt * (v[idx[0]] + self.corr[idx[0]])
        u1 = dt * (v[idx[1]] + self.corr[idx[1]])
        u2 = dt * (v[idx[2]] + self.corr[idx[2]])
        u3 = dt * (v[idx[3]] + self.corr[idx[3]])
        reach = u0.norm() + ti.max(u1.norm(), u2.norm(), u3.norm())
        if kind == KIND_EE:
            reach = ti.max(u0.norm(), u1.norm()) + ti.max(u2.norm(), u3.norm())
        return reach

    @ti.func
    def _collision(self, kind, idx, x, v, dt):
        """First contact of the pair along the step: (hit, W, n, g0) or hit = False.

        g0 is the pair's normal distance at the start (>= 0 along n).
        """
        x0, x1, x2, x3 = x[idx[0]], x[idx[1]], x[idx[2]], x[idx[3]]
        u0 = dt * (v[idx[0]] + self.corr[idx[0]])
        u1 = dt * (v[idx[1]] + self.corr[idx[1]])
        u2 = dt * (v[idx[2]] + self.corr[idx[2]])
        u3 = dt * (v[idx[3]] + self.corr[idx[3]])
        reach = self._reach(kind, idx, v, dt)
        hit = False
        W = ti.Vector([0.0, 0.0, 0.0, 0.0])
        n = ti.Vector([0.0, 0.0, 0.0])
        g0 = 0.0
        h = self.thickness[None]
        eps = 1e-6 + 1e-3 * h
        roots = ti.Vector([0.0, 2.0, 2.0, 2.0])  # entry 0: the start, to bound the motion
        count = 1
        r = 0
        while r < count and not hit:  # one inlined distance routine for every time
            t = roots[r]
            y0, y1, y2, y3 = x0 + t * u0, x1 + t * u1, x2 + t * u2, x3 + t * u3
            Wt, d = self._geometry(kind, y0, y1, y2, y3)
            if r == 0:
                if reach >= d.norm() - eps:  # otherwise the pair cannot meet this step
                    found, k = coplanar_times(x0, x1, x2, x3, u0, u1, u2, u3)
                    roots[1] = found[0]
                    roots[2] = found[1]
                    roots[3] = found[2]
                    count = 1 + k
            elif d.norm() < eps:
                hit = True
                W = Wt
                n = self._fallback_normal(kind, y0, y1, y2, y3)
                start = W[0] * x0 + W[1] * x1 + W[2] * x2 + W[3] * x3
                if n.dot(start) < 0.0:
                    n = -n
                g0 = n.dot(start)
            r += 1
        return hit, W, n, g0

    @ti.func
    def continuous(self, x, v, dt):
        """Pass 2: CCD with inelastic impulses, repeated; sets ``unresolved``.

        A pair can collide only if its features' motions this step add up to at least
        their distance at x(t) (from pass 1). That is checked for every pair in parallel;
        the serial passes then test, in order, the pairs that could collide and the pairs
        whose vertices an impulse of this pass has moved since.
        """
        h = self.thickness[None]
        eps = 1e-6 + 1e-3 * h
        count = ti.min(self.pair_count[None], self.capacity)
        self.unresolved[None] = 0
        for i in range(self.model.particle_count):
            self.step_len[i] = (dt * (v[i] + self.corr[i])).norm()
        self.hit_count[None] = 0
        for p in range(count):  # parallel (``touched`` was cleared by ``prepare``)
            idx = self.pair[p]
            s0, s1 = self.step_len[idx[0]], self.step_len[idx[1]]
            s2, s3 = self.step_len[idx[2]], self.step_len[idx[3]]
            reach = s0 + ti.max(s1, s2, s3)  # as :meth:`_reach`, from the stored lengths
            if self.pair_kind[p] == KIND_EE:
                reach = ti.max(s0, s1) + ti.max(s2, s3)
            self.pair_hit[p] = 0
            if reach >= self.pair_dist[p] - eps:
                self.pair_hit[p] = 1
                self.hit_count[None] += 1
        for _ in range(1):  # serial
            # no pair can collide: nothing to test, and no impulse to pass on
            remaining = 1 if self.hit_count[None] > 0 else 0
            passes = 0
            while remaining > 0 and passes < self.config.ccd_passes and dt > 0.0:
                remaining = 0
                passes += 1
                for p in range(count):
                    idx = self.pair[p]
                    moved = self.touched[idx[0]] + self.touched[idx[1]] + self.touched[idx[2]]
                    if self.pair_hit[p] + moved + self.touched[idx[3]] > 0:
                        hit, W, n, g0 = self._collision(self.pair_kind[p], idx, x, v, dt)
                        denom = self._denominator(idx, W)
                        if hit and denom > 0.0:
                            ur = ti.Vector([0.0, 0.0, 0.0])
                            for k in ti.static(range(4)):
                                ur += W[k] * dt * (v[idx[k]] + self.corr[idx[k]])
                            gap = ti.min(self.config.ccd_gap_fraction * h, 0.5 * g0)
                            need = (gap - g0 - ur.dot(n)) / dt  # normal velocity change
                            if need > 0.0:
                                self._apply(idx, W, need / denom * n, v)
                                for k in ti.static(range(4)):
                                    self.touched[idx[k]] = 1
                                remaining += 1
                                self.ccd_hits[None] += 1
            if remaining > 0:
                self.unresolved[None] = remaining
        # the candidate list covers the step only if no vertex ends beyond margin / 2 (or
        # if it was built for this step's own motion: rebuilt again at the next step)
        self.covered[None] = 1
        if self._drift_from_build(x, v, dt) > 0.5 * self.margin[None]:
            self.needs_build[None] = 1
            if self.swept[None] == 0:
                self.covered[None] = 0
        if self.swept[None] == 1:
            # a list built for this step's motion holds the pairs that the velocities before
            # the passes could bring together (swept boxes); the impulses changed them: it
            # still covers the step only if no vertex ends more than half the margin away
            # from where those velocities took it
            self.excess[None] = 0.0
            for i in range(self.model.particle_count):
                u = dt * (v[i] + self.corr[i]) - self.build_step[i]
                ti.atomic_max(self.excess[None], u.norm())
            if self.excess[None] > 0.5 * self.margin[None]:
                self.needs_build[None] = 1
                self.covered[None] = 0
        self.swept[None] = 0
