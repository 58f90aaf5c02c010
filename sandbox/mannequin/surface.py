"""One watertight triangle mesh from the control net: fixed topology per resolution.

:class:`BodyTemplate` is built once per resolution from a base body: it fixes the row and
column counts of every part, the junction index maps, the quad diagonals, the cap
triangulations and the orientation. :meth:`BodyTemplate.evaluate` then maps any
:class:`BodyShape` to vertex positions with a handful of vectorised numpy products, so a
resize changes vertex positions only (same triangles), which is what a live UI needs.
"""

from __future__ import annotations

import math

import numpy as np
import triangle

from sandbox.mannequin import body
from sandbox.mannequin.loft import (
    graded_column_matrix,
    hermite_matrix,
    key_row_indices,
    loft,
    loft_columns,
    reflect_ghost,
)
from sandbox.mannequin.sections import limb_ring
from sandbox.mannequin.shape import BodyShape

LEG_ANGLE_BLEND = (0.45, 0.85, 1.0, 1.0, 1.0)
ARM_ANGLE_BLEND = (0.5, 0.9, 1.0, 1.0, 1.0)
TORSO_STRETCH = 1.2  # row spacing / column spacing, per part
YOKE_STRETCH = 1.0
LIMB_STRETCH = 1.6
BRIDGE_STRETCH = 1.3  # bridge point spacing / torso column spacing
ARM_SKIP = 1  # arm sections left out: the upper-arm ring cut into the torso at the armpit
ARM_NORMAL_BLEND = 1.0  # arm start tangent: 0 chord to the first section, 1 loop normal
ARM_NORMAL_REACH = 2.0  # ghost distance along the loop normal, times the first section's reach
CORNER_BLEND = (0.0, 0.5, 1.0)  # yoke column continuation weight by distance to an armhole point


def _counts(keys: np.ndarray, stretch: float) -> tuple[np.ndarray, np.ndarray]:
    """Row intervals between key rows (K, M, 3) and nominal key parameters [m].

    Rows are spaced ``stretch`` times the mean column spacing of the neighbouring keys
    (quads up to that aspect ratio keep the triangles' smallest angle above ~30 degrees).
    """
    spacing = _ring_spacing(keys)
    seg = np.linalg.norm(np.diff(keys, axis=0), axis=2).mean(axis=1)
    target = stretch * 0.5 * (spacing[:-1] + spacing[1:])
    counts = np.maximum(1, np.round(seg / target)).astype(int)
    t = np.concatenate([[0.0], np.cumsum(seg)])
    return counts, t


def _ring_spacing(keys: np.ndarray) -> np.ndarray:
    """Mean edge length around each closed key row (K, M, 3) -> (K,)."""
    return np.linalg.norm(keys - np.roll(keys, -1, axis=1), axis=2).mean(axis=1)


def _mean_value_weights(poly: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Mean value coordinates (len(pts), len(poly)) of 2D points inside a polygon."""
    s = poly[None, :, :] - pts[:, None, :]
    r = np.linalg.norm(s, axis=2)
    s1 = np.roll(s, -1, axis=1)
    r1 = np.roll(r, -1, axis=1)
    cross = s[..., 0] * s1[..., 1] - s[..., 1] * s1[..., 0]
    dot = (s * s1).sum(axis=2)
    tan_half = (r * r1 - dot) / cross
    w = (np.roll(tan_half, 1, axis=1) + tan_half) / r
    return w / w.sum(axis=1, keepdims=True)


def _cap(ring: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """Quality triangulation of a planar ring (M, 3): (weights (I, M), triangles (T, 3)).

    Triangles index the ring as 0..M-1 and interior points as M..M+I-1; interior points are
    fixed mean-value combinations of the ring, so they follow any later resize.
    """
    c = ring.mean(axis=0)
    _, _, vt = np.linalg.svd(ring - c)
    p2 = (ring - c) @ vt[:2].T
    m = len(ring)
    seg = np.stack([np.arange(m), (np.arange(m) + 1) % m], axis=1)
    area = 0.5 * spacing**2
    out = triangle.triangulate({"vertices": p2, "segments": seg}, f"pq32Ya{area:.3e}")
    verts = out["vertices"]
    if not np.allclose(verts[:m], p2):
        raise RuntimeError("cap triangulation reordered the boundary")
    weights = _mean_value_weights(p2, verts[m:])
    return weights, out["triangles"].astype(np.int64)


def _min_angle(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray) -> np.ndarray:
    """Smallest angle [rad] of triangles with corners (..., 3) each."""
    out = []
    for a, b, c in ((p0, p1, p2), (p1, p2, p0), (p2, p0, p1)):
        u, w = b - a, c - a
        cos = (u * w).sum(-1) / (np.linalg.norm(u, axis=-1) * np.linalg.norm(w, axis=-1))
        out.append(np.arccos(np.clip(cos, -1.0, 1.0)))
    return np.minimum(np.minimum(out[0], out[1]), out[2])


def _grid_quads(grid: np.ndarray, samples: list[np.ndarray]) -> np.ndarray:
    """Two triangles per quad of a periodic index grid (R, M).

    Each quad is split along the diagonal whose worst triangle over all ``samples``
    (vertex positions of a few sizes) has the larger smallest angle, so the choice is fixed
    per topology and good for every size.
    """
    a = grid[:-1]
    b = np.roll(grid, -1, axis=1)[:-1]
    c = np.roll(grid, -1, axis=1)[1:]
    d = grid[1:]
    q_ac = np.full(a.shape, np.inf)
    q_bd = np.full(a.shape, np.inf)
    for pos in samples:
        pa, pb, pc, pd = pos[a], pos[b], pos[c], pos[d]
        q_ac = np.minimum(q_ac, np.minimum(_min_angle(pa, pb, pc), _min_angle(pa, pc, pd)))
        q_bd = np.minimum(q_bd, np.minimum(_min_angle(pa, pb, pd), _min_angle(pb, pc, pd)))
    use_ac = (q_ac >= q_bd)[..., None]
    t1 = np.where(use_ac, np.stack([a, b, c], -1), np.stack([a, b, d], -1))
    t2 = np.where(use_ac, np.stack([a, c, d], -1), np.stack([b, c, d], -1))
    return np.concatenate([t1.reshape(-1, 3), t2.reshape(-1, 3)])


def _outward(tris: np.ndarray, pos: np.ndarray, inside: np.ndarray) -> np.ndarray:
    """Flip a consistently wound patch so its normals point away from ``inside`` points."""
    p = pos[tris]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    if float(np.sum(normal * (p.mean(axis=1) - inside))) < 0:
        return tris[:, ::-1].copy()
    return tris


class BodyTemplate:
    """Topology and fixed linear maps of the body mesh at one resolution.

    ``n_columns`` is the torso column count (multiple of 16): 48 gives about 18k triangles,
    64 about 31k. Built from ``base`` (a database size); any other shape is evaluated on
    the same topology. ``samples`` (other sizes) only take part in choosing the quad
    diagonals, so that the fixed choice suits them too.
    """

    def __init__(self, base: BodyShape, n_columns: int = 64, samples: tuple[BodyShape, ...] = ()):
        self.cols = body.Columns(n_columns)
        self._nv = 0  # vertices allocated so far (:meth:`_block`)
        rings = body.torso_key_rings(base, self.cols)
        keys_t = np.stack([rings[k] for k in body.TORSO_RINGS])
        self._plan_torso_and_bridges(base, rings, keys_t)
        self._plan_loops()
        self._plan_limbs(base, rings, keys_t)
        self._build_faces(base, samples)
        self._vtmp = None

    def _block(self, count: int) -> np.ndarray:
        """The indices of ``count`` new vertices."""
        idx = np.arange(self._nv, self._nv + count)
        self._nv += count
        return idx

    def _plan_torso_and_bridges(self, base: BodyShape, rings: dict, keys_t: np.ndarray):
        """Row counts of the torso, the crotch bridge and the shoulder bridges."""
        cols = self.cols
        spacing_t = _ring_spacing(keys_t)
        self.target = float(spacing_t.mean())
        counts, t = _counts(keys_t, TORSO_STRETCH)
        self.torso_counts, self.torso_t = counts, t
        self.h_torso = hermite_matrix(t, counts)
        self.torso_key_rows = key_row_indices(counts)

        # crotch bridge (odd count so the crotch point is a vertex)
        depth = abs(keys_t[0, 0, 2] - keys_t[0, cols.back, 2]) + body.CROTCH_DIP
        kc = max(3, int(round(depth / spacing_t[0])))
        self.kc = kc + (kc % 2 == 0)

        # shoulder bridge pieces
        ctrl = body.shoulder_bridge_points(base, rings["armpit"], cols)
        piece = np.linalg.norm(np.diff(ctrl, axis=0), axis=1)
        self.bridge_pieces = np.maximum(2, np.round(piece / (BRIDGE_STRETCH * self.target)))
        self.bridge_pieces = self.bridge_pieces.astype(int)
        tb = np.concatenate([[0.0], np.cumsum(piece)])
        self.h_bridge = hermite_matrix(tb, self.bridge_pieces)
        self.ka = int(self.bridge_pieces.sum()) - 1
        cum = np.cumsum(self.bridge_pieces)
        self.bridge_front_crease, self.bridge_shoulder, self.bridge_back_crease = (
            int(cum[0]) - 1,
            int(cum[1]) - 1,
            int(cum[2]) - 1,
        )  # indices into the bridge interior

    def _plan_loops(self):
        """Vertex blocks of the torso and bridges, and the loops where the yoke, the arms
        and the legs join them."""
        cols, ka = self.cols, self.ka
        n = cols.n
        rt = self.torso_key_rows[-1] + 1
        self.torso_idx = self._block(rt * n).reshape(rt, n)
        self.crotch_idx = self._block(self.kc)
        self.bridge_l_idx = self._block(ka)
        self.bridge_r_idx = self._block(ka)

        h = cols.armhole_half
        sl, sr = cols.side_left, cols.side_right
        top = self.torso_idx[-1]
        bottom = self.torso_idx[0]
        # yoke loop: front-left, left bridge (front->back), back, right bridge, front-right
        self.yoke_loop = np.concatenate(
            [
                top[0 : sl - h + 1],
                self.bridge_l_idx,
                top[sl + h : sr - h + 1],
                self.bridge_r_idx[::-1],
                top[sr + h :],
            ]
        )
        my = len(self.yoke_loop)
        self.yoke_torso_cols = np.concatenate(
            [np.arange(0, sl - h + 1), np.arange(sl + h, sr - h + 1), np.arange(sr + h, n)]
        )
        self.yoke_torso_pos = np.concatenate(
            [
                np.arange(0, sl - h + 1),
                np.arange(sl - h + 1 + ka, sl - h + 1 + ka + (sr - sl - 2 * h + 1)),
                np.arange(my - (n - sr - h), my),
            ]
        )
        # torso columns next to the armhole points leave the loop towards the neck (a
        # corner of the yoke), the others continue the torso column (C1 junction)
        corners = np.array([sl - h, sl - h + 1 + ka])
        corners = np.concatenate([corners, my - corners])
        gap = np.abs(self.yoke_torso_pos[:, None] - corners[None]).min(axis=1)
        self.yoke_continuation = np.interp(gap, np.arange(len(CORNER_BLEND)), CORNER_BLEND)
        j_spl = sl - h + 1 + self.bridge_shoulder
        j_cb = int(np.nonzero(self.yoke_loop == top[cols.back])[0][0])
        j_spr = int(np.nonzero(self.yoke_loop == self.bridge_r_idx[self.bridge_shoulder])[0][0])
        self.yoke_anchor = (j_spl, j_cb, j_spr)
        anchors_j = np.array([0, j_spl, j_cb, j_spr, my])
        anchors_psi = np.array([0.0, 0.5, 1.0, 1.5, 2.0]) * math.pi
        self.neck_psi = np.interp(np.arange(my), anchors_j, anchors_psi)

        # arm loop (left): underarm torso columns then bridge interior back->front
        self.arm_l_loop = np.concatenate([top[sl - h : sl + h + 1], self.bridge_l_idx[::-1]])
        mirror_top = top[cols.mirror(np.arange(sl - h, sl + h + 1))]
        self.arm_r_loop = np.concatenate([mirror_top, self.bridge_r_idx[::-1]])
        # leg loop (left): torso bottom CF -> left -> CB, then crotch bridge CB -> CF
        self.leg_l_loop = np.concatenate([bottom[0 : cols.back + 1], self.crotch_idx])
        self.leg_r_loop = np.concatenate(
            [bottom[cols.mirror(np.arange(0, cols.back + 1))], self.crotch_idx]
        )

    def _plan_limbs(self, base: BodyShape, rings: dict, keys_t: np.ndarray):
        """Evaluate the loops on the base shape to fix the yoke's, arms' and legs' row
        counts and angles, then allocate their grids."""
        nv = self._nv
        self.n_vertices_core = nv
        self._vtmp = np.zeros((nv, 3))
        torso_rows = self._torso_rows(keys_t)
        self._vtmp[self.torso_idx] = torso_rows
        self._fill_bridges(base, rings)
        loop_arm = self._vtmp[self.arm_l_loop]
        loop_leg = self._vtmp[self.leg_l_loop]
        loop_yoke = self._vtmp[self.yoke_loop]

        arm = body.arm_frames(base, loop_arm, self._half_width_fn(keys_t))
        self.arm_loop_angles = body.limb_angles(loop_arm, arm["c0"], arm["u0"], arm["v0"])
        leg_c, _, _ = body.leg_sections(base, rings["hip"], loop_leg)
        c_leg = loop_leg.mean(axis=0)
        self.leg_loop_angles = body.limb_angles(
            loop_leg, c_leg, np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])
        )

        keys_y = self._yoke_keys(base, loop_yoke, torso_rows)
        _, ty = _counts(keys_y[1:-1], YOKE_STRETCH)
        self.h_yoke, self.yoke_key_rows = graded_column_matrix(ty, keys_y, (0, 1, 2), YOKE_STRETCH)
        keys_a = self._arm_keys(base, loop_arm, keys_t)
        _, ta = _counts(keys_a[1:-1], LIMB_STRETCH)
        self.h_arm, _ = graded_column_matrix(ta, keys_a, (0, len(ta) - 1), LIMB_STRETCH)
        keys_l = self._leg_keys(base, rings["hip"], loop_leg)
        _, tl = _counts(keys_l[1:-1], LIMB_STRETCH)
        self.h_leg, _ = graded_column_matrix(tl, keys_l, (0, len(tl) - 1), LIMB_STRETCH)

        ry = self.h_yoke.shape[1]
        ra = self.h_arm.shape[1]
        rl = self.h_leg.shape[1]
        my = len(self.yoke_loop)
        block = self._block
        self.yoke_grid = np.vstack([self.yoke_loop, block((ry - 1) * my).reshape(ry - 1, my)])
        ma, ml = len(self.arm_l_loop), len(self.leg_l_loop)
        self.arm_l_grid = np.vstack([self.arm_l_loop, block((ra - 1) * ma).reshape(ra - 1, ma)])
        self.arm_r_grid = np.vstack([self.arm_r_loop, block((ra - 1) * ma).reshape(ra - 1, ma)])
        self.leg_l_grid = np.vstack([self.leg_l_loop, block((rl - 1) * ml).reshape(rl - 1, ml)])
        self.leg_r_grid = np.vstack([self.leg_r_loop, block((rl - 1) * ml).reshape(rl - 1, ml)])
        self.n_vertices_core = self._nv

    def _build_faces(self, base: BodyShape, samples: tuple[BodyShape, ...]):
        """Triangles of every grid (quad diagonals chosen to suit the base and the samples)
        and the caps closing the neck, arm and leg openings."""
        nv = self._nv
        pos = np.zeros((nv, 3))
        self._vtmp = pos
        self._evaluate_core(base)
        sample_pos = [pos]
        for other in samples:
            self._vtmp = np.zeros((nv, 3))
            self._evaluate_core(other)
            sample_pos.append(self._vtmp)
        self._vtmp = pos
        grids = (
            self.torso_idx,
            self.yoke_grid,
            self.arm_l_grid,
            self.arm_r_grid,
            self.leg_l_grid,
            self.leg_r_grid,
        )
        faces = []
        for grid in grids:
            tris = _grid_quads(grid, sample_pos)
            row_centre = pos[grid].mean(axis=1)
            ref = np.repeat(row_centre[:-1], grid.shape[1], axis=0)
            faces.append(_outward(tris, pos, np.concatenate([ref, ref])))
        self.caps = []
        full = pos
        for grid in grids[1:]:
            ring_idx = grid[-1]
            ring = pos[ring_idx]
            spacing = float(_ring_spacing(ring[None])[0])
            w, tris = _cap(ring, spacing)
            interior = self._block(len(w))
            full = np.concatenate([full, w @ ring])
            lookup = np.concatenate([ring_idx, interior])
            ref = pos[grid[-2]].mean(axis=0)
            faces.append(_outward(lookup[tris], full, ref[None, :]))
            self.caps.append((ring_idx, interior, w))
        self.n_vertices = self._nv
        self.faces = np.concatenate(faces).astype(np.int64)

    # --- evaluation pieces --------------------------------------------------------------
    def _torso_rows(self, keys_t: np.ndarray) -> np.ndarray:
        ext = np.concatenate(
            [
                reflect_ghost(keys_t[0], keys_t[1])[None],
                keys_t,
                reflect_ghost(keys_t[-1], keys_t[-2])[None],
            ]
        )
        return loft(self.h_torso, ext)

    def _half_width_fn(self, keys_t: np.ndarray):
        ys = keys_t[:, 0, 1]
        hw = keys_t[:, :, 0].max(axis=1)

        def fn(y: float) -> float:
            return float(np.interp(y, ys, hw))

        return fn

    def _fill_bridges(self, s: BodyShape, rings: dict) -> None:
        v = self._vtmp
        cols = self.cols
        ctrl = body.shoulder_bridge_points(s, rings["armpit"], cols)
        ext = np.concatenate(
            [reflect_ghost(ctrl[0], ctrl[1])[None], ctrl, reflect_ghost(ctrl[-1], ctrl[-2])[None]]
        )
        pts = (self.h_bridge @ ext)[1:-1]
        v[self.bridge_l_idx] = pts
        v[self.bridge_r_idx] = pts * np.array([-1.0, 1.0, 1.0])
        bottom = self.torso_idx[0]
        cf, cb = v[bottom[0]], v[bottom[cols.back]]
        v[self.crotch_idx] = body.crotch_bridge(cf, cb, self.kc)

    def _yoke_keys(self, s: BodyShape, loop: np.ndarray, torso_rows: np.ndarray) -> np.ndarray:
        base = body.neck_ring(s, self.neck_psi)
        top = body.neck_ring(s, self.neck_psi, top=True)
        ghost_lo = reflect_ghost(loop, base)
        below = torso_rows[-2][self.yoke_torso_cols]
        here = torso_rows[-1][self.yoke_torso_cols]
        dist = np.linalg.norm(base[self.yoke_torso_pos] - here, axis=1)
        step = np.linalg.norm(here - below, axis=1)
        cont = here + (below - here) * (dist / step)[:, None]
        w = self.yoke_continuation[:, None]
        ghost_lo[self.yoke_torso_pos] = w * cont + (1 - w) * ghost_lo[self.yoke_torso_pos]
        ghost_hi = reflect_ghost(top, base)
        return np.stack([ghost_lo, loop, base, top, ghost_hi])

    def _arm_keys(self, s: BodyShape, loop: np.ndarray, keys_t: np.ndarray) -> np.ndarray:
        arm = body.arm_frames(s, loop, self._half_width_fn(keys_t))
        rows = [loop]
        for k, ((c, _n, u, v), g, w) in enumerate(
            zip(arm["frames"], arm["girths"], ARM_ANGLE_BLEND, strict=True)
        ):
            if k < ARM_SKIP:
                continue
            ang = body.blended_angles(self.arm_loop_angles, w)
            rows.append(limb_ring(c, u, v, ang, g, 1.05))
        rows = np.stack(rows)
        # the arm leaves the armhole across it (along the loop plane's normal), not along
        # the chord to the first section, which runs nearly parallel to the front and back
        # of the armhole
        n0 = np.cross(arm["u0"], arm["v0"])
        reach = np.linalg.norm(rows[1] - rows[0], axis=1, keepdims=True)
        chord = reflect_ghost(rows[0], rows[1])
        ghost = (1 - ARM_NORMAL_BLEND) * chord + ARM_NORMAL_BLEND * (
            rows[0] - ARM_NORMAL_REACH * reach * n0
        )
        return np.concatenate([ghost[None], rows, reflect_ghost(rows[-1], rows[-2])[None]])

    def _leg_keys(self, s: BodyShape, hip_ring: np.ndarray, loop: np.ndarray) -> np.ndarray:
        centres, girths, aspects = body.leg_sections(s, hip_ring, loop)
        u = np.array([0.0, 0.0, 1.0])
        v = np.array([1.0, 0.0, 0.0])
        rows = [loop]
        for c, g, a, w in zip(centres, girths, aspects, LEG_ANGLE_BLEND, strict=True):
            ang = body.blended_angles(self.leg_loop_angles, w)
            rows.append(limb_ring(c, u, v, ang, g, a))
        rows = np.stack(rows)
        return np.concatenate(
            [reflect_ghost(rows[0], rows[1])[None], rows, reflect_ghost(rows[-1], rows[-2])[None]]
        )

    def _evaluate_core(self, s: BodyShape) -> dict:
        v = self._vtmp
        rings = body.torso_key_rings(s, self.cols)
        keys_t = np.stack([rings[k] for k in body.TORSO_RINGS])
        torso_rows = self._torso_rows(keys_t)
        v[self.torso_idx] = torso_rows
        self._fill_bridges(s, rings)
        mirror = np.array([-1.0, 1.0, 1.0])
        ky = self._yoke_keys(s, v[self.yoke_loop], torso_rows)
        v[self.yoke_grid[1:]] = loft_columns(self.h_yoke, ky)[1:]
        ka = self._arm_keys(s, v[self.arm_l_loop], keys_t)
        arm = loft_columns(self.h_arm, ka)[1:]
        v[self.arm_l_grid[1:]] = arm
        v[self.arm_r_grid[1:]] = arm * mirror
        kl = self._leg_keys(s, rings["hip"], v[self.leg_l_loop])
        leg = loft_columns(self.h_leg, kl)[1:]
        v[self.leg_l_grid[1:]] = leg
        v[self.leg_r_grid[1:]] = leg * mirror
        return {"rings": rings, "keys_t": keys_t}

    def evaluate_upper(self, s: BodyShape) -> np.ndarray:
        """Vertices (n_vertices, 3) with only the torso, bridges and yoke filled [m]."""
        v = np.zeros((self.n_vertices, 3))
        self._vtmp = v
        try:
            rings = body.torso_key_rings(s, self.cols)
            keys_t = np.stack([rings[k] for k in body.TORSO_RINGS])
            torso_rows = self._torso_rows(keys_t)
            v[self.torso_idx] = torso_rows
            self._fill_bridges(s, rings)
            ky = self._yoke_keys(s, v[self.yoke_loop], torso_rows)
            v[self.yoke_grid[1:]] = loft_columns(self.h_yoke, ky)[1:]
        finally:
            self._vtmp = None
        return v

    def centre_back_profile(self, s: BodyShape) -> np.ndarray:
        """Centre-back points (k, 3) [m] from the waist ring up to the back neck point."""
        rings = body.torso_key_rings(s, self.cols)
        keys_t = np.stack([rings[k] for k in body.TORSO_RINGS])
        torso_rows = self._torso_rows(keys_t)
        loop = np.zeros((len(self.yoke_loop), 3))
        loop[self.yoke_torso_pos] = torso_rows[-1][self.yoke_torso_cols]
        ky = self._yoke_keys(s, loop, torso_rows)
        j_cb = self.yoke_anchor[1]
        yoke_col = loft_columns(self.h_yoke[[j_cb]], ky[:, [j_cb]])[:, 0]
        waist_row = self.torso_key_rows[body.TORSO_RINGS.index("waist")]
        torso_col = torso_rows[waist_row:, self.cols.back]
        return np.concatenate([torso_col, yoke_col[1 : self.yoke_key_rows[1] + 1]])

    def landmark_indices(self) -> dict[str, int]:
        """Vertex index of every named landmark."""
        c = self.cols
        kr = dict(zip(body.TORSO_RINGS, self.torso_key_rows, strict=True))
        t = self.torso_idx
        neck = self.yoke_grid[self.yoke_key_rows[1]]
        j_spl, j_cb, j_spr = self.yoke_anchor
        bl, br = self.bridge_l_idx, self.bridge_r_idx
        lm = {
            "front_neck_point": neck[0],
            "back_neck_point": neck[j_cb],
            "side_neck_point_left": neck[j_spl],
            "side_neck_point_right": neck[j_spr],
            "shoulder_point_left": bl[self.bridge_shoulder],
            "shoulder_point_right": br[self.bridge_shoulder],
            "front_armhole_point_left": bl[self.bridge_front_crease],
            "front_armhole_point_right": br[self.bridge_front_crease],
            "back_armhole_point_left": bl[self.bridge_back_crease],
            "back_armhole_point_right": br[self.bridge_back_crease],
            "underarm_point_left": t[-1, c.side_left],
            "underarm_point_right": t[-1, c.side_right],
            "bust_point_left": t[kr["bust"], c.princess_front],
            "bust_point_right": t[kr["bust"], c.mirror(c.princess_front)],
            "waist_front": t[kr["waist"], 0],
            "waist_back": t[kr["waist"], c.back],
            "hip_front": t[kr["hip"], 0],
            "hip_back": t[kr["hip"], c.back],
            "crotch_point": self.crotch_idx[self.kc // 2],
        }
        return {k: int(v) for k, v in lm.items()}

    def feature_line_indices(self) -> dict[str, np.ndarray]:
        """Vertex index polylines of the feature lines (closed lines repeat their start)."""
        c = self.cols
        kr = dict(zip(body.TORSO_RINGS, self.torso_key_rows, strict=True))
        t = self.torso_idx
        ykey = self.yoke_key_rows[1]
        y = self.yoke_grid[: ykey + 1]
        j_spl, j_cb, j_spr = self.yoke_anchor

        def closed(a):
            return np.append(a, a[0])

        def yoke_col(torso_col):
            return y[1:, int(np.nonzero(self.yoke_loop == t[-1, torso_col])[0][0])]

        def column(col):
            return np.concatenate([t[:, col], yoke_col(col)])

        pf, pb = c.princess_front, c.back - c.princess_back
        lines = {
            "neck_base": closed(y[-1]),
            "shoulder_line_left": y[:, j_spl],
            "shoulder_line_right": y[:, j_spr],
            "armhole_left": closed(self.arm_l_loop),
            "armhole_right": closed(self.arm_r_loop),
            "bust_girth": closed(t[kr["bust"]]),
            "waist_girth": closed(t[kr["waist"]]),
            "hip_girth": closed(t[kr["hip"]]),
            "centre_front": column(0),
            "centre_back": column(c.back),
            "princess_front_left": column(pf),
            "princess_front_right": column(int(c.mirror(pf))),
            "princess_back_left": column(pb),
            "princess_back_right": column(int(c.mirror(pb))),
            "side_seam_left": t[:, c.side_left],
            "side_seam_right": t[:, c.side_right],
        }
        return {k: np.asarray(v, dtype=np.int64) for k, v in lines.items()}

    def evaluate(self, s: BodyShape) -> np.ndarray:
        """Vertex positions (n_vertices, 3) [m] of shape ``s`` on this template."""
        v = np.zeros((self.n_vertices, 3))
        self._vtmp = v
        try:
            self._evaluate_core(s)
        finally:
            self._vtmp = None
        for ring_idx, interior, w in self.caps:
            v[interior] = w @ v[ring_idx]
        return v
