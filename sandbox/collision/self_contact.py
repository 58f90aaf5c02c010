"""Cloth against itself, after Bridson, Fedkiw and Anderson (2002), paper §2.5.

After the explicit velocity update of Eq. 2 (and the body colliders), and before the
position update, the cloth's candidate velocities v(t+dt) are revised in three passes:

1. **Proximity** (Bridson §7.2). Every vertex–triangle and edge–edge pair closer than the
   thickness h at x(t) gets an inelastic normal impulse if it approaches, Coulomb friction
   from that impulse (μ), and a separation of a quarter of the missing thickness, applied as
   a position correction that does not enter the velocity (a 1/dt velocity kick would
   throw the cloth apart at small dt).
2. **Continuous collision** (§6.1, §7.3). Each pair is tested along its linear motion
   x(t) -> x(t) + dt v: the times where the four points are coplanar (a cubic) are checked
   for contact, and the first contact is answered with the normal velocity change that
   leaves the pair 0.1 h (or half its start distance) apart at the end of the step. The
   pass repeats until no pair collides, at most ``CCD_PASSES`` times.
3. **Rigid impact zones** (§7.4), the fail-safe: if collisions remain, the vertices of the
   colliding pairs are merged into zones that move rigidly for this step (their linear and
   angular momentum kept; a zone with a pinned vertex stands still), growing until no pair
   collides. This runs in numpy, outside the step kernel, and is rare.

Impulses are distributed to the four vertices with the pair's barycentric weights w
(vertex–triangle: 1, −b0, −b1, −b2; edge–edge: 1−s, s, −(1−t), −t) and the inverse masses,
so momentum is conserved and pinned vertices never move.

Candidate pairs are kept in a list (a Verlet list): all pairs closer than h + margin at the
positions x_b of the last rebuild. Moving every vertex by at most margin/2 changes any
pair's distance by at most margin, so as long as x(t) and x(t+dt) stay within margin/2 of
x_b, no pair outside the list can come within h during the step. The list is rebuilt
(a dense grid of vertices and edge midpoints, in Taichi) when a vertex would leave that bound; the
margin grows with the step's largest displacement so large steps stay covered. In a slow
step where only a few vertices drifted, only their pairs are found again (:meth:`refresh`).

Excluded pairs: a vertex and a triangle that contains it, two edges with a common vertex,
and pairs joined by a seam (a vertex with a triangle or an edge holding its seam partner or
one of the partner's mesh neighbours). Excluding mesh neighbours too would shrink the list
a lot but lets tight folds of a soft fabric cross (measured on the floor pile test).
"""

import numpy as np
import taichi as ti

from sandbox import runtime
from sandbox.collision.primitives import (
    coplanar_times,
    point_triangle_closest,
    segment_segment_closest,
)
from sandbox.errors import SandboxError

CCD_PASSES = 8
SWEEP_SAFETY = 1.25  # a fast step's pairs: reach grown by this times their relative motion
MARGIN_STEPS = 8.0  # the margin covers this many steps of the fastest relative motion...
MARGIN_EDGE_FRACTION = 0.3  # ...but stays below this part of the mean edge length
CELL_SCALE = 1.5  # grid cell size over max(mean rest edge length, reach)
CELLS_PER_ITEM = 8  # grid cells allocated per vertex or edge (whichever are more)
SCAN_BLOCK = 1024  # cells per block of the parallel prefix sum
MAX_GRID_EXTENT_M = 1e4  # the grid covers at most this much of the cloth's bounding box
SEPARATION_FRACTION = 0.25  # of the missing thickness, per step (proximity pass)
CCD_GAP_FRACTION = 0.1  # of the thickness, left between a colliding pair (CCD pass)
PAIRS_PER_VERTEX = 32
# partial refresh: when the list must be renewed but only the vertices that drifted more
# than PARTIAL_TAU margins (at most PARTIAL_FRACTION of them) caused it, only their pairs
# are found again
PARTIAL_TAU = 0.2
PARTIAL_FRACTION = 0.05
ZONE_ROUNDS = 100
NARROW_EDGE_EXCLUSION = False
"""Exclude edge-edge pairs only where an end of one edge is sewn to an end of the other
(or to a partner of it), instead of over the partner's whole mesh neighbourhood as for
vertex-triangle pairs. Off. With the neighbourhood, a panel's corner triangle next to a
seam can swing through the other panel across the seam line: the 1 cm camisole, size 12,
ends with four crossing pairs at the top of its side seam. Narrowed, it ends with none,
but its folded corner then holds that seam 5.2 mm open (1,416 s instead of 75 s, four
runs sharing two cores); the 1 cm long-sleeve shirt's underarm junction stayed 3.5 mm
open and still moving at the 30 min limit, and the 1 cm T-shirt ended with 5 crossing
pairs narrowed against 1 without (partners' partners in all these runs)."""
KIND_VT = 0
KIND_EE = 1
# the passes' status: bit 0, the list covered the step and no pair collides at its end;
# bit 1, a query overflowed the list (the step must be redone)
RESOLVED = 1
OVERFLOWED = 2


@ti.data_oriented
class SelfCollider:
    """Self-collision for a :class:`~sandbox.sim.model.Model`'s cloth.

    Args:
        model: the cloth model (triangles, inverse masses, seam pairs).
        thickness_m: h, the distance the cloth keeps from itself [m].
        friction: Coulomb coefficient μ between cloth layers.
        margin_m: the candidate list's extra reach [m] (default 2 h).
    """

    def __init__(self, model, *, thickness_m=2e-3, friction=0.3, margin_m=None):
        if not thickness_m > 0:
            raise SandboxError("self-collision: thickness must be positive")
        self.model = model
        n = model.particle_count
        tris = np.asarray(model.tri_indices_np, np.int64)
        e = np.sort(tris[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
        edges = np.unique(e, axis=0)
        self.edge_count = len(edges)
        self.edges_np = edges
        self.edge = ti.Vector.field(2, ti.i32, shape=max(1, len(edges)))
        self.edge.from_numpy(edges.astype(np.int32))
        rest = model.initial_positions_np
        self.margin0 = float(margin_m if margin_m is not None else 2.0 * thickness_m)

        # seam partners, CSR: the particles each particle is sewn to (and their mesh
        # neighbours). Pairs of them are never candidates: the seam joins them. Sized for
        # the model's seam capacity, so seams sewn live fit (set_seam_partners).
        self._ring = None
        degree = np.bincount(edges.ravel(), minlength=n) if len(edges) else np.zeros(n, int)
        # each sewn pair adds up to a ring per partner, partners' partners included
        room = 8 * model.seam_capacity * (int(degree.max(initial=0)) + 1)
        self.partner_start = ti.field(ti.i32, shape=n + 1)
        self.partner = ti.field(ti.i32, shape=max(1, room))
        # the edge-edge tests' list: the same as above, or with NARROW_EDGE_EXCLUSION only
        # the partners and the partners' partners (the other panels at a seam junction)
        self.ee_partner_start = ti.field(ti.i32, shape=n + 1)
        self.ee_partner = ti.field(ti.i32, shape=max(1, room))
        self.set_seam_partners(model.seam_pairs_np)

        self.thickness = ti.field(float, shape=())
        self.mu = ti.field(float, shape=())
        self.margin = ti.field(float, shape=())
        self.cell = ti.field(float, shape=())
        self.thickness[None] = thickness_m
        self.mu[None] = friction
        self.margin[None] = self.margin0
        self.mean_edge = float(np.linalg.norm(rest[edges[:, 0]] - rest[edges[:, 1]], axis=1).mean())

        # a dense grid over the cloth's bounding box, cells numbered row by row so that
        # the cells along z are consecutive; vertices by position, edges by midpoint (one
        # entry each). Its cell count is fixed here: a cloth spread wider gets larger cells.
        self.cell_capacity = max(1 << 12, CELLS_PER_ITEM * max(n, len(edges)))
        blocks = (self.cell_capacity + SCAN_BLOCK - 1) // SCAN_BLOCK
        self.grid_lo = ti.Vector.field(3, float, shape=())
        self.grid_hi = ti.Vector.field(3, float, shape=())
        self.grid_dims = ti.Vector.field(3, ti.i32, shape=())
        self.v_count = ti.field(ti.i32, shape=self.cell_capacity)
        self.v_start = ti.field(ti.i32, shape=self.cell_capacity + 1)
        self.v_block = ti.field(ti.i32, shape=blocks)
        self.v_entry = ti.field(ti.i32, shape=max(1, n))
        self.e_count = ti.field(ti.i32, shape=self.cell_capacity)
        self.e_start = ti.field(ti.i32, shape=self.cell_capacity + 1)
        self.e_block = ti.field(ti.i32, shape=blocks)
        self.e_entry = ti.field(ti.i32, shape=max(1, len(edges)))
        # the entries' end points, in entry order: a cell's edges are read from consecutive
        # memory by the queries' box tests
        self.e_p0 = ti.Vector.field(3, float, shape=max(1, len(edges)))
        self.e_p1 = ti.Vector.field(3, float, shape=max(1, len(edges)))
        self.half_edge = ti.field(float, shape=())

        self.capacity = PAIRS_PER_VERTEX * (n + len(edges)) + 1024
        self.pair = ti.Vector.field(4, ti.i32, shape=self.capacity)
        self.pair_kind = ti.field(ti.i32, shape=self.capacity)
        self.pair_hit = ti.field(ti.i32, shape=self.capacity)
        # the pairs closer than h at x(t), in list order (a draped sheet: ~0.3 % of them):
        # the serial impulse loop runs over these only
        self.near = ti.field(ti.i32, shape=self.capacity)
        self.near_block = ti.field(ti.i32, shape=(self.capacity + SCAN_BLOCK - 1) // SCAN_BLOCK)
        self.near_count = ti.field(ti.i32, shape=())
        self.hit_count = ti.field(ti.i32, shape=())  # pairs that may collide this step
        self.hit_fill = ti.field(ti.i32, shape=())  # the impact zones' copy of the marked pairs
        # each pair's geometry at x(t), computed in parallel at the start of the passes
        # (x does not change during them): weights W, closest-point vector d, |d|
        self.pair_w = ti.Vector.field(4, float, shape=self.capacity)
        self.pair_d = ti.Vector.field(3, float, shape=self.capacity)
        self.pair_dist = ti.field(float, shape=self.capacity)
        # each pair's distance at the list's build, and how far each vertex has moved since:
        # a pair whose features cannot have come within h skips the exact geometry
        self.pair_dist0 = ti.field(float, shape=self.capacity)
        self.moved = ti.field(float, shape=max(1, n))
        self.step_len = ti.field(float, shape=max(1, n))  # |dt (v + corr)| after pass 1 [m]
        self.fresh = ti.field(ti.i32, shape=())
        self.touched = ti.field(ti.i32, shape=max(1, n))  # got a CCD impulse this step
        self.pair_count = ti.field(ti.i32, shape=())
        self.overflow = ti.field(ti.i32, shape=())
        # the list in a fixed order (the parallel queries append in any order, and the
        # serial impulses depend on it): a counting sort by the pair's first feature (its
        # vertex, or its first edge's first end point), then by the rest within each
        keys = 2 * max(1, n)  # vertex keys below n, edge keys n + end point below 2n
        self.sort_count = ti.field(ti.i32, shape=keys)
        self.sort_start = ti.field(ti.i32, shape=keys + 1)
        self.sort_block = ti.field(ti.i32, shape=(keys + SCAN_BLOCK - 1) // SCAN_BLOCK)
        self.sort_pair = ti.Vector.field(4, ti.i32, shape=self.capacity)
        self.sort_kind = ti.field(ti.i32, shape=self.capacity)
        # a list built for one fast step holds the pairs that these displacements dt v [m]
        # (the velocities before the passes) could bring together
        self.build_step = ti.Vector.field(3, float, shape=max(1, n))
        self.excess = ti.field(float, shape=())

        self.x_build = ti.Vector.field(3, float, shape=max(1, n))
        # the partial refresh: the drifted vertices M, their own grid (vertices, and the
        # edges touching them, by midpoint), the positional common shift c
        self.marked = ti.field(ti.i32, shape=max(1, n))
        self.marked_count = ti.field(ti.i32, shape=())
        self.shift = ti.Vector.field(3, float, shape=())
        self.mv_count = ti.field(ti.i32, shape=self.cell_capacity)
        self.mv_start = ti.field(ti.i32, shape=self.cell_capacity + 1)
        self.mv_entry = ti.field(ti.i32, shape=max(1, n))
        self.me_count = ti.field(ti.i32, shape=self.cell_capacity)
        self.me_start = ti.field(ti.i32, shape=self.cell_capacity + 1)
        self.me_entry = ti.field(ti.i32, shape=max(1, len(edges)))
        self.me_p0 = ti.Vector.field(3, float, shape=max(1, len(edges)))
        self.me_p1 = ti.Vector.field(3, float, shape=max(1, len(edges)))
        self.sort_dist0 = ti.field(float, shape=self.capacity)
        self.keep_block = ti.field(ti.i32, shape=(self.capacity + SCAN_BLOCK - 1) // SCAN_BLOCK)
        self.refreshes = ti.field(ti.i32, shape=())
        self.corr = ti.Vector.field(3, float, shape=max(1, n))  # position correction [m/s]
        self.max_step = ti.field(float, shape=())
        self.mean_shift = ti.Vector.field(3, float, shape=())  # this step's mean dt v
        self.drift_mean = ti.Vector.field(3, float, shape=())
        self.swept = ti.field(ti.i32, shape=())
        self.sweep_scale = ti.field(float, shape=())  # 0: no swept pairs (after an overflow)
        self.sweep_scale[None] = 1.0
        self.overflow_steps = 0
        self.covered = ti.field(ti.i32, shape=())
        self.spread = ti.field(float, shape=())
        self.unresolved = ti.field(ti.i32, shape=())
        # counters since construction: rebuilds, CCD hits, steps that needed zones
        self.rebuilds = ti.field(ti.i32, shape=())
        self.ccd_hits = ti.field(ti.i64, shape=())
        self.zone_steps = 0
        self.needs_build = ti.field(ti.i32, shape=())
        self.needs_build[None] = 1

    def set_seam_partners(self, seam_pairs: np.ndarray | None, neighbours: bool = True) -> None:
        """Exclude the pairs joined by ``seam_pairs`` (k, 2) and, with ``neighbours``, their
        mesh neighbours: a vertex is not pushed away from the triangles that hold its seam
        partner (or one of the partner's neighbours). Partners' partners count as partners
        (where three panels meet, as at an underarm, the third panel's vertex is otherwise
        held a thickness away: 2 mm seam gaps at the 1 cm raglan top's underarms). Edge-edge
        pairs use the same list, or the partners alone with :data:`NARROW_EDGE_EXCLUSION`.

        The neighbours let a seam close: a vertex next to its partner's triangles would
        otherwise be held a thickness away from them. ``neighbours=False`` (used by the
        drape once the seams are closed if ``SEW_NARROW_EXCLUSION`` is set; off by
        default) keeps only the partners, so the panels next to a seam cannot pass through
        each other. Called at construction and whenever the seams change
        (set_seam_springs); the candidate list is rebuilt at the next step.
        """
        from sandbox.collision.metrics import seam_joined_pairs

        n = self.model.particle_count
        # a's partners and its partners' partners: at a junction of three panels (an
        # underarm) the third panel's vertex is sewn to a only through the second's
        j = seam_joined_pairs(seam_pairs, n)
        joined = _symmetric(j, n)
        near = joined
        if neighbours and len(j):
            if self._ring is None:  # mesh neighbours
                self._ring = _symmetric(self.edges_np, n)
            near = joined + joined @ self._ring
        edge_near = joined if NARROW_EDGE_EXCLUSION else near
        self._store_partners(near, self.partner_start, self.partner)
        self._store_partners(edge_near, self.ee_partner_start, self.ee_partner)
        if hasattr(self, "needs_build"):
            self.needs_build[None] = 1

    @staticmethod
    def _store_partners(near, start_field, flat_field) -> None:
        """Each particle's partners (a sparse (n, n) matrix's pattern), as CSR into two
        fields."""
        near = near.tocsr()
        near.sum_duplicates()
        near.sort_indices()
        start = near.indptr.astype(np.int64)
        flat = near.indices.astype(np.int64)
        if len(flat) > flat_field.shape[0]:
            raise SandboxError(f"self-collision: {len(flat)} seam exclusions exceed the room "
                               f"for {flat_field.shape[0]}")  # fmt: skip
        start_field.from_numpy(start.astype(np.int32))
        pad = np.zeros(flat_field.shape[0], np.int32)
        pad[: len(flat)] = flat
        flat_field.from_numpy(pad)

    # ------------------------------------------------------------------ grid helpers
    @ti.func
    def _cell_of(self, p):
        """The grid cell (i, j, k) holding point p [m] (outside the grid for far points)."""
        return ti.floor((p - self.grid_lo[None]) / self.cell[None], ti.i32)

    @ti.func
    def _cell_index(self, c):
        """Row-major number of cell c (clamped into the grid): cells (i, j, k..k') are
        consecutive."""
        dims = self.grid_dims[None]
        c = ti.max(ti.min(c, dims - 1), ti.Vector([0, 0, 0]))
        return (c[0] * dims[1] + c[1]) * dims[2] + c[2]

    @ti.func
    def _cell_range(self, box_lo, box_hi):
        """The cells [lo, hi] (inclusive) a box overlaps, clipped to the grid."""
        lo = ti.max(self._cell_of(box_lo), ti.Vector([0, 0, 0]))
        hi = ti.min(self._cell_of(box_hi), self.grid_dims[None] - 1)
        return lo, hi

    @ti.func
    def _fit_grid(self, x, cell):
        """Grid over the bounding box of x with cells of at least ``cell`` [m], enlarged
        until the cell count fits the allocation. Returns the cell count."""
        self.grid_lo[None] = ti.Vector([1e30, 1e30, 1e30])
        self.grid_hi[None] = ti.Vector([-1e30, -1e30, -1e30])
        for i in range(self.model.particle_count):
            ti.atomic_min(self.grid_lo[None], x[i])
            ti.atomic_max(self.grid_hi[None], x[i])
        # (counted in floats, and a cloth flung absurdly far still gets a grid that fits)
        extent = ti.min(self.grid_hi[None] - self.grid_lo[None], MAX_GRID_EXTENT_M)
        size = cell
        span = ti.floor(extent / size) + 1.0
        while span[0] * span[1] * span[2] > self.cell_capacity:
            size *= 1.25
            span = ti.floor(extent / size) + 1.0
        dims = ti.cast(span, ti.i32)
        self.cell[None] = size
        self.grid_dims[None] = dims
        return dims[0] * dims[1] * dims[2]

    @ti.func
    def _starts(self, count, start, block, cells):
        """start[c] = count[0] + ... + count[c-1] for c <= cells (count reset to 0).

        Parallel over blocks of SCAN_BLOCK cells, serial over the block sums.
        """
        blocks = (cells + SCAN_BLOCK - 1) // SCAN_BLOCK
        for b in range(blocks):
            total = 0
            for c in range(b * SCAN_BLOCK, ti.min((b + 1) * SCAN_BLOCK, cells)):
                total += count[c]
            block[b] = total
        ti.loop_config(serialize=True)
        for b in range(blocks):
            if b == 0:
                start[cells] = 0
            offset = start[cells]
            start[cells] = offset + block[b]
            block[b] = offset
        for b in range(blocks):
            offset = block[b]
            for c in range(b * SCAN_BLOCK, ti.min((b + 1) * SCAN_BLOCK, cells)):
                start[c] = offset
                offset += count[c]
                count[c] = 0

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
    def _edge_partners(self, a, b):
        """The same for edge-edge pairs (the partners alone with NARROW_EDGE_EXCLUSION)."""
        return self._listed(self.ee_partner_start, self.ee_partner, a, b)

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
            self._edge_partners(a[0], b[0]) or self._edge_partners(a[0], b[1])
            or self._edge_partners(a[1], b[0]) or self._edge_partners(a[1], b[1])
        )  # fmt: skip
        return shared or sewn

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

    @ti.func
    def _append(self, kind, idx):
        slot = ti.atomic_add(self.pair_count[None], 1)
        if slot < self.capacity:
            self.pair[slot] = idx
            self.pair_kind[slot] = kind
        else:
            self.overflow[None] = 1

    # ------------------------------------------------------------------ per-step pieces
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
    def prepare(self, x, v, dt):
        """Start of the contact passes: clear corrections, decide whether to rebuild.

        ``max_step`` becomes this step's largest displacement relative to the cloth's mean
        motion [m], the motion a rebuilt list must cover. ``needs_build`` becomes 1 (a full
        rebuild) or 2 (a partial refresh, :meth:`refresh`) when a vertex would leave the
        list's bound: a refresh when the step is slow and only the few vertices that
        drifted more than ``PARTIAL_TAU`` margins caused it.
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
        tau = PARTIAL_TAU * self.margin[None]
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
            grown = ti.max(self.margin0, ti.min(MARGIN_STEPS * self.max_step[None],
                                                MARGIN_EDGE_FRACTION * self.mean_edge))  # fmt: skip
            steady = ti.abs(grown - margin) <= 0.2 * margin  # a rebuild would keep it
            slow = 2.0 * self.max_step[None] <= 0.4 * margin and steady
            few = self.marked_count[None] <= PARTIAL_FRACTION * n
            if slow and few and self.marked_count[None] > 0:
                self.needs_build[None] = 2

    @ti.func
    def _motion(self, i, v, dt):
        """Particle i's displacement this step relative to the cloth's mean motion [m]."""
        return (dt * v[i] - self.mean_shift[None]).norm()

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
        grown = ti.min(MARGIN_STEPS * self.max_step[None], MARGIN_EDGE_FRACTION * self.mean_edge)
        self.margin[None] = ti.max(self.margin0, grown)
        reach = h + self.margin[None]
        # pairs that this very step's relative motion could bring together are kept too
        sweep_k = SWEEP_SAFETY * self.sweep_scale[None]
        fast = 2.0 * self.max_step[None] > 0.4 * self.margin[None]
        self.swept[None] = 1 if fast and sweep_k > 0.0 else 0
        query = reach + 2.0 * sweep_k * self.max_step[None]
        cells = self._fit_grid(x, CELL_SCALE * ti.max(self.mean_edge, reach))
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
    def _bin_vertices(self, x, cells):
        """The vertex grid: every vertex by its position (v_start, v_entry)."""
        for c in range(cells):
            self.v_count[c] = 0
        for i in range(self.model.particle_count):
            ti.atomic_add(self.v_count[self._cell_index(self._cell_of(x[i]))], 1)
        self._starts(self.v_count, self.v_start, self.v_block, cells)
        for i in range(self.model.particle_count):
            c = self._cell_index(self._cell_of(x[i]))
            self.v_entry[self.v_start[c] + ti.atomic_add(self.v_count[c], 1)] = i

    @ti.func
    def _edge_marked(self, e):
        return self.marked[self.edge[e][0]] + self.marked[self.edge[e][1]] > 0

    @ti.func
    def _drop_marked_pairs(self):
        """Remove the pairs with a marked vertex from the list, keeping the order (and
        each pair's ``pair_dist0``)."""
        count = ti.min(self.pair_count[None], self.capacity)
        blocks = (count + SCAN_BLOCK - 1) // SCAN_BLOCK
        for b in range(blocks):
            total = 0
            for p in range(b * SCAN_BLOCK, ti.min((b + 1) * SCAN_BLOCK, count)):
                idx = self.pair[p]
                mk = self.marked[idx[0]] + self.marked[idx[1]]
                if mk + self.marked[idx[2]] + self.marked[idx[3]] == 0:
                    total += 1
            self.keep_block[b] = total
        ti.loop_config(serialize=True)
        for b in range(blocks):
            if b == 0:
                self.pair_count[None] = 0
            offset = self.pair_count[None]
            self.pair_count[None] = offset + self.keep_block[b]
            self.keep_block[b] = offset
        for b in range(blocks):
            slot = self.keep_block[b]
            for p in range(b * SCAN_BLOCK, ti.min((b + 1) * SCAN_BLOCK, count)):
                idx = self.pair[p]
                mk = self.marked[idx[0]] + self.marked[idx[1]]
                if mk + self.marked[idx[2]] + self.marked[idx[3]] == 0:
                    self.sort_pair[slot] = idx
                    self.sort_kind[slot] = self.pair_kind[p]
                    self.sort_dist0[slot] = self.pair_dist0[p]
                    slot += 1
        for p in range(self.pair_count[None]):
            self.pair[p] = self.sort_pair[p]
            self.pair_kind[p] = self.sort_kind[p]
            self.pair_dist0[p] = self.sort_dist0[p]

    @ti.func
    def refresh(self, x, v, dt):
        """Partial refresh of the candidate list (``needs_build`` 2, a slow step): only the
        pairs with a marked vertex (one that drifted more than ``PARTIAL_TAU`` margins) are
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
        tau = PARTIAL_TAU * self.margin[None]
        reach = h + self.margin[None] + 2.0 * tau
        sweep_k = SWEEP_SAFETY * self.sweep_scale[None]
        query = reach + 2.0 * sweep_k * self.max_step[None]
        self._drop_marked_pairs()
        base = self.pair_count[None]
        cells = self._fit_grid(x, CELL_SCALE * ti.max(self.mean_edge, reach))
        self._bin_vertices(x, cells)
        # the marked vertices' grid, and the marked edges' (by midpoint)
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
    def _pair_key(self, kind, idx):
        """Sort key of a pair: its vertex (vertex-triangle), or n + its first edge's first
        end point (edge-edge)."""
        key = idx[0]
        if kind == KIND_EE:
            key = self.model.particle_count + idx[0]
        return key

    @ti.func
    def _before(self, a, ka, b, kb):
        """Is pair (ka, a) ordered before pair (kb, b)? Kind, then indices 0..3."""
        less = ka < kb
        if ka == kb:
            decided = False
            for k in ti.static(range(4)):
                if not decided and a[k] != b[k]:
                    less = a[k] < b[k]
                    decided = True
        return less

    @ti.func
    def _order_pairs(self):
        """Put the candidate list in a fixed order, whatever order the threads appended
        in (so the same run gives the same result): counting sort by :meth:`_pair_key`,
        then insertion sort within each key."""
        count = ti.min(self.pair_count[None], self.capacity)
        keys = self.sort_count.shape[0]
        for k in range(keys):
            self.sort_count[k] = 0
        for p in range(count):
            ti.atomic_add(self.sort_count[self._pair_key(self.pair_kind[p], self.pair[p])], 1)
        self._starts(self.sort_count, self.sort_start, self.sort_block, keys)
        for p in range(count):
            k = self._pair_key(self.pair_kind[p], self.pair[p])
            slot = self.sort_start[k] + ti.atomic_add(self.sort_count[k], 1)
            self.sort_pair[slot] = self.pair[p]
            self.sort_kind[slot] = self.pair_kind[p]
            self.sort_dist0[slot] = self.pair_dist0[p]
        for k in range(keys):
            lo, hi = self.sort_start[k], self.sort_start[k + 1]
            for i in range(lo, hi):  # insertion sort of the (few) pairs of this key
                j = i
                moving = True
                while moving:  # (Taichi evaluates both sides of ``and``: j - 1 >= lo here)
                    moving = False
                    if j > lo:
                        a, ka = self.sort_pair[j], self.sort_kind[j]
                        b, kb = self.sort_pair[j - 1], self.sort_kind[j - 1]
                        if self._before(a, ka, b, kb):
                            self.sort_pair[j], self.sort_kind[j] = b, kb
                            self.sort_pair[j - 1], self.sort_kind[j - 1] = a, ka
                            da, db = self.sort_dist0[j], self.sort_dist0[j - 1]
                            self.sort_dist0[j], self.sort_dist0[j - 1] = db, da
                            j -= 1
                            moving = True
            for i in range(lo, hi):
                self.pair[i] = self.sort_pair[i]
                self.pair_kind[i] = self.sort_kind[i]
                self.pair_dist0[i] = self.sort_dist0[i]

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
                            extra = SEPARATION_FRACTION * (h - dist) - dt * ti.max(vn + dvn, 0.0)
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
            while remaining > 0 and passes < CCD_PASSES and dt > 0.0:
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
                            gap = ti.min(CCD_GAP_FRACTION * h, 0.5 * g0)
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

    # ------------------------------------------------------------------ Python side
    @ti.kernel
    def _prepare_kernel(self, x: ti.template(), v: ti.template(), dt: float) -> ti.i32:
        self.prepare(x, v, dt)
        return self.needs_build[None]

    @ti.func
    def passes(self, x, v, dt):
        """Passes 1 and 2; returns the status (``RESOLVED``, ``OVERFLOWED`` bits)."""
        self.proximity(x, v, dt)
        self.continuous(x, v, dt)
        status = OVERFLOWED * self.overflow[None]
        if self.unresolved[None] == 0 and self.covered[None] == 1:
            status += RESOLVED
        return status

    @ti.kernel
    def _passes_kernel(self, x: ti.template(), v: ti.template(), dt: float) -> ti.i32:
        return self.passes(x, v, dt)

    def build_list(self, x, v, dt: float, build: int) -> None:
        """Rebuild (``build`` 1) or refresh (2) the candidate list, as ``prepare`` said."""
        if build == 1:
            self._rebuild_kernel(x, v, dt)
        elif build == 2:
            self._refresh_kernel(x, v, dt)

    def _respond_kernel(self, x, v, dt: float) -> int:
        """The kernels of one response: prepare, rebuild or refresh if needed, the passes.
        Returns the passes' status."""
        self.build_list(x, v, dt, self._prepare_kernel(x, v, dt))
        return int(self._passes_kernel(x, v, dt))

    @ti.kernel
    def _rebuild_kernel(self, x: ti.template(), v: ti.template(), dt: float):
        self.rebuild(x, v, dt)

    @ti.kernel
    def _refresh_kernel(self, x: ti.template(), v: ti.template(), dt: float):
        self.refresh(x, v, dt)

    @ti.kernel
    def _mark_kernel(self, x: ti.template(), v: ti.template(), dt: float) -> ti.i32:
        hits = 0
        for p in range(ti.min(self.pair_count[None], self.capacity)):
            hit, W, n, g0 = self._collision(self.pair_kind[p], self.pair[p], x, v, dt)
            self.pair_hit[p] = 1 if hit else 0
            if hit:
                hits += 1
        return hits

    def warm_up(self, x, v) -> None:
        """Compile the kernels a run reaches only now and then (the partial refresh, the
        fallbacks), so neither a scripted run's timing nor a live window stalls on them
        mid-run. The list, its build positions and the velocities are put back as they
        were, so a run takes the same path with or without it."""
        fields = (self.pair, self.pair_kind, self.pair_dist0, self.x_build, v)
        saved = [f.to_numpy() for f in fields]
        scalars = (self.pair_count, self.needs_build, self.fresh, self.margin, self.swept,
                   self.refreshes, self.rebuilds, self.overflow)  # fmt: skip
        saved_scalars = [f[None] for f in scalars]
        self._prepare_kernel(x, v, 0.0)
        self._refresh_kernel(x, v, 0.0)
        self._passes_kernel(x, v, 0.0)
        self._mark_kernel(x, v, 0.0)
        for f, a in zip(fields, saved, strict=True):
            f.from_numpy(a)
        for f, a in zip(scalars, saved_scalars, strict=True):
            f[None] = a

    def check_capacity(self):
        if self.overflow[None]:
            raise SandboxError(
                f"self-collision: more than {self.capacity} candidate pairs; the cloth is "
                "crumpled far beyond its thickness (lower margin_m or check the start shape)"
            )

    def resolve(self, state_x, state_v, dt: float, status: int | None = None) -> None:
        """Python driver for one step's response (used when steps are launched one by
        one). ``status``: that of a first response the caller already ran (the explicit
        solver runs it in its own kernels), else it is run here."""
        if status is None:
            status = self._respond_kernel(state_x, state_v, dt)
        if status & OVERFLOWED:
            # a violent step (e.g. a crumpling hem) swept more pairs than the list holds:
            # redo it with the resting list only; CCD and the impact zones still run
            self.overflow_steps += 1
            self.overflow[None] = 0
            self.needs_build[None] = 1
            self.sweep_scale[None] = 0.0
            status = self._respond_kernel(state_x, state_v, dt)
            self.sweep_scale[None] = 1.0
            if status & OVERFLOWED:
                self.check_capacity()
        tries = 0
        while not status & RESOLVED and self.needs_build[None] and tries < 2:
            tries += 1  # the impulses moved a vertex beyond the list's reach: rebuild
            status = self._respond_kernel(state_x, state_v, dt)
            if status & OVERFLOWED:
                self.check_capacity()
        if not status & RESOLVED:
            self.resolve_zones(state_x, state_v, dt)

    def resolve_zones(self, state_x, state_v, dt: float) -> None:
        """Rigid impact zones (Bridson et al. 2002 §7.4) until no candidate pair collides.

        Each round marks the pairs that still collide; a zone is a connected component of the
        vertices of all the pairs marked so far (this step), and moves rigidly with its
        linear and angular momentum (:func:`_rigid_velocities`). Only the marked pairs are
        copied out of Taichi, and the zones are found and moved with whole-array numpy:
        at 1 cm a sleeve cap sewn over the bodice can need this fallback at every step.
        """
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components

        model = self.model
        n = model.particle_count
        inv_m = model.particle_inv_mass.to_numpy()[:n].astype(np.float64)
        mass = model.particle_mass.to_numpy()[:n].astype(np.float64)
        in_zone = np.zeros(n, bool)
        marked = []  # the quads of every round's colliding pairs
        ftype = runtime.float_dtype()
        x = state_x.to_numpy()[:n].astype(np.float64)
        for _ in range(ZONE_ROUNDS):
            hits = self._mark_kernel(state_x, state_v, dt)
            if hits == 0:
                return
            if not in_zone.any():
                self.zone_steps += 1
            quads = np.zeros((hits, 4), np.int32)
            self.hit_fill[None] = 0
            self._marked_quads_kernel(quads)
            marked.append(quads)
            in_zone[quads.ravel()] = True
            q = np.concatenate(marked)
            rows, cols = np.repeat(q[:, 0], 3), q[:, 1:].ravel()
            links = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
            _, zone = connected_components(links, directed=False)
            members = np.nonzero(in_zone)[0]
            v = state_v.to_numpy()[:n].astype(np.float64)
            corr = self.corr.to_numpy()[:n].astype(np.float64)
            v_eff = v[members] + corr[members]
            v[members] = _rigid_velocities(x[members], v_eff, mass[members], inv_m[members],
                                           zone[members])  # fmt: skip
            corr[members] = 0.0
            state_v.from_numpy(v.astype(ftype))
            self.corr.from_numpy(corr.astype(ftype))
        raise SandboxError("self-collision: rigid impact zones did not resolve the step")

    @ti.kernel
    def _marked_quads_kernel(self, out: ti.types.ndarray()):
        """out (hits, 4) := the vertices of the pairs :meth:`_mark_kernel` marked (any order)."""
        for p in range(ti.min(self.pair_count[None], self.capacity)):
            if self.pair_hit[p]:
                k = ti.atomic_add(self.hit_fill[None], 1)
                q = self.pair[p]
                for j in ti.static(range(4)):
                    out[k, j] = q[j]


def _rigid_velocities(x, v, m, inv_m, zone):
    """Velocities (k, 3) of rigid motions keeping each zone's linear and angular momentum.

    ``x``, ``v`` (k, 3) positions [m] and velocities [m/s] of the zones' vertices, ``m``,
    ``inv_m`` (k,) their masses [kg] and inverse masses, ``zone`` (k,) their zone labels.
    A zone's velocity is v_c + ω × (x − x_c), with x_c, v_c its centre of mass and its
    velocity, and ω = I⁻¹ L (the pseudo-inverse for a zone whose vertices lie on a line). A
    zone holding a pinned vertex (inverse mass 0) stands still.
    """
    _, z = np.unique(zone, return_inverse=True)
    nz = int(z.max()) + 1

    def per_zone(values):  # sums per zone of the columns of values (k, c) -> (nz, c)
        return np.stack([np.bincount(z, values[:, c], nz) for c in range(values.shape[1])], 1)

    mt = np.bincount(z, m, nz)
    xc = per_zone(m[:, None] * x) / mt[:, None]
    vc = per_zone(m[:, None] * v) / mt[:, None]
    r = x - xc[z]
    angular = per_zone(m[:, None] * np.cross(r, v - vc[z]))
    outer = per_zone((m[:, None, None] * r[:, :, None] * r[:, None, :]).reshape(-1, 9))
    outer = outer.reshape(nz, 3, 3)
    inertia = np.trace(outer, axis1=1, axis2=2)[:, None, None] * np.eye(3) - outer
    w = np.einsum("zij,zj->zi", np.linalg.pinv(inertia), angular)
    out = vc[z] + np.cross(w[z], r)
    out[(np.bincount(z, inv_m == 0, nz) > 0)[z]] = 0.0
    return out


def _symmetric(pairs, n: int):
    """The symmetric (n, n) sparse pattern of vertex pairs (k, 2)."""
    import scipy.sparse as sp

    p = np.asarray(pairs, np.int64).reshape(-1, 2)
    rows, cols = np.r_[p[:, 0], p[:, 1]], np.r_[p[:, 1], p[:, 0]]
    return sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
