"""Rigid impact zones (Bridson et al. 2002 §7.4), self-collision's fail-safe.

If collisions remain after the passes, the vertices of the colliding pairs are merged into
zones that move rigidly for this step (their linear and angular momentum kept; a zone with
a pinned vertex stands still), growing until no pair collides. This runs in numpy, outside
the step kernel, and is rare.

Zones that still collide after ``zone_rounds`` rounds (zones pressed together from several
sides, each rigid motion driving into the next) are stopped for the step: every vertex of a
zone gets zero velocity, and vertices that then collide join the stopped set. Vertices that
stand still cannot meet, so this always ends; pairs still reported once all their vertices
stand still touched at the step's start (closer than the contact test's tolerance, a
crossing left by an earlier step) and go no deeper: they are counted
(``touching_at_start``) and left to the repair passes. A step that needed this is counted
(``freeze_steps``, in the run's ``self_collision_counts`` metrics) instead of aborting the
run.

A mixin of :class:`sandbox.collision.self_contact.SelfCollider` (its fields and settings).
"""

import numpy as np
import taichi as ti

from sandbox import runtime


class ImpactZones:
    """Mark the pairs that still collide and move their zones rigidly."""

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
        for _ in range(self.config.zone_rounds):
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
        self._freeze_zones(state_x, state_v, dt, in_zone)

    def _freeze_zones(self, state_x, state_v, dt: float, still: np.ndarray) -> None:
        """Stop the vertices ``still`` (n,) bool, and any vertex that then collides, for this
        step (zero velocity and correction) until no candidate pair collides."""
        n = self.model.particle_count
        ftype = runtime.float_dtype()
        self.freeze_steps += 1
        while True:  # each round stops at least one more vertex, or ends
            v = state_v.to_numpy()
            corr = self.corr.to_numpy()
            v[:n][still] = 0.0
            corr[:n][still] = 0.0
            state_v.from_numpy(v.astype(ftype))
            self.corr.from_numpy(corr.astype(ftype))
            hits = self._mark_kernel(state_x, state_v, dt)
            if hits == 0:
                self.frozen_vertices_max = max(self.frozen_vertices_max, int(still.sum()))
                return
            quads = np.zeros((hits, 4), np.int32)
            self.hit_fill[None] = 0
            self._marked_quads_kernel(quads)
            grown = still.copy()
            grown[quads.ravel()] = True
            if grown.sum() == still.sum():
                # only pairs of stopped vertices are left: they touched at the step's start
                # (closer than the contact test's tolerance) and, standing still, go no
                # deeper; the repair passes separate such pairs
                self.frozen_vertices_max = max(self.frozen_vertices_max, int(still.sum()))
                self.touching_at_start += hits
                return
            still = grown

    def collision_counts(self) -> dict:
        """Counters since construction: steps that needed rigid impact zones, steps whose
        zones had to be stopped, the most vertices stopped in one step, list overflows."""
        return {"impact_zone_steps": int(self.zone_steps),
                "freeze_steps": int(self.freeze_steps),
                "frozen_vertices_max": int(self.frozen_vertices_max),
                "touching_at_start": int(self.touching_at_start),
                "overflow_steps": int(self.overflow_steps)}  # fmt: skip

    @ti.kernel
    def _mark_kernel(self, x: ti.template(), v: ti.template(), dt: float) -> ti.i32:
        hits = 0
        for p in range(ti.min(self.pair_count[None], self.capacity)):
            hit, W, n, g0 = self._collision(self.pair_kind[p], self.pair[p], x, v, dt)
            self.pair_hit[p] = 1 if hit else 0
            if hit:
                hits += 1
        return hits

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
