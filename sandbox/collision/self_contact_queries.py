"""Self-collision candidate queries: vertex-triangle and edge-edge pairs within reach.

A pair is appended to the list when its features are closer than the reach (thickness plus
margin), grown for a fast step by their relative motion (the sweep). Excluded pairs: a
vertex and a triangle that contains it, two edges with a common vertex, and pairs joined
by a seam (a vertex with a triangle or an edge holding its seam partner or one of the
partner's mesh neighbours).

A mixin of :class:`sandbox.collision.self_contact.SelfCollider` (its fields and settings).
"""

import taichi as ti

from sandbox.collision.primitives import point_triangle_closest, segment_segment_closest
from sandbox.collision.self_contact_config import KIND_EE, KIND_VT


class PairQueries:
    """Exclusions, per-item queries and the append of vertex-triangle and edge-edge pairs."""

    @ti.func
    def _listed(self, start: ti.template(), flat: ti.template(), a, b):
        """Is particle b in particle a's CSR list (start, flat)?"""
        found = False
        for k in range(start[a], start[a + 1]):
            if flat[k] == b:
                found = True
        return found

    @ti.func
    def _partners(self, a, b):
        """Is particle b near particle a (sewn, a partner's partner, or their neighbour)?"""
        return self._listed(self.partner_start, self.partner, a, b)

    @ti.func
    def _excluded_vt(self, u, t):
        """u is a corner of t, or t holds u's seam partner (or its neighbours)."""
        return (
            u == t[0] or u == t[1] or u == t[2]
            or self._partners(u, t[0]) or self._partners(u, t[1]) or self._partners(u, t[2])
        )  # fmt: skip

    @ti.func
    def _excluded_ee(self, a, b):
        """The edges share a vertex, or an end point of one is sewn near the other."""
        shared = a[0] == b[0] or a[0] == b[1] or a[1] == b[0] or a[1] == b[1]
        sewn = (
            self._partners(a[0], b[0]) or self._partners(a[0], b[1])
            or self._partners(a[1], b[0]) or self._partners(a[1], b[1])
        )  # fmt: skip
        return shared or sewn

    @ti.func
    def _append(self, kind, idx):
        slot = ti.atomic_add(self.pair_count[None], 1)
        if slot < self.capacity:
            self.pair[slot] = idx
            self.pair_kind[slot] = kind
        else:
            self.overflow[None] = 1

    @ti.func
    def _motion(self, i, v, dt):
        """Particle i's displacement this step relative to the cloth's mean motion [m]."""
        return (dt * v[i] - self.mean_shift[None]).norm()

    @ti.func
    def _triangle_query(self, t, x, v, dt, query, reach):
        """Triangle t's query for the list: its corners (tv, a, b, c), its box grown by
        ``query`` and that box's cells, its largest relative motion this step, and its
        swept box this step grown by ``reach``."""
        tv = self.model.tri_indices[t]
        a, b, c = x[tv[0]], x[tv[1]], x[tv[2]]
        box_lo, box_hi = ti.min(a, b, c) - query, ti.max(a, b, c) + query
        lo, hi = self._cell_range(box_lo, box_hi)
        tri_move = ti.max(self._motion(tv[0], v, dt), self._motion(tv[1], v, dt),
                          self._motion(tv[2], v, dt))  # fmt: skip
        ya, yb, yc = a + dt * v[tv[0]], b + dt * v[tv[1]], c + dt * v[tv[2]]
        t_lo = ti.min(ti.min(a, b, c), ti.min(ya, yb, yc)) - reach
        t_hi = ti.max(ti.max(a, b, c), ti.max(ya, yb, yc)) + reach
        return tv, a, b, c, box_lo, box_hi, lo, hi, tri_move, t_lo, t_hi

    @ti.func
    def _vertex_triangle(self, u, tv, a, b, c, box_lo, box_hi, t_lo, t_hi, tri_move, reach,
                         sweep_k, x, v, dt):  # fmt: skip
        """Append vertex u and triangle tv = (a, b, c) if u is within the reach (plus sweep).

        Cheap tests first (Taichi does not short-circuit ``and``): the query box, the swept
        boxes, the exclusions, then the closest point.
        """
        p = x[u]
        if (p >= box_lo).all() and (p <= box_hi).all():
            y = p + dt * v[u]
            if (ti.min(p, y) <= t_hi).all() and (ti.max(p, y) >= t_lo).all():
                if not self._excluded_vt(u, tv):
                    w = point_triangle_closest(p, a, b, c)
                    q = w[0] * a + w[1] * b + w[2] * c
                    sweep = sweep_k * (self._motion(u, v, dt) + tri_move)
                    if (p - q).norm() < reach + sweep:
                        self._append(KIND_VT, ti.Vector([u, tv[0], tv[1], tv[2]]))

    @ti.func
    def _edge_query(self, e, x, v, dt, query, reach, grow):
        """Edge e's query: its ends, its box grown by ``query``, its largest relative
        motion, its swept box grown by ``reach``, and the cells of its box grown by
        ``grow`` (other edges are binned by midpoint)."""
        ea = self.edge[e]
        p0, p1 = x[ea[0]], x[ea[1]]
        box_lo, box_hi = ti.min(p0, p1) - query, ti.max(p0, p1) + query
        move_a = ti.max(self._motion(ea[0], v, dt), self._motion(ea[1], v, dt))
        r0, r1 = p0 + dt * v[ea[0]], p1 + dt * v[ea[1]]
        a_lo = ti.min(ti.min(p0, p1), ti.min(r0, r1)) - reach
        a_hi = ti.max(ti.max(p0, p1), ti.max(r0, r1)) + reach
        lo, hi = self._cell_range(ti.min(p0, p1) - grow, ti.max(p0, p1) + grow)
        return ea, p0, p1, box_lo, box_hi, move_a, a_lo, a_hi, lo, hi

    @ti.func
    def _edge_edge(self, e, s, entry, ends0, ends1, box_lo, box_hi, a_lo, a_hi, move_a, reach,
                   sweep_k, x, v, dt):  # fmt: skip
        """Append edge e and the edge of grid entry s (of ``entry``, with end points
        ``ends0``, ``ends1``) if they are within the reach (plus sweep); cheap tests first,
        as in :meth:`_vertex_triangle`."""
        q0, q1 = ends0[s], ends1[s]
        if (ti.min(q0, q1) <= box_hi).all() and (ti.max(q0, q1) >= box_lo).all():
            f = entry[s]
            eb = self.edge[f]
            s0, s1 = q0 + dt * v[eb[0]], q1 + dt * v[eb[1]]
            b_lo = ti.min(ti.min(q0, q1), ti.min(s0, s1))
            b_hi = ti.max(ti.max(q0, q1), ti.max(s0, s1))
            if (a_lo <= b_hi).all() and (b_lo <= a_hi).all():
                ea = self.edge[e]
                if not self._excluded_ee(ea, eb):
                    self._edge_pair(ea, eb, x[ea[0]], x[ea[1]], q0, q1, move_a, reach,
                                    sweep_k, v, dt, f < e)  # fmt: skip

    @ti.func
    def _edge_pair(self, ea, eb, p0, p1, q0, q1, move_a, reach, sweep_k, v, dt, swap):
        """Append edges ea, eb (eb first if ``swap``: the lower edge number leads) if their
        closest points are within the reach (plus sweep)."""
        sa, sb = segment_segment_closest(p0, p1, q0, q1)
        d = (p0 + sa * (p1 - p0)) - (q0 + sb * (q1 - q0))
        move_b = ti.max(self._motion(eb[0], v, dt), self._motion(eb[1], v, dt))
        if d.norm() < reach + sweep_k * (move_a + move_b):
            idx = ti.Vector([ea[0], ea[1], eb[0], eb[1]])
            if swap:
                idx = ti.Vector([eb[0], eb[1], ea[0], ea[1]])
            self._append(KIND_EE, idx)
