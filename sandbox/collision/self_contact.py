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
   pass repeats until no pair collides, at most ``ccd_passes`` times.
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

This module holds :class:`SelfCollider`: its fields, the seam exclusions and the launch
order of a step's response. The work is in its mixins: the grid and the list's order
(:mod:`~sandbox.collision.self_contact_grid`), the pair queries
(:mod:`~sandbox.collision.self_contact_queries`), the list's rebuild and refresh
(:mod:`~sandbox.collision.self_contact_list`), passes 1 and 2
(:mod:`~sandbox.collision.self_contact_passes`) and the impact zones
(:mod:`~sandbox.collision.self_contact_zones`); the tunables are one
:class:`~sandbox.collision.self_contact_config.SelfContactConfig`.
"""

import numpy as np
import taichi as ti

from sandbox.collision.self_contact_config import (
    OVERFLOWED,
    RESOLVED,
    SCAN_BLOCK,
    SelfContactConfig,
)
from sandbox.collision.self_contact_grid import PairGrid
from sandbox.collision.self_contact_list import CandidateList
from sandbox.collision.self_contact_passes import ContactPasses
from sandbox.collision.self_contact_queries import PairQueries
from sandbox.collision.self_contact_zones import ImpactZones
from sandbox.errors import SandboxError

DEFAULT_CONFIG = SelfContactConfig()


@ti.data_oriented
class SelfCollider(PairGrid, PairQueries, CandidateList, ContactPasses, ImpactZones):
    """Self-collision for a :class:`~sandbox.sim.model.Model`'s cloth.

    Args:
        model: the cloth model (triangles, inverse masses, seam pairs).
        thickness_m: h, the distance the cloth keeps from itself [m].
        friction: Coulomb coefficient μ between cloth layers.
        margin_m: the candidate list's extra reach [m] (default 2 h).
        config: the passes' and the list's tunables (:class:`SelfContactConfig`).
    """

    def __init__(self, model, *, thickness_m=2e-3, friction=0.3, margin_m=None,
                 config: SelfContactConfig = DEFAULT_CONFIG):  # fmt: skip
        if not thickness_m > 0:
            raise SandboxError("self-collision: thickness must be positive")
        self.model = model
        self.config = config
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
        self.needs_build = ti.field(ti.i32, shape=())  # 1: rebuild, 2: refresh the list
        self.set_seam_partners(model.seam_pairs_np)  # sets needs_build

        self.thickness = ti.field(float, shape=())
        self.mu = ti.field(float, shape=())
        self.margin = ti.field(float, shape=())
        self.cell = ti.field(float, shape=())
        self.thickness[None] = thickness_m
        self.mu[None] = friction
        self.margin[None] = self.margin0
        self.mean_edge = float(np.linalg.norm(rest[edges[:, 0]] - rest[edges[:, 1]], axis=1).mean())

        self._allocate_grid(n, len(edges))
        self._allocate_list(n, len(edges))
        self._allocate_step(n, len(edges))

    def _allocate_grid(self, n: int, edge_count: int) -> None:
        # a dense grid over the cloth's bounding box, cells numbered row by row so that
        # the cells along z are consecutive; vertices by position, edges by midpoint (one
        # entry each). Its cell count is fixed here: a cloth spread wider gets larger cells.
        self.cell_capacity = max(1 << 12, self.config.cells_per_item * max(n, edge_count))
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
        self.e_entry = ti.field(ti.i32, shape=max(1, edge_count))
        # the entries' end points, in entry order: a cell's edges are read from consecutive
        # memory by the queries' box tests
        self.e_p0 = ti.Vector.field(3, float, shape=max(1, edge_count))
        self.e_p1 = ti.Vector.field(3, float, shape=max(1, edge_count))
        self.half_edge = ti.field(float, shape=())

    def _allocate_list(self, n: int, edge_count: int) -> None:
        self.capacity = self.config.pairs_per_vertex * (n + edge_count) + 1024
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

    def _allocate_step(self, n: int, edge_count: int) -> None:
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
        self.me_entry = ti.field(ti.i32, shape=max(1, edge_count))
        self.me_p0 = ti.Vector.field(3, float, shape=max(1, edge_count))
        self.me_p1 = ti.Vector.field(3, float, shape=max(1, edge_count))
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
        self.freeze_steps = 0  # steps whose impact zones were stopped (self_contact_zones)
        self.frozen_vertices_max = 0
        self.touching_at_start = 0  # pairs left touching by a stopped step

    def set_seam_partners(self, seam_pairs: np.ndarray | None, neighbours: bool = True) -> None:
        """Exclude the pairs joined by ``seam_pairs`` (k, 2) and, with ``neighbours``, their
        mesh neighbours: a vertex is not pushed away from the triangles that hold its seam
        partner (or one of the partner's neighbours). Partners' partners count as partners
        (where three panels meet, as at an underarm, the third panel's vertex is otherwise
        held a thickness away: 2 mm seam gaps at the 1 cm raglan top's underarms), and
        theirs too (four panels sewn in a chain, as a hood's halves and the two fronts at
        the front neck, whose corners otherwise fought the seams and kept the hood
        trembling). Edge-edge
        pairs use the same list (the partners alone left the 1 cm shirts' seams open where
        a panel's folded corner held them, docs/drape.md).

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
        self._store_partners(near, self.partner_start, self.partner)
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

    @ti.func
    def passes(self, x, v, dt):
        """Passes 1 and 2; returns the status (``RESOLVED``, ``OVERFLOWED`` bits)."""
        self.proximity(x, v, dt)
        self.continuous(x, v, dt)
        status = OVERFLOWED * self.overflow[None]
        if self.unresolved[None] == 0 and self.covered[None] == 1:
            status += RESOLVED
        return status

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
    def _prepare_kernel(self, x: ti.template(), v: ti.template(), dt: float) -> ti.i32:
        self.prepare(x, v, dt)
        return self.needs_build[None]

    @ti.kernel
    def _passes_kernel(self, x: ti.template(), v: ti.template(), dt: float) -> ti.i32:
        return self.passes(x, v, dt)

    @ti.kernel
    def _rebuild_kernel(self, x: ti.template(), v: ti.template(), dt: float):
        self.rebuild(x, v, dt)

    @ti.kernel
    def _refresh_kernel(self, x: ti.template(), v: ti.template(), dt: float):
        self.refresh(x, v, dt)

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


def _symmetric(pairs, n: int):
    """The symmetric (n, n) sparse pattern of vertex pairs (k, 2)."""
    import scipy.sparse as sp

    p = np.asarray(pairs, np.int64).reshape(-1, 2)
    rows, cols = np.r_[p[:, 0], p[:, 1]], np.r_[p[:, 1], p[:, 0]]
    return sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
