"""ModelBuilder: numpy pattern pieces in, a Taichi :class:`~sandbox.sim.model.Model` out.

Every array here is plain numpy and in SI units. ``finalize()`` is the only place that
allocates Taichi fields for the cloth, and it allocates only what the scene needs.
"""

from __future__ import annotations

import math

import numpy as np

from sandbox.errors import SandboxError
from sandbox.sim.hinges import bending_calibration, find_hinges, hinge_rest_weights
from sandbox.sim.materials import Material, bend_rigidity_at
from sandbox.sim.model import Model, PieceInfo
from sandbox.sim.seams import edge_vertices, merge_lines, sew

MIN_REST_AREA_M2 = 1e-14
SEAM_CLOSE_TIME_S = 0.1
#: No vertex is lighter than this fraction of the model's median vertex mass (selective
#: mass scaling). A pattern corner between two edges much shorter than the mesh's (a
#: GarmentCode outline has edges of 1-8 mm) meshes into tiny triangles whose vertices,
#: thousands of times lighter than the rest, would set the explicit step (dt ~ sqrt(m/k)).
#: The lumped masses of a quality mesh stay above 0.12 of the median (the library's 14
#: garments at 1, 1.5 and 3 cm, except six vertices of one at 3 cm), so ordinary meshes are
#: untouched; the mass added is a few vertices' worth.
MASS_FLOOR_FRACTION = 0.1
"""Default seam springs close a gap on this time scale: k = m (2π/T)² for the mean mass m
of the sewn particles. Springs as stiff as the cloth itself snap the edge across a gap of
centimetres in milliseconds and crumple the panels."""


class ModelBuilder:
    """Collects cloth pieces as numpy arrays; ``finalize()`` makes the Taichi Model."""

    def __init__(self):
        self._pieces: list[dict] = []
        self._seams: list[dict] = []

    def add_seam(self, *, side_a, side_b, direction: str = "auto", stiffness_N_m=None,
                 where: str = "seam") -> None:  # fmt: skip
        """Sew two seam lines (paper §2.4).

        ``side_a`` and ``side_b`` are lists of pattern edges, in order; several edges on one
        side are merged into one line. Each edge is either ``(piece index, (u0, v0), (u1,
        v1))``, a straight segment of the piece's pattern, or ``(piece index, indices)``, the
        piece's local vertex indices along the edge in order (curved edges).
        ``direction`` is "auto" (Fig. 5a), "same" or "reverse". ``stiffness_N_m`` per spring
        defaults to m (2π/SEAM_CLOSE_TIME_S)² with m the mean mass of the sewn particles.
        """
        if direction not in ("auto", "same", "reverse"):
            raise SandboxError(f"{where}: direction must be auto, same or reverse")
        for side in (side_a, side_b):
            for entry in side:
                piece = entry[0]
                if len(entry) not in (2, 3):
                    raise SandboxError(f"{where}: an edge is (piece, a, b) or (piece, indices)")
                if not 0 <= piece < len(self._pieces):
                    raise SandboxError(f"{where}: no cloth piece number {piece}")
        self._seams.append(dict(a=side_a, b=side_b, direction=direction, k=stiffness_N_m,
                                where=where))  # fmt: skip

    def add_cloth(
        self,
        *,
        name: str,
        pattern_uv: np.ndarray,
        triangles: np.ndarray,
        material: Material,
        rotation: np.ndarray | None = None,
        translation=(0.0, 0.0, 0.0),
        grain_rad: float = 0.0,
        pinned: np.ndarray | None = None,
        velocity=(0.0, 0.0, 0.0),
        positions: np.ndarray | None = None,
        where: str | None = None,
        meta: dict | None = None,
    ) -> int:
        """Add a flat pattern piece.

        Args:
            pattern_uv: (n, 2) pattern-plane coordinates [m] (also the output UVs).
            triangles: (m, 3) vertex indices, counter-clockwise in the pattern plane.
            material: stiffness and density.
            rotation, translation: world placement X = R [p_x, p_y, 0] + t [m].
            grain_rad: angle of the warp (u axis) from the pattern's x axis [rad].
            pinned: (n,) bool, particles that never move.
            velocity: initial velocity [m/s].
            positions: (n, 3) initial world positions [m] (for example a panel bent around
                the body); when given, ``rotation`` and ``translation`` are ignored.
        Returns the index of the piece.
        """
        where = where or name
        uv = np.asarray(pattern_uv, dtype=np.float64)
        tris = np.asarray(triangles, dtype=np.int64)
        if uv.ndim != 2 or uv.shape[1] != 2:
            raise SandboxError(f"{where}: pattern coordinates must have shape (n, 2)")
        if tris.ndim != 2 or tris.shape[1] != 3 or len(tris) == 0:
            raise SandboxError(f"{where}: triangles must have shape (m, 3) with m > 0")
        if tris.min() < 0 or tris.max() >= len(uv):
            raise SandboxError(f"{where}: a triangle refers to a vertex that does not exist")
        if not np.all(np.isfinite(uv)):
            raise SandboxError(f"{where}: pattern coordinates contain NaN or infinity")
        rot = np.eye(3) if rotation is None else np.asarray(rotation, dtype=np.float64)
        pins = np.zeros(len(uv), bool) if pinned is None else np.asarray(pinned, bool)
        pos = None
        if positions is not None:
            pos = np.asarray(positions, dtype=np.float64)
            if pos.shape != (len(uv), 3) or not np.all(np.isfinite(pos)):
                raise SandboxError(f"{where}: positions must be finite with shape (n, 3)")
        self._pieces.append(
            dict(
                name=name,
                where=where,
                uv=uv,
                tris=tris,
                material=material,
                rot=rot,
                t=np.asarray(translation, dtype=np.float64),
                grain=float(grain_rad),
                pins=pins,
                vel=np.asarray(velocity, dtype=np.float64),
                pos=pos,
                meta=meta or {},
            )
        )
        return len(self._pieces) - 1

    def finalize(self, *, bending: bool = True, seam_capacity: int = 0) -> Model:
        """Allocate the Taichi Model. With ``bending=False`` no hinge is built.

        ``seam_capacity`` reserves room for that many seam springs beyond the ones sewn here,
        for scenes that sew while they run (:func:`sandbox.sim.seams.set_seam_springs`).
        """
        if not self._pieces:
            raise SandboxError("the scene has no cloth piece")
        xs, vs, uvs, masses, pins, tri_all, rinv, areas, stiff = ([] for _ in range(9))
        grain_uvs = []
        h_idx, h_rest, h_k = [], [], []
        pieces = []
        offset = tri_offset = 0
        for pc in self._pieces:
            uv, tris, mat = pc["uv"], pc["tris"], pc["material"]
            n = len(uv)
            rest, dm, area, mass = _rest_shape(pc)
            world = pc["pos"] if pc["pos"] is not None else uv @ pc["rot"][:, :2].T + pc["t"]
            xs.append(world)
            vs.append(np.tile(pc["vel"], (n, 1)))
            uvs.append(uv)
            grain_uvs.append(rest)
            masses.append(mass)
            pins.append(pc["pins"])
            tri_all.append(tris + offset)
            rinv.append(np.linalg.inv(dm))
            areas.append(area)
            stiff.append(
                np.tile([mat.stretch_u_N_m, mat.stretch_v_N_m, mat.shear_N_m], (len(tris), 1))
            )
            hinge_count = 0
            c = None
            if bending:
                hinges = find_hinges(tris)
                weight, phi = hinge_rest_weights(rest, hinges)
                c = bending_calibration(rest, tris, hinges)
                k_b = c * bend_rigidity_at(mat, phi) * weight
                keep = k_b > 0
                h_idx.append(hinges[keep] + offset)
                h_rest.append(np.zeros(int(keep.sum())))
                h_k.append(k_b[keep])
                hinge_count = int(keep.sum())
            pieces.append(
                PieceInfo(
                    name=pc["name"],
                    material=mat,
                    particle_start=offset,
                    particle_count=n,
                    tri_start=tri_offset,
                    tri_count=len(tris),
                    meta=dict(pc["meta"], hinge_count=hinge_count, bending_calibration=c),
                )
            )
            offset += n
            tri_offset += len(tris)
        world_all = np.concatenate(xs)
        self._mass_all = np.concatenate(masses)
        self._mass_all = np.maximum(self._mass_all, MASS_FLOOR_FRACTION * np.median(self._mass_all))
        seam_pairs, seam_rest, seam_k = self._sew(world_all, [p.particle_start for p in pieces])
        hinge_indices = np.concatenate(h_idx) if h_idx else None
        if hinge_indices is not None and len(hinge_indices) == 0:
            hinge_indices = None
        return Model(
            rest_uv=np.concatenate(uvs),
            material_uv=np.concatenate(grain_uvs),
            positions=np.concatenate(xs),
            velocities=np.concatenate(vs),
            mass=self._mass_all,
            pinned=np.concatenate(pins),
            tri_indices=np.concatenate(tri_all),
            tri_rest_inv=np.concatenate(rinv),
            tri_rest_area=np.concatenate(areas),
            tri_stiffness=np.concatenate(stiff).astype(np.float64),
            hinge_indices=hinge_indices,
            hinge_rest_angle=None if hinge_indices is None else np.concatenate(h_rest),
            hinge_stiffness=None if hinge_indices is None else np.concatenate(h_k),
            pieces=pieces,
            seam_pairs=seam_pairs,
            seam_rest=seam_rest,
            seam_stiffness=seam_k,
            seam_capacity=seam_capacity,
        )

    def _sew(self, world: np.ndarray, starts: list[int]):
        """Seam springs of every add_seam call, as global particle pairs (or Nones)."""
        if not self._seams:
            return None, None, None
        pairs, rest, stiff = [], [], []
        self.seam_lines = []
        for sm in self._seams:
            lines = []
            for side in (sm["a"], sm["b"]):
                parts = []
                for k, entry in enumerate(side):
                    piece = entry[0]
                    uv = self._pieces[piece]["uv"]
                    at = f"{sm['where']}: edge {k}"
                    if len(entry) == 3:
                        idx = edge_vertices(uv, entry[1], entry[2], where=at)
                    else:
                        idx = np.asarray(entry[1], dtype=np.int64)
                        if idx.ndim != 1 or len(idx) < 2 or idx.min() < 0 or idx.max() >= len(uv):
                            raise SandboxError(f"{at}: needs 2 or more valid vertex indices")
                    parts.append((idx + starts[piece], uv[idx]))
                lines.append(merge_lines(parts))
            p, r, _ = sew(lines[0], lines[1], world, sm["direction"])
            if sm["k"] is not None:
                k = sm["k"]
            else:
                mean_mass = float(self._mass_all[p.ravel()].mean())
                k = mean_mass * (2.0 * math.pi / SEAM_CLOSE_TIME_S) ** 2
            pairs.append(p)
            rest.append(r)
            stiff.append(np.full(len(p), float(k)))
            self.seam_lines.append(lines)
        return np.concatenate(pairs), np.concatenate(rest), np.concatenate(stiff)


def _rest_shape(pc: dict):
    """One piece's rest shape: material coordinates (n, 2) [m] along warp and weft, the
    rest edge matrices D_m (m, 2, 2), the triangle areas (m,) [m²] and the lumped vertex
    masses (n,) [kg]; SandboxError for a degenerate or clockwise triangle or a vertex that
    belongs to no triangle."""
    uv, tris, mat = pc["uv"], pc["tris"], pc["material"]
    g = pc["grain"]
    warp = np.array([math.cos(g), math.sin(g)])
    weft = np.array([-math.sin(g), math.cos(g)])
    rest = np.stack([uv @ warp, uv @ weft], axis=1)  # (u, v) material coordinates
    d1 = rest[tris[:, 1]] - rest[tris[:, 0]]
    d2 = rest[tris[:, 2]] - rest[tris[:, 0]]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    bad = np.nonzero(np.abs(det) < 2 * MIN_REST_AREA_M2)[0]
    if len(bad):
        raise SandboxError(
            f"{pc['where']}: triangle {int(bad[0])} has zero rest area "
            f"({len(bad)} degenerate triangle(s))"
        )
    if np.any(det < 0):
        raise SandboxError(
            f"{pc['where']}: triangle {int(np.nonzero(det < 0)[0][0])} is clockwise "
            "in the pattern plane; all triangles must be counter-clockwise"
        )
    dm = np.stack([np.stack([d1[:, 0], d2[:, 0]], 1), np.stack([d1[:, 1], d2[:, 1]], 1)], 1)
    area = 0.5 * det
    mass = np.zeros(len(uv))
    np.add.at(mass, tris.ravel(), np.repeat(mat.density_kg_m2 * area / 3.0, 3))
    if np.any(mass <= 0):
        raise SandboxError(f"{pc['where']}: a vertex belongs to no triangle")
    return rest, dm, area, mass
