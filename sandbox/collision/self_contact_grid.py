"""The self-collision candidate list's data structures: a dense grid and a fixed pair order.

A dense grid over the cloth's bounding box, cells numbered row by row so that the cells
along z are consecutive; items are counted per cell, offset by a parallel prefix sum
(blocks of ``SCAN_BLOCK``) and filled. The candidate pairs are then put in a fixed order
(counting sort by their first feature, insertion sort within), so the same run gives the
same result whatever order the threads appended in.

A mixin of :class:`sandbox.collision.self_contact.SelfCollider` (its fields and settings).
"""

import taichi as ti

from sandbox.collision.self_contact_config import KIND_EE, SCAN_BLOCK


class PairGrid:
    """Grid cells, prefix sums, binning, and the list's order."""

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
        extent = ti.min(self.grid_hi[None] - self.grid_lo[None], self.config.max_grid_extent_m)
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
