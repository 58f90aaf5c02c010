"""The self-collision candidate list (a Verlet list): when to renew it, rebuild, refresh.

The list holds all pairs closer than h + margin at the positions x_b of the last rebuild.
Moving every vertex by at most margin/2 changes any pair's distance by at most margin, so
as long as x(t) and x(t+dt) stay within margin/2 of x_b, no pair outside the list can come
within h during the step. The list is rebuilt when a vertex would leave that bound; the
margin grows with the step's largest displacement so large steps stay covered. In a slow
step where only a few vertices drifted, only their pairs are found again (``refresh``).

A mixin of :class:`sandbox.collision.self_contact.SelfCollider` (its fields and settings).
"""

import taichi as ti


class CandidateList:
    """Prepare a step, and rebuild or refresh the list of candidate pairs."""

    @ti.func
    def prepare(self, x, v, dt):
        """Start of the contact passes: clear corrections, decide whether to rebuild.

        ``max_step`` becomes this step's largest displacement relative to the cloth's mean
        motion [m], the motion a rebuilt list must cover. ``needs_build`` becomes 1 (a full
        rebuild) or 2 (a partial refresh, :meth:`refresh`) when a vertex would leave the
        list's bound: a refresh when the step is slow and only the few vertices that
        drifted more than ``partial_tau`` margins caused it.
        """
        n = self.model.particle_count
        # two passes (means, then maxima) for the step's motion and the drift since x_b
        self.mean_shift[None] = ti.Vector([0.0, 0.0, 0.0])
        self.drift_mean[None] = ti.Vector([0.0, 0.0, 0.0])
        ti.loop_config(serialize=True)  # sums in a fixed order: the same run, the same result
        for i in range(n):
            self.mean_shift[None] += dt * v[i] / n
            self.drift_mean[None] += (x[i] + dt * v[i] - self.x_build[i]) / n
        self.max_step[None] = 0.0
        self.spread[None] = 0.0
        self.shift[None] = self.drift_mean[None] - self.mean_shift[None]  # mean of x − x_b
        self.marked_count[None] = 0
        tau = self.config.partial_tau * self.margin[None]
        for i in range(n):
            ti.atomic_max(self.max_step[None], (dt * v[i] - self.mean_shift[None]).norm())
            u = x[i] + dt * v[i] - self.x_build[i] - self.drift_mean[None]
            ti.atomic_max(self.spread[None], u.norm())
            # drifted at the start of the step or at its predicted end
            w = (x[i] - self.x_build[i] - self.shift[None]).norm()
            self.marked[i] = 0
            if ti.max(w, u.norm()) > tau:
                self.marked[i] = 1
                ti.atomic_add(self.marked_count[None], 1)
            self.moved[i] = (x[i] - self.x_build[i]).norm()
            self.corr[i] = ti.Vector([0.0, 0.0, 0.0])
            self.touched[i] = 0
        if self.spread[None] > 0.4 * self.margin[None] and self.needs_build[None] == 0:
            self.needs_build[None] = 1
            margin = self.margin[None]
            grown = ti.max(
                self.margin0,
                ti.min(self.config.margin_steps * self.max_step[None],
                       self.config.margin_edge_fraction * self.mean_edge),
            )  # fmt: skip
            steady = ti.abs(grown - margin) <= 0.2 * margin  # a rebuild would keep it
            slow = 2.0 * self.max_step[None] <= 0.4 * margin and steady
            few = self.marked_count[None] <= self.config.partial_fraction * n
            if slow and few and self.marked_count[None] > 0:
                self.needs_build[None] = 2

    @ti.func
    def _drift_from_build(self, x, v, dt):
        """max_i |x_i + dt (v_i + corr_i) − x_b,i − c| [m], c = ``drift_mean`` (the mean of
        those displacements before the passes, from :meth:`prepare`).

        Pair distances change only through relative motion, so the cloth moving as a whole
        (falling) does not invalidate the candidate list; any common shift c may be taken
        out, and the mean before the passes' small impulses is close to the best one.
        """
        self.spread[None] = 0.0
        for i in range(self.model.particle_count):
            u = x[i] + dt * (v[i] + self.corr[i]) - self.x_build[i] - self.drift_mean[None]
            ti.atomic_max(self.spread[None], u.norm())
        return self.spread[None]

    @ti.func
    def rebuild(self, x, v, dt):
        """The candidate list at the current positions (call when ``needs_build``).

        A dense grid over the cloth with one entry per item: vertices by position, edges by
        midpoint. Each triangle looks for vertices in its box grown by the reach; each edge
        looks for edges whose midpoint lies in its box grown by the reach plus half the
        longest edge. Every pair is found once: that condition is symmetric, so only the
        edge whose midpoint cell comes first (row-major; the lower index within a cell)
        looks, and it visits only the cells from its own on.
        """
        m = self.model
        h = self.thickness[None]
        # more steps per rebuild when the cloth moves fast, but not so far that pairs of
        # neighbours in the cloth's own plane fill the list; a single step that moves
        # further than that still gets a list that covers it (large dt)
        grown = ti.min(
            self.config.margin_steps * self.max_step[None],
            self.config.margin_edge_fraction * self.mean_edge,
        )
        self.margin[None] = ti.max(self.margin0, grown)
        reach = h + self.margin[None]
        # pairs that this very step's relative motion could bring together are kept too
        sweep_k = self.config.sweep_safety * self.sweep_scale[None]
        fast = 2.0 * self.max_step[None] > 0.4 * self.margin[None]
        self.swept[None] = 1 if fast and sweep_k > 0.0 else 0
        query = reach + 2.0 * sweep_k * self.max_step[None]
        cells = self._fit_grid(x, self.config.cell_scale * ti.max(self.mean_edge, reach))
        self.half_edge[None] = 0.0
        for i in range(m.particle_count):
            self.x_build[i] = x[i]
        for e in range(self.edge_count):
            length = (x[self.edge[e][0]] - x[self.edge[e][1]]).norm()
            ti.atomic_max(self.half_edge[None], 0.5 * length)
        self._bin_vertices(x, cells)
        for c in range(cells):
            self.e_count[c] = 0
        for e in range(self.edge_count):
            mid = 0.5 * (x[self.edge[e][0]] + x[self.edge[e][1]])
            ti.atomic_add(self.e_count[self._cell_index(self._cell_of(mid))], 1)
        self._starts(self.e_count, self.e_start, self.e_block, cells)
        for e in range(self.edge_count):
            q0, q1 = x[self.edge[e][0]], x[self.edge[e][1]]
            c = self._cell_index(self._cell_of(0.5 * (q0 + q1)))
            s = self.e_start[c] + ti.atomic_add(self.e_count[c], 1)
            self.e_entry[s] = e
            self.e_p0[s] = q0
            self.e_p1[s] = q1
        self.pair_count[None] = 0
        # vertex-triangle
        for t in range(m.tri_count):
            tv, a, b, c, box_lo, box_hi, lo, hi, tri_move, t_lo, t_hi = self._triangle_query(
                t, x, v, dt, query, reach
            )
            for i in range(lo[0], hi[0] + 1):
                for j in range(lo[1], hi[1] + 1):
                    # the vertices of cells (i, j, lo..hi) are consecutive entries
                    row = self._cell_index(ti.Vector([i, j, 0]))
                    for s in range(self.v_start[row + lo[2]], self.v_start[row + hi[2] + 1]):
                        self._vertex_triangle(
                            self.v_entry[s], tv, a, b, c, box_lo, box_hi, t_lo, t_hi,
                            tri_move, reach, sweep_k, x, v, dt,
                        )  # fmt: skip
        # edge-edge
        grow = query + self.half_edge[None]
        for e in range(self.edge_count):
            ea, p0, p1, box_lo, box_hi, move_a, a_lo, a_hi, lo, hi = self._edge_query(
                e, x, v, dt, query, reach, grow
            )
            # this edge's own cell (as binned): the cells before it in row-major order are
            # left to their edges, which find this one
            own = self._cell_of(0.5 * (p0 + p1))
            own = ti.max(ti.min(own, self.grid_dims[None] - 1), ti.Vector([0, 0, 0]))
            own_index = self._cell_index(own)
            own_hi = self.e_start[own_index + 1]
            for i in range(own[0], hi[0] + 1):
                j_from = lo[1]
                if i == own[0]:
                    j_from = own[1]
                for j in range(j_from, hi[1] + 1):
                    k_from = lo[2]
                    if i == own[0] and j == own[1]:
                        k_from = own[2]
                    # the edges of cells (i, j, k_from..hi) are consecutive entries
                    row = self._cell_index(ti.Vector([i, j, 0]))
                    for s in range(self.e_start[row + k_from], self.e_start[row + hi[2] + 1]):
                        # in the own cell, each pair once: the other edge's index is higher
                        if s >= own_hi or self.e_entry[s] > e:
                            self._edge_edge(e, s, self.e_entry, self.e_p0, self.e_p1, box_lo,
                                            box_hi, a_lo, a_hi, move_a, reach, sweep_k, x, v,
                                            dt)  # fmt: skip
        for i in range(m.particle_count):
            self.build_step[i] = dt * v[i]
        self._order_pairs()
        self.needs_build[None] = 0
        self.fresh[None] = 1  # the next proximity pass records the pairs' distances
        self.rebuilds[None] += 1

    @ti.func
    def refresh(self, x, v, dt):
        """Partial refresh of the candidate list (``needs_build`` 2, a slow step): only the
        pairs with a marked vertex (one that drifted more than ``partial_tau`` margins) are
        found again, at the current positions.

        Why it holds: a pair not in the list was farther than h + margin either at the
        last full rebuild (no marked vertex: the usual bound) or now. A pair found now
        is searched with a reach grown by 2 tau: each of its unmarked vertices has drifted
        at most tau from its own build position, so measured against the build positions,
        as every later bound is, the pair is at least h + margin apart too. The marked
        vertices' build positions become their current ones (less the common shift), and
        their new pairs compute their distance every step (``pair_dist0`` = -1).

        The marked vertices, and the edges that touch them, get a grid of their own; every
        triangle and every edge looks in it. A triangle with a marked corner looks at every
        vertex instead. Each pair is found once: a marked edge takes only the marked edges
        numbered after it.
        """
        m = self.model
        h = self.thickness[None]
        tau = self.config.partial_tau * self.margin[None]
        reach = h + self.margin[None] + 2.0 * tau
        sweep_k = self.config.sweep_safety * self.sweep_scale[None]
        query = reach + 2.0 * sweep_k * self.max_step[None]
        self._drop_marked_pairs()
        base = self.pair_count[None]
        cells = self._fit_grid(x, self.config.cell_scale * ti.max(self.mean_edge, reach))
        self._bin_vertices(x, cells)
        self._bin_marked(x, cells)
        # vertex-triangle: a triangle with a marked corner against every vertex, any other
        # triangle against the marked vertices
        for t in range(m.tri_count):
            tv, a, b, c, box_lo, box_hi, lo, hi, tri_move, t_lo, t_hi = self._triangle_query(
                t, x, v, dt, query, reach
            )
            corner = self.marked[tv[0]] + self.marked[tv[1]] + self.marked[tv[2]] > 0
            for i in range(lo[0], hi[0] + 1):
                for j in range(lo[1], hi[1] + 1):
                    row = self._cell_index(ti.Vector([i, j, 0]))
                    if corner:
                        for s in range(self.v_start[row + lo[2]], self.v_start[row + hi[2] + 1]):
                            self._vertex_triangle(
                                self.v_entry[s], tv, a, b, c, box_lo, box_hi, t_lo, t_hi,
                                tri_move, reach, sweep_k, x, v, dt,
                            )  # fmt: skip
                    else:
                        for s in range(self.mv_start[row + lo[2]], self.mv_start[row + hi[2] + 1]):
                            self._vertex_triangle(
                                self.mv_entry[s], tv, a, b, c, box_lo, box_hi, t_lo, t_hi,
                                tri_move, reach, sweep_k, x, v, dt,
                            )  # fmt: skip
        # edge-edge: every edge against the marked edges (a marked edge: those after it)
        grow = query + self.half_edge[None]
        for e in range(self.edge_count):
            ea, p0, p1, box_lo, box_hi, move_a, a_lo, a_hi, lo, hi = self._edge_query(
                e, x, v, dt, query, reach, grow
            )
            own_marked = self._edge_marked(e)
            for i in range(lo[0], hi[0] + 1):
                for j in range(lo[1], hi[1] + 1):
                    row = self._cell_index(ti.Vector([i, j, 0]))
                    for s in range(self.me_start[row + lo[2]], self.me_start[row + hi[2] + 1]):
                        if not own_marked or self.me_entry[s] > e:
                            self._edge_edge(e, s, self.me_entry, self.me_p0, self.me_p1,
                                            box_lo, box_hi, a_lo, a_hi, move_a, reach, sweep_k,
                                            x, v, dt)  # fmt: skip
        count = ti.min(self.pair_count[None], self.capacity)
        for p in range(base, count):
            self.pair_dist0[p] = -1.0  # computed every step (see above)
        for i in range(m.particle_count):
            if self.marked[i] == 1:
                self.x_build[i] = x[i] - self.shift[None]
        self._order_pairs()
        self.needs_build[None] = 0
        self.refreshes[None] += 1

    @ti.func
    def _edge_marked(self, e):
        return self.marked[self.edge[e][0]] + self.marked[self.edge[e][1]] > 0

    @ti.func
    def _bin_marked(self, x, cells):
        """The marked vertices' grid (mv_start, mv_entry) and the marked edges' by midpoint
        (me_start, me_entry, me_p0, me_p1); ``half_edge`` := half the longest marked edge."""
        m = self.model
        self.half_edge[None] = 0.0
        for c in range(cells):
            self.mv_count[c] = 0
            self.me_count[c] = 0
        for i in range(m.particle_count):
            if self.marked[i] == 1:
                ti.atomic_add(self.mv_count[self._cell_index(self._cell_of(x[i]))], 1)
        for e in range(self.edge_count):
            if self._edge_marked(e):
                q0, q1 = x[self.edge[e][0]], x[self.edge[e][1]]
                ti.atomic_add(self.me_count[self._cell_index(self._cell_of(0.5 * (q0 + q1)))], 1)
                ti.atomic_max(self.half_edge[None], 0.5 * (q0 - q1).norm())
        self._starts(self.mv_count, self.mv_start, self.v_block, cells)
        self._starts(self.me_count, self.me_start, self.e_block, cells)
        for i in range(m.particle_count):
            if self.marked[i] == 1:
                c = self._cell_index(self._cell_of(x[i]))
                self.mv_entry[self.mv_start[c] + ti.atomic_add(self.mv_count[c], 1)] = i
        for e in range(self.edge_count):
            if self._edge_marked(e):
                q0, q1 = x[self.edge[e][0]], x[self.edge[e][1]]
                c = self._cell_index(self._cell_of(0.5 * (q0 + q1)))
                slot = self.me_start[c] + ti.atomic_add(self.me_count[c], 1)
                self.me_entry[slot] = e
                self.me_p0[slot] = q0
                self.me_p1[slot] = q1
