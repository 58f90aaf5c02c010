"""Cloth against rigid bodies, after Bridson, Fedkiw and Anderson (2002), paper §2.5.

The body is a triangle mesh (the mannequin or any collider) held in a uniform grid that is
rebuilt in Taichi whenever the body moves or is resized (a slider). After the explicit
velocity update of Eq. 2 each free vertex is checked twice, before its position update:

1. **Continuous detection.** If the segment x(t) -> x(t) + dt·v(t+dt) crosses a body
   triangle, the velocity is cut so that the vertex stops ``thickness`` in front of it.
   Nothing passes through, at any speed or dt.
2. **Proximity.** If the predicted position is closer than ``thickness`` to the body (or
   behind it), an inelastic normal impulse brings it back to the thickness, and Coulomb
   friction acts on the tangential velocity: the vertex sticks if |v_t| <= μ_s Δv_n,
   otherwise v_t loses μ_k Δv_n. The part of the normal change that only restores the
   thickness moves the vertex this step and is then dropped (:meth:`respond_split`).

Thickness [m], friction coefficients and the body's vertex positions live in fields, so a
UI can change them between steps. Capacities are fixed at construction.
"""

import math

import numpy as np
import taichi as ti

from sandbox.collision.primitives import point_triangle_closest
from sandbox.errors import SandboxError

MAX_CELLS_PER_QUERY = 512
NEAREST_REACH_CELLS = (round(MAX_CELLS_PER_QUERY ** (1.0 / 3.0)) - 2) / 2
"""A nearest-face query (:meth:`BodyCollider.contact_planes`) reaches at most this many cells
[cell sizes]: its box then spans at most 8 cells an axis, 512 in all, so it is searched
whole. A box searched only in its first 512 cells (lowest x first) can return a face on the
body's far side: a vertex 5 mm outside a shrunk sphere (the stability report's x0.7 resize
row; reach 2 cm + twice the step's predicted move) would take it as its plane and be lifted
1-2.3 cm."""
# Triangles are binned with their box grown by this many thicknesses h. A vertex whose
# step |x1 - x| is at most that pad finds, in the one cell of its end point x1, every
# triangle within h of x1 and every triangle its step crosses (the crossing point is within
# |x1 - x| of x1): one cell, each triangle once, instead of the cells of its box.
TIE_M = 1e-12
"""Two triangles whose closest points to a vertex are this close in distance [m] tie (they
share the closest point: an edge or a corner); see :meth:`BodyCollider.respond_split`."""
BIN_PAD_THICKNESSES = 2.0
NEAR_FIRST_CELLS = 0.5
"""A nearest-face query looks first within this many cell sizes of the point (a box of at
most 2 cells an axis) and searches its whole reach only when no face is that near: a face
found there is the nearest within any larger reach too, since every face within a
distance d of the point is binned in a cell of the point's box of half-width d. Cloth
lying on the body finds its face in the first look (the sheath dress at 1.5 cm, 1/60 s
steps: its contact planes 30.0 -> 27.2 ms a step; most of its vertices hang farther)."""
CREASE_COS = 0.98
"""Two faces meet in a crease (:meth:`BodyCollider.contact_planes`) when their normals
differ by more than this cosine (11°); flatter neighbours share the nearest face's plane."""


@ti.data_oriented
class BodyCollider:
    """A triangle mesh collider with its uniform-grid acceleration structure.

    Args:
        vertices: (m, 3) body vertices [m]. triangles: (k, 3) indices, outward-facing
        (counter-clockwise seen from outside). thickness_m: cloth thickness/proximity
        distance. friction_static, friction_kinetic: Coulomb coefficients. closed: the
        mesh bounds a solid, so cloth is always pushed to the outside of its faces (this
        also frees a vertex less than ``thickness`` inside; cloth must start outside);
        an open mesh (a plane, a single surface)
        pushes each vertex back to the side it came from. face_pass: also keep the body's
        vertices under the cloth's triangles (closed bodies; see :meth:`poke`), so a coarse
        cloth does not let the body show through its faces. Off by default: on garments it
        keeps the cloth jittering (docs/self_collision.md).
    """

    def __init__(
        self,
        vertices: np.ndarray,
        triangles: np.ndarray,
        *,
        thickness_m: float = 2e-3,
        friction_static: float = 0.4,
        friction_kinetic: float = 0.3,
        name: str = "body",
        closed: bool = True,
        face_pass: bool = False,
    ):
        v = np.asarray(vertices, dtype=np.float64)
        t = np.asarray(triangles, dtype=np.int64)
        if v.ndim != 2 or v.shape[1] != 3 or len(v) < 3:
            raise SandboxError(f"collider {name!r}: vertices must have shape (m, 3)")
        if t.ndim != 2 or t.shape[1] != 3 or len(t) == 0:
            raise SandboxError(f"collider {name!r}: triangles must have shape (k, 3), k > 0")
        if t.min() < 0 or t.max() >= len(v):
            raise SandboxError(f"collider {name!r}: a triangle refers to a missing vertex")
        if not np.isfinite(v).all():
            raise SandboxError(f"collider {name!r}: vertices contain NaN or infinity")
        self.name = name
        self.closed = closed
        # body vertices against cloth triangles (BodyCollider.poke): opt-in, closed bodies
        self.face_pass = bool(face_pass and closed)
        self.vertex_count = len(v)
        self.tri_count = len(t)
        self.triangles_np = t
        self.body_x = ti.Vector.field(3, float, shape=len(v))
        self.tri = ti.Vector.field(3, ti.i32, shape=len(t))
        self.tri_normal = ti.Vector.field(3, float, shape=len(t))  # unit, outward
        self.tri_offset = ti.field(float, shape=len(t))  # n·a: plane n·x = offset
        self.tri_centre = ti.Vector.field(3, float, shape=len(t))  # bounding sphere
        self.tri_radius = ti.field(float, shape=len(t))
        self.tri.from_numpy(t.astype(np.int32))
        self.thickness = ti.field(float, shape=())
        self.mu_s = ti.field(float, shape=())
        self.mu_k = ti.field(float, shape=())
        self.thickness[None] = thickness_m
        # the thickness added over convex creases for the cloth that drapes (follow_cloth)
        self.vert_extra = ti.field(float, shape=len(v))  # per body vertex [m]
        self.tri_extra = ti.field(float, shape=len(t))  # the largest of a face's corners
        self.extra_max = ti.field(float, shape=())
        self.cloth_edge_m = 0.0
        self._adjacency = None  # the faces' edge adjacency, made once (crease_adjacency)
        self._crease_extra = None  # follow_cloth's thickness per body vertex, without cover
        self.cover_depth_m = 0.0  # how deep the body showed through at the last cover [m]
        self.generation = ti.field(ti.i32, shape=())
        """How many times the body has changed (:meth:`update`): what solvers that keep
        per-vertex contact queries compare to know they are still valid."""
        self.mu_s[None] = friction_static
        self.mu_k[None] = friction_kinetic
        # grid: cell size near the mean edge length, dims fixed from the first bounds
        edges = np.linalg.norm(v[t[:, [1, 2, 0]]] - v[t], axis=2)
        self.cell_size_init = float(max(edges.mean(), 4 * thickness_m))
        self.extent_init = float(np.ptp(v, axis=0).max())
        span = np.ptp(v, axis=0) * 1.6 + 8 * self.cell_size_init
        self.dims = tuple(int(min(256, max(1, math.ceil(s / self.cell_size_init)))) for s in span)
        n_cells = self.dims[0] * self.dims[1] * self.dims[2]
        self.origin = ti.Vector.field(3, float, shape=())
        self.cell_size = ti.field(float, shape=())
        self.cell_start = ti.field(ti.i32, shape=n_cells + 1)
        self.cell_fill = ti.field(ti.i32, shape=n_cells)
        self.entry_capacity = int(len(t) * 80 + 4096)
        self.cell_entries = ti.field(ti.i32, shape=self.entry_capacity)
        self.overflow = ti.field(ti.i32, shape=())
        self.bin_pad = ti.field(float, shape=())  # the triangles' box growth at the build [m]
        # body vertices, one grid entry each, with area-weighted outward normals: the
        # face pass (body vertices against cloth triangles) of a closed body
        self.vertex_normal = ti.Vector.field(3, float, shape=len(v))
        self.v_cell_start = ti.field(ti.i32, shape=n_cells + 1)
        self.v_cell_fill = ti.field(ti.i32, shape=n_cells)
        self.v_entries = ti.field(ti.i32, shape=len(v))
        self.update(v)

    # ------------------------------------------------------------------ build
    def update(self, vertices: np.ndarray) -> None:
        """New body vertex positions (same topology), e.g. after a resize; rebuilds the grid."""
        v = np.asarray(vertices, dtype=np.float64)
        if v.shape != (self.vertex_count, 3):
            raise SandboxError(f"collider {self.name!r}: expected {self.vertex_count} vertices")
        from sandbox import runtime

        self.body_x.from_numpy(v.astype(runtime.float_dtype()))
        self.generation[None] += 1
        lo, hi = v.min(axis=0), v.max(axis=0)
        ratio = float(np.ptp(v, axis=0).max()) / max(self.extent_init, 1e-12)
        size = max(self.cell_size_init * ratio, float(((hi - lo) / np.array(self.dims)).max()))
        centre = 0.5 * (lo + hi)
        self.origin[None] = ti.Vector(list(centre - 0.5 * size * np.array(self.dims)))
        self.cell_size[None] = float(size)
        self.overflow[None] = 0
        self._build()
        if self.overflow[None]:
            raise SandboxError(f"collider {self.name!r}: grid entry capacity exceeded")

    def follow_cloth(self, cloth_edge_m: float) -> None:
        """Thicken the contact over the body's convex creases for a cloth of mean edge
        ``cloth_edge_m`` [m], so its straight edges pass over them
        (:func:`sandbox.collision.crease.crease_thickness`). The thickness belongs to the
        body's vertices: :meth:`update` (a resize, 40 ms for the window's slider) carries it
        to the new shape without recomputing it (70–240 ms on the mannequin)."""
        self.cloth_edge_m = float(cloth_edge_m)
        self._write_extra(self.body_x.to_numpy().astype(np.float64))
        self.update(self.body_x.to_numpy().astype(np.float64))  # the grid, binned wider

    def cover(self, cloth_x: np.ndarray, cloth_triangles: np.ndarray) -> int:
        """Thicken the contact where the body shows through the cloth (``cloth_x`` (n, 3)
        [m], ``cloth_triangles`` (k, 3)), by how far it shows plus a quarter of the
        thickness, over a cloth edge span around it
        (:func:`sandbox.collision.crease.cover_thickness`; needs :meth:`follow_cloth`).
        Returns the number of body vertices that showed (0: nothing changed), and keeps the
        deepest in ``cover_depth_m`` [m]. The
        thickness only grows and belongs to the body's vertices, as the crease thickness,
        until :meth:`uncover`; about 20-45 ms a call on the mannequin, a grid rebuild included
        when it grows (``benchmarks/bench_gui.py``)."""
        from sandbox.collision.body_probe import through_cloth_depth
        from sandbox.collision.crease import cover_thickness

        if not self.closed or self.cloth_edge_m <= 0.0:
            return 0
        v = self.body_x.to_numpy().astype(np.float64)
        depth = through_cloth_depth(cloth_x, cloth_triangles, v, self.triangles_np)
        shows = int(np.count_nonzero(depth > 0.0))
        self.cover_depth_m = float(depth.max(initial=0.0))
        if shows:
            extra = cover_thickness(v, self.vert_extra.to_numpy().astype(np.float64), depth,
                                    self.cloth_edge_m, 0.25 * self.thickness[None])  # fmt: skip
            self._set_extra(extra)
            self.update(v)  # the grid, binned wider
        return shows

    def uncover(self) -> None:
        """Back to the crease thickness alone (:meth:`follow_cloth`), dropping what
        :meth:`cover` added; takes effect at the next :meth:`update` (its grid)."""
        if self._crease_extra is not None:
            self._set_extra(self._crease_extra)

    def _write_extra(self, v: np.ndarray) -> None:
        from sandbox.collision.crease import crease_adjacency, crease_thickness

        if self._adjacency is None:
            self._adjacency = crease_adjacency(self.triangles_np)
        self._crease_extra = crease_thickness(v, self.triangles_np, self.cloth_edge_m,
                                              self.thickness[None], self._adjacency)  # fmt: skip
        self._set_extra(self._crease_extra)

    def _set_extra(self, extra: np.ndarray) -> None:
        self.vert_extra.from_numpy(extra)
        self.tri_extra.from_numpy(extra[self.triangles_np].max(axis=1))
        self.extra_max[None] = float(extra.max())

    @ti.func
    def _extra_at(self, t, q):
        """The crease thickness [m] at point q of face t, interpolated from its corners."""
        out = 0.0
        if self.tri_extra[t] > 0.0:
            tv = self.tri[t]
            w = _barycentric(q, self.body_x[tv[0]], self.body_x[tv[1]], self.body_x[tv[2]])
            w = ti.max(w, 0.0)
            if w.sum() > 0.0:  # False for NaN: a degenerate face takes its largest
                w = w / w.sum()
                out = (w[0] * self.vert_extra[tv[0]] + w[1] * self.vert_extra[tv[1]]
                       + w[2] * self.vert_extra[tv[2]])  # fmt: skip
            else:
                out = self.tri_extra[t]
        return out

    @ti.func
    def _cell_of(self, p):
        c = ti.floor((p - self.origin[None]) / self.cell_size[None], ti.i32)
        return ti.math.clamp(c, 0, ti.Vector(self.dims) - 1)

    @ti.func
    def _cell_index(self, c):
        return (c[0] * self.dims[1] + c[1]) * self.dims[2] + c[2]

    @ti.kernel
    def _build(self):
        for t in self.tri:
            a, b, c = (
                self.body_x[self.tri[t][0]],
                self.body_x[self.tri[t][1]],
                self.body_x[self.tri[t][2]],
            )
            n = (b - a).cross(c - a)
            self.tri_normal[t] = n / ti.max(n.norm(), 1e-30)
            self.tri_offset[t] = self.tri_normal[t].dot(a)
            g = (a + b + c) / 3.0
            self.tri_centre[t] = g
            self.tri_radius[t] = ti.max((a - g).norm(), (b - g).norm(), (c - g).norm())
        for c in self.cell_fill:
            self.cell_fill[c] = 0
        pad = BIN_PAD_THICKNESSES * self.thickness[None]
        self.bin_pad[None] = pad
        # a face with a crease thickness is binned that much wider, so one cell still holds
        # every face within its own thickness of a point in it
        for t in self.tri:
            a, b, c = (
                self.body_x[self.tri[t][0]],
                self.body_x[self.tri[t][1]],
                self.body_x[self.tri[t][2]],
            )
            lo = self._cell_of(ti.min(a, b, c) - pad - self.tri_extra[t])
            hi = self._cell_of(ti.max(a, b, c) + pad + self.tri_extra[t])
            for i in range(lo[0], hi[0] + 1):
                for j in range(lo[1], hi[1] + 1):
                    for k in range(lo[2], hi[2] + 1):
                        ti.atomic_add(self.cell_fill[self._cell_index(ti.Vector([i, j, k]))], 1)
        ti.loop_config(serialize=True)
        for c in range(self.cell_fill.shape[0]):
            if c == 0:
                self.cell_start[0] = 0
            self.cell_start[c + 1] = self.cell_start[c] + self.cell_fill[c]
            self.cell_fill[c] = 0
        for t in self.tri:
            a, b, c = (
                self.body_x[self.tri[t][0]],
                self.body_x[self.tri[t][1]],
                self.body_x[self.tri[t][2]],
            )
            lo = self._cell_of(ti.min(a, b, c) - pad - self.tri_extra[t])
            hi = self._cell_of(ti.max(a, b, c) + pad + self.tri_extra[t])
            for i in range(lo[0], hi[0] + 1):
                for j in range(lo[1], hi[1] + 1):
                    for k in range(lo[2], hi[2] + 1):
                        cid = self._cell_index(ti.Vector([i, j, k]))
                        slot = self.cell_start[cid] + ti.atomic_add(self.cell_fill[cid], 1)
                        if slot < self.entry_capacity:
                            self.cell_entries[slot] = t
                        else:
                            self.overflow[None] = 1
        # each cell's triangles in increasing order: the parallel fill above enters them in
        # any order, and a vertex equally close to two triangles takes the first one's
        # normal, so the same run would otherwise not give the same result
        for c in range(self.cell_fill.shape[0]):
            _sort_range(self.cell_entries, self.cell_start[c], self.cell_start[c + 1])
        # vertex normals (area-weighted) and the vertex grid
        for i in self.vertex_normal:
            self.vertex_normal[i] = ti.Vector([0.0, 0.0, 0.0])
        for t in self.tri:
            a, b, c = (
                self.body_x[self.tri[t][0]],
                self.body_x[self.tri[t][1]],
                self.body_x[self.tri[t][2]],
            )
            n = (b - a).cross(c - a)
            for k in ti.static(range(3)):
                ti.atomic_add(self.vertex_normal[self.tri[t][k]], n)
        for i in self.vertex_normal:
            self.vertex_normal[i] = self.vertex_normal[i] / ti.max(
                self.vertex_normal[i].norm(), 1e-30
            )
        for c in self.v_cell_fill:
            self.v_cell_fill[c] = 0
        for i in self.body_x:
            ti.atomic_add(self.v_cell_fill[self._cell_index(self._cell_of(self.body_x[i]))], 1)
        ti.loop_config(serialize=True)
        for c in range(self.v_cell_fill.shape[0]):
            if c == 0:
                self.v_cell_start[0] = 0
            self.v_cell_start[c + 1] = self.v_cell_start[c] + self.v_cell_fill[c]
            self.v_cell_fill[c] = 0
        for i in self.body_x:
            cid = self._cell_index(self._cell_of(self.body_x[i]))
            self.v_entries[self.v_cell_start[cid] + ti.atomic_add(self.v_cell_fill[cid], 1)] = i
        for c in range(self.v_cell_fill.shape[0]):
            _sort_range(self.v_entries, self.v_cell_start[c], self.v_cell_start[c + 1])

    # ------------------------------------------------------------------ response
    @ti.func
    def _cells_to_visit(self, lo, hi):
        """How many cells of the box [lo, hi] a query visits (at most MAX_CELLS_PER_QUERY)."""
        span = hi - lo + 1
        return ti.min(span[0] * span[1] * span[2], MAX_CELLS_PER_QUERY)

    @ti.func
    def _next_cell(self, cell, lo, hi):
        """The cell after ``cell`` in the box [lo, hi], k fastest (no divisions: cheaper
        than ``ti.ndrange``'s index arithmetic in these small loops)."""
        nxt = cell + ti.Vector([0, 0, 1])
        if nxt[2] > hi[2]:
            nxt[2] = lo[2]
            nxt[1] += 1
            if nxt[1] > hi[1]:
                nxt[1] = lo[1]
                nxt[0] += 1
        return nxt

    @ti.func
    def poke(self, a, b, c):
        """The deepest body vertex poking through the cloth triangle (a, b, c) [m].

        A coarse cloth triangle spans the body's curvature: its corners keep the thickness
        h from the body (:meth:`respond`) while its middle sags into it (bust, shoulder
        blades). For each body vertex p whose projection falls inside the triangle, with the
        cloth normal n turned to the outside of the body (the side of p's vertex normal),
        the depth is (p − a)·n + h: how far the triangle must move along n to keep p the
        thickness h below it. Returns ``(depth, n, w)`` with w the barycentric weights of the
        projection; depth <= 0 when nothing pokes. Only the vertices of a closed body, and
        not deeper than a quarter of the triangle's longest edge (deeper means the cloth is
        inside the body, which the vertex test handles).
        """
        h = self.thickness[None]
        best = 0.0
        best_n = ti.Vector([0.0, 0.0, 0.0])
        best_w = ti.Vector([0.0, 0.0, 0.0])
        nc = (b - a).cross(c - a)
        area2 = nc.norm()
        longest = ti.max((b - a).norm(), (c - b).norm(), (a - c).norm())
        if area2 > 1e-12 * longest * longest and longest > 0.0:
            nc = nc / area2
            box_lo = ti.min(a, b, c) - h
            box_hi = ti.max(a, b, c) + h
            lo = self._cell_of(box_lo)
            hi = self._cell_of(box_hi)
            cell = lo
            for _ in range(self._cells_to_visit(lo, hi)):
                cid = self._cell_index(cell)
                for e in range(self.v_cell_start[cid], self.v_cell_start[cid + 1]):
                    vid = self.v_entries[e]
                    p = self.body_x[vid]
                    if (p >= box_lo).all() and (p <= box_hi).all():
                        n = nc
                        if nc.dot(self.vertex_normal[vid]) < 0.0:
                            n = -nc
                        s = (p - a).dot(n)
                        if s > -h and s < 0.25 * longest:
                            w = _barycentric(p - s * n, a, b, c)
                            if w.min() > 0.0 and s + h > best:
                                best = s + h
                                best_n = n
                                best_w = w
                cell = self._next_cell(cell, lo, hi)
        return best, best_n, best_w

    @ti.func
    def contact_planes(self, x, reach, crease_reach):
        """Up to two body planes that cloth at x must stay in front of, from the faces
        within ``reach`` [m] of x (the second within ``crease_reach`` [m]).

        Returns ``(count, n1, o1, n2, o2)``: n the faces' outward unit normals and o
        offsets such that n·y − o is the distance of y in front of the plane less the
        thickness (≥ 0 keeps the thickness). Plane 1 is the nearest face's. Plane 2, when
        there is one, is the nearest face that meets it in a concave crease (an armpit,
        under the bust): its normal differs by more than ``CREASE_COS`` and the nearest
        point on face 1 is in front of it, so a vertex sliding along face 1 cannot pass
        through it. Across a convex edge (the shoulder ridge) the second face's plane would
        cut into face 1, and it is not used. An open surface's normals are turned to the
        side x is on. The implicit solver keeps cloth in front of these planes with a
        penalty in its step energy (:mod:`sandbox.sim.implicit`), so contact acts inside the
        Newton solve, where cloth can slide along the body instead of being stopped after.
        """
        count = 0
        n1 = ti.Vector([0.0, 0.0, 1.0])
        o1 = 0.0
        n2 = n1
        o2 = o1
        e1 = 0.0  # the faces' crease thickness (follow_cloth)
        e2 = 0.0
        found, t1 = self._nearest_face(x, reach, n1, x, False)
        if found:
            count = 1
            n1, o1 = self._face_plane(t1, x)
            n2, o2 = n1, o1
            e1 = self._extra_at(t1, self._closest_on(t1, x))
            e2 = e1
            found2, t2 = self._nearest_face(x, ti.min(reach, crease_reach), n1,
                                            self._closest_on(t1, x), True)  # fmt: skip
            if found2:
                count = 2
                n2, o2 = self._face_plane(t2, x)
                e2 = self._extra_at(t2, self._closest_on(t2, x))
        h = self.thickness[None]
        return count, n1, o1 + h + e1, n2, o2 + h + e2

    @ti.func
    def _nearest_face(self, x, reach, n1, q1, crease: ti.template()):
        """``(found, t)``: the body face nearest to x within ``reach`` [m] (at most
        :data:`NEAREST_REACH_CELLS` cells); with ``crease``, only faces that meet face 1
        (normal n1, point q1 nearest to x) in a concave crease: their normal differs by
        more than CREASE_COS, q1 is in front of their plane and their centre in front of
        face 1's (a convex ridge's faces fall behind each other's planes; its shared edge,
        where q1 lies when x is nearest to the ridge, is on both planes). Looks within
        :data:`NEAR_FIRST_CELLS` cells first, then, if nothing is that near, the whole reach."""
        within = ti.min(reach, NEAREST_REACH_CELLS * self.cell_size[None])  # searched whole
        near = ti.min(within, NEAR_FIRST_CELLS * self.cell_size[None])
        found, t_best = self._nearest_face_in(x, near, n1, q1, crease)
        if not found and within > near:
            found, t_best = self._nearest_face_in(x, within, n1, q1, crease)
        return found, t_best

    @ti.func
    def _nearest_face_in(self, x, within, n1, q1, crease: ti.template()):
        """:meth:`_nearest_face` in the cells of the box x ± ``within`` [m]."""
        lo = self._cell_of(x - within)
        hi = self._cell_of(x + within)
        best = within
        found = 0
        t_best = 0
        cell = lo
        for _ in range(self._cells_to_visit(lo, hi)):
            cid = self._cell_index(cell)
            for e in range(self.cell_start[cid], self.cell_start[cid + 1]):
                t = self.cell_entries[e]
                r = self.tri_radius[t] + best
                if (x - self.tri_centre[t]).norm_sqr() <= r * r:
                    ok = 1
                    if ti.static(crease):
                        n, o = self._face_plane(t, x)
                        if (n.dot(n1) >= CREASE_COS or n.dot(q1) - o < 0.0
                                or n1.dot(self.tri_centre[t] - q1) <= 0.0):  # fmt: skip
                            ok = 0
                    if ok:
                        d = (x - self._closest_on(t, x)).norm()
                        if d < best:
                            best = d
                            found = 1
                            t_best = t
            cell = self._next_cell(cell, lo, hi)
        return found, t_best

    @ti.func
    def _closest_on(self, t, x):
        """The point of body triangle t closest to x."""
        a = self.body_x[self.tri[t][0]]
        b = self.body_x[self.tri[t][1]]
        c = self.body_x[self.tri[t][2]]
        return closest_point_on_triangle(x, a, b, c)

    @ti.func
    def _face_plane(self, t, x):
        """(n, o): triangle t's plane n·y = o, n outward (an open surface: towards x)."""
        n = self.tri_normal[t]
        o = self.tri_offset[t]
        if ti.static(not self.closed):
            if n.dot(x) < o:
                n = -n
                o = -o
        return n, o

    @ti.func
    def respond(self, x, v, dt):
        """Revised velocity v(t+dt) for a vertex at x(t) with predicted velocity v: the one
        that moves it this step (see :meth:`respond_split`)."""
        v_move, _ = self.respond_split(x, v, dt)
        return v_move

    # One piece: a Taichi function inlined into the solver's per-vertex loop; the crossing
    # test, the thickness push and friction share the step's local state (the plane, the
    # normal velocity) and run in this order for every vertex, so splitting it would only
    # pass that state through more arguments.
    @ti.func
    def respond_split(self, x, v, dt):
        """Contact response of a vertex at x(t) with predicted velocity v(t+dt) [m/s].

        Returns ``(v_move, v_keep)``. ``v_move`` moves the vertex this step: it stops in
        front of a crossing and ends at least the thickness h from the body, with Coulomb
        friction. ``v_keep`` is the velocity the vertex keeps for the next step: the same,
        less the outward push that restored the thickness. Its normal speed is at most
        the vertex's own outward speed before contact (inelastic contact). Keeping the
        push, (h − φ)/dt, would launch a vertex that starts 2 mm inside the layer at
        dt = 31 µs outward at 64 m/s, and keep it jittering against the body. Over a convex
        crease the thickness grows by the face's ``tri_extra`` (:meth:`follow_cloth`).
        """
        h = self.thickness[None]
        hx = h + self.extra_max[None]  # the largest thickness of any face
        x1 = x + dt * v
        # the cell of x1 alone when the binning pad covers both h and the step
        # (BIN_PAD_THICKNESSES), else every cell of the step's box grown by h
        lo = self._cell_of(x1)
        hi = lo
        if ti.max(h, (x1 - x).norm()) > self.bin_pad[None]:
            lo = self._cell_of(ti.min(x, x1) - hx)
            hi = self._cell_of(ti.max(x, x1) + hx)
        # 1. continuous: earliest crossing of the segment through a triangle
        best_t = 2.0
        best_n = ti.Vector([0.0, 0.0, 0.0])
        # 2. proximity at the predicted position: the closest triangle within reach
        best_d = 1e30
        best_q = ti.Vector([0.0, 0.0, 0.0])
        best_pn = ti.Vector([0.0, 0.0, 0.0])
        best_side = -1e30  # (x1 - q) . n of the closest triangle: > 0 in front of its plane
        best_tri = -1  # the closest triangle
        # a step whose box has more cells than a query may visit tests every triangle
        # instead (a 10 m/s impact at 1/60 s): visiting only the box's first cells, lowest x
        # first, would miss crossings on its far side
        span = hi - lo + 1
        every = span[0] * span[1] * span[2] > MAX_CELLS_PER_QUERY
        visits = self._cells_to_visit(lo, hi)
        if every:
            visits = 1
        cell = lo
        for _ in range(visits):
            cid = self._cell_index(cell)
            first, last = self.cell_start[cid], self.cell_start[cid + 1]
            if every:
                first, last = 0, self.tri.shape[0]
            for e in range(first, last):
                t = e
                if not every:
                    t = self.cell_entries[e]
                n = self.tri_normal[t]
                s0 = n.dot(x) - self.tri_offset[t]
                s1 = n.dot(x1) - self.tri_offset[t]
                # a crossing needs the two ends on opposite sides of the plane, and
                # proximity needs the predicted position within h of the plane
                if s0 * s1 <= 0.0 or ti.abs(s1) <= hx:
                    a = self.body_x[self.tri[t][0]]
                    b = self.body_x[self.tri[t][1]]
                    c = self.body_x[self.tri[t][2]]
                    if s0 * s1 <= 0.0:
                        hit, s = segment_triangle(x, x1, a, b, c)
                        if hit and s < best_t:
                            best_t = s
                            best_n = n
                            if ti.static(not self.closed):
                                if s0 < 0.0:
                                    best_n = -n
                    reach = self.tri_radius[t] + hx
                    near = (x1 - self.tri_centre[t]).norm_sqr() <= reach * reach
                    if near or s0 * s1 <= 0.0:
                        q = closest_point_on_triangle(x1, a, b, c)
                        d = (x1 - q).norm()
                        side = (x1 - q).dot(n)
                        # triangles that share the closest point (an edge or a corner) tie:
                        # the one whose plane the vertex is most in front of decides the side
                        if d < best_d - TIE_M or (d <= best_d + TIE_M and side > best_side):
                            best_d = d
                            best_q = q
                            best_pn = n
                            best_side = side
                            best_tri = t
            cell = self._next_cell(cell, lo, hi)
        v_new = v
        cn = ti.Vector([0.0, 0.0, 0.0])  # the contact normal, where there is contact
        if dt <= 0.0:  # a zero step (the compile warm-up) moves nothing: nothing to revise
            best_t = 2.0
            best_d = 1e30
        if best_t <= 1.0:
            # stop in front of the first crossing, then let proximity add friction below
            hit_p = x + best_t * (x1 - x)
            target = hit_p + h * best_n
            v_new = (target - x) / dt
            # keep the tangential motion up to the hit (sliding, not sticking)
            x1 = x + dt * v_new
            best_q = hit_p
            best_pn = best_n
            best_d = h * 0.0
            cn = best_n
        best_h = h  # the closest triangle's thickness at the closest point
        if best_tri >= 0 and self.extra_max[None] > 0.0:
            best_h = h + self._extra_at(best_tri, best_q)
        if best_d < best_h:
            # side: the face normal, flipped to the side the vertex came from
            n = best_pn
            if ti.static(not self.closed):
                if (x - best_q).dot(n) < 0.0 and best_t > 1.0:
                    n = -n
            phi = (x1 - best_q).dot(n)
            if phi > 0.0 and phi < best_d * (1.0 - 1e-6):
                # in front of the body, nearest to an edge or a corner of it: the distance
                # and its direction are those to the closest point (the face's plane would
                # measure less: at a sharp rim, a vertex resting on the top face beside the
                # rim is 0 from the side face's plane and was pushed sideways by h a step)
                n = (x1 - best_q) / best_d
                phi = best_d
            if phi < best_h:
                dvn = (best_h - phi) / dt  # normal velocity change that restores the thickness
                vn = v_new.dot(n)
                vt = v_new - vn * n
                vt_len = vt.norm()
                if vt_len <= self.mu_s[None] * dvn:
                    vt = ti.Vector([0.0, 0.0, 0.0])
                else:
                    vt = vt * (1.0 - self.mu_k[None] * dvn / vt_len)
                v_new = vt + (vn + dvn) * n
                cn = n
        v_keep = v_new
        out = v_new.dot(cn) - ti.max(v.dot(cn), 0.0)  # the push beyond the own motion
        if out > 0.0:
            v_keep = v_new - out * cn
        return v_new, v_keep


@ti.func
def _sort_range(a, lo, hi):
    """Insertion sort of a[lo:hi] (a grid cell's few entries)."""
    for i in range(lo + 1, hi):
        key = a[i]
        j = i - 1
        while j >= lo and a[ti.max(j, lo)] > key:  # (``and`` does not short-circuit)
            a[j + 1] = a[j]
            j -= 1
        a[j + 1] = key


@ti.func
def _barycentric(p, a, b, c):
    """Barycentric weights of p (in the plane of a, b, c) [1]."""
    v0, v1, v2 = b - a, c - a, p - a
    d00, d01, d11 = v0.dot(v0), v0.dot(v1), v1.dot(v1)
    d20, d21 = v2.dot(v0), v2.dot(v1)
    den = d00 * d11 - d01 * d01
    wb = (d11 * d20 - d01 * d21) / den
    wc = (d00 * d21 - d01 * d20) / den
    return ti.Vector([1.0 - wb - wc, wb, wc])


@ti.func
def segment_triangle(p0, p1, a, b, c):
    """Does the segment p0 -> p1 cross triangle abc? Returns (hit, s in [0, 1])."""
    d = p1 - p0
    e1 = b - a
    e2 = c - a
    pv = d.cross(e2)
    det = e1.dot(pv)
    hit = False
    s = 2.0
    if ti.abs(det) > 1e-20:
        inv = 1.0 / det
        tv = p0 - a
        u = tv.dot(pv) * inv
        qv = tv.cross(e1)
        w = d.dot(qv) * inv
        s_ = e2.dot(qv) * inv
        if u >= 0.0 and w >= 0.0 and u + w <= 1.0 and s_ >= 0.0 and s_ <= 1.0:
            hit = True
            s = s_
    return hit, s


@ti.func
def closest_point_on_triangle(p, a, b, c):
    """Closest point to p on triangle abc (the weights from the shared primitive)."""
    w = point_triangle_closest(p, a, b, c)
    return w[0] * a + w[1] * b + w[2] * c
