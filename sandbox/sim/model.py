"""Model (static), State (x, v) and Control (live inputs) of a cloth simulation.

The split follows Newton: a :class:`~sandbox.sim.builder.ModelBuilder` collects numpy
arrays and ``finalize()`` allocates the Taichi fields of a :class:`Model` once. The model
never changes during a run; :class:`State` holds what a step changes and :class:`Control`
what a user or script may change between steps (gravity, damping) without recompiling.

Only what the scene needs is allocated: no hinge fields when bending is off
(``model.hinge_count == 0`` and ``model.hinge_indices is None``), no collision structures
when there is nothing to collide with (``model.colliders == []``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import taichi as ti

from sandbox import runtime
from sandbox.errors import SandboxError
from sandbox.sim.upload import upload


@dataclass
class PieceInfo:
    """Where one cloth piece lives in the model's particle and triangle arrays."""

    name: str
    material: object
    particle_start: int
    particle_count: int
    tri_start: int
    tri_count: int
    meta: dict = field(default_factory=dict)


@ti.data_oriented
class Model:
    """Static description of the cloth, in SI units.

    Fields (allocated once, sizes fixed):
      particle_mass       (n,)    [kg] lumped mass, a third of each adjacent triangle's mass
      particle_inv_mass   (n,)    [1/kg] 0 for pinned particles
      tri_indices         (m,)    ivec3, counter-clockwise in the pattern plane
      tri_rest_inv        (m,)    2x2 inverse of the rest edge matrix [[Δu1, Δu2], [Δv1, Δv2]]
                                  (u along the warp, v along the weft) [1/m]
      tri_rest_area       (m,)    rest area a [m^2]
      tri_stiffness       (m,)    vec3 (E_u, E_v, E_s) [N/m]
      hinge_indices       (h,)    ivec4 (edge x0, x1; opposite x2, x3), only with bending
      hinge_rest_angle    (h,)    θ_b at rest [rad]
      hinge_stiffness     (h,)    E_b of Eq. 7 [N·m]: B(φ)·l²/(A0+A1), see docs/model.md
      vert_tri_start/slot         CSR incidence: the corners 3t+c of the triangles at each
                                  particle, so forces are gathered without atomics
      vert_hinge_start/slot       the same for hinge slots 4h+k
      seam_pairs          (S,)    ivec2 particles joined by a seam spring (§2.4), only if the
                                  scene sews (S = seam_capacity >= the live count s)
      seam_rest           (S,)    rest length [m] (0 where the parameters match)
      seam_stiffness      (S,)    spring stiffness [N/m]
      seam_active         ()      the live count s that kernels loop over (set_seams)
    Numpy copies of the inputs stay available as ``*_np`` attributes for writers and tests;
    ``material_uv_np`` (n, 2) [m] are the rest coordinates along warp and weft (the pattern
    coordinates turned by each piece's grain), what textures and strain maps follow.
    """

    def __init__(
        self,
        *,
        rest_uv: np.ndarray,
        positions: np.ndarray,
        velocities: np.ndarray,
        mass: np.ndarray,
        pinned: np.ndarray,
        tri_indices: np.ndarray,
        tri_rest_inv: np.ndarray,
        tri_rest_area: np.ndarray,
        tri_stiffness: np.ndarray,
        hinge_indices: np.ndarray | None,
        hinge_rest_angle: np.ndarray | None,
        hinge_stiffness: np.ndarray | None,
        pieces: list[PieceInfo],
        seam_pairs: np.ndarray | None = None,
        seam_rest: np.ndarray | None = None,
        seam_stiffness: np.ndarray | None = None,
        seam_capacity: int = 0,
        material_uv: np.ndarray | None = None,
    ):
        self.particle_count = int(len(positions))
        self.tri_count = int(len(tri_indices))
        self.hinge_count = 0 if hinge_indices is None else int(len(hinge_indices))
        self.seam_count = 0 if seam_pairs is None else int(len(seam_pairs))
        self.seam_pairs_np = seam_pairs
        self.seam_rest_np = seam_rest
        self.seam_stiffness_np = seam_stiffness
        self.seam_version = 0
        self.pieces = pieces
        self.rest_uv_np = rest_uv
        self.material_uv_np = rest_uv if material_uv is None else material_uv
        self.initial_positions_np = positions
        self.initial_velocities_np = velocities
        self.mass_np = mass
        self.pinned_np = pinned
        self.tri_indices_np = tri_indices
        self.tri_rest_area_np = tri_rest_area
        self.tri_rest_inv_np = tri_rest_inv
        self.tri_stiffness_np = tri_stiffness
        self.hinge_indices_np = hinge_indices
        self.hinge_stiffness_np = hinge_stiffness
        self.colliders: list = []  # BodyColliders, added by the scene only when it has some
        self.self_collider = None  # a SelfCollider, only when the scene asks for one

        n, m, h = self.particle_count, self.tri_count, self.hinge_count
        self.particle_mass = ti.field(float, shape=max(1, n))
        self.particle_inv_mass = ti.field(float, shape=max(1, n))
        self.tri_indices = ti.Vector.field(3, ti.i32, shape=max(1, m))
        self.tri_rest_inv = ti.Matrix.field(2, 2, float, shape=max(1, m))
        self.tri_rest_area = ti.field(float, shape=max(1, m))
        self.tri_stiffness = ti.Vector.field(3, float, shape=max(1, m))
        self.strain_damping_s = ti.field(float, shape=())
        """Strain-rate damping β [s] of the membrane (:func:`~sandbox.sim.forces.
        membrane_damping_gradient`; 0 = off, the default). A 0-D field: set it any time."""
        self.seam_damping_ratio = ti.field(float, shape=())
        """Damping ratio ζ of each seam spring's dashpot, c = 2 ζ √(k μ) with μ the pair's
        reduced mass (0 = off, the default). Without it a stiff seam pair rings at a few
        steps' period for ever, unseen by a stop rule that samples once a frame."""
        self.seam_hold_m = ti.field(float, shape=())
        """How far a sewn stitch may open [m] (0 = no hold, the default; explicit only): the
        solver's seam hold (``SymplecticEulerSolver._seam_hold``) draws each stitch that has
        come close to within this distance and keeps it there, as thread holds a stitch
        however hard the cloth pulls. A 0-D field: set it any time."""
        inv_mass = np.where(pinned, 0.0, 1.0 / np.maximum(mass, 1e-30))
        # every static array in one kernel launch (sandbox.sim.upload)
        loads = [(self.particle_mass, mass), (self.particle_inv_mass, inv_mass),
                 (self.tri_indices, tri_indices), (self.tri_rest_inv, tri_rest_inv),
                 (self.tri_rest_area, tri_rest_area),
                 (self.tri_stiffness, tri_stiffness)]  # fmt: skip
        self.vert_tri_start, self.vert_tri_slot = _incidence(tri_indices, n, loads)
        self.hinge_indices = None
        self.vert_hinge_start = self.vert_hinge_slot = None
        self.hinge_rest_angle = None
        self.hinge_stiffness = None
        self.seam_pairs = self.seam_rest = self.seam_stiffness = None
        self.vert_seam_start = self.vert_seam_slot = self.seam_active = None
        self.seam_limit = None
        if h:
            self.hinge_indices = ti.Vector.field(4, ti.i32, shape=h)
            self.hinge_rest_angle = ti.field(float, shape=h)
            self.hinge_stiffness = ti.field(float, shape=h)
            loads += [(self.hinge_indices, hinge_indices),
                      (self.hinge_rest_angle, hinge_rest_angle),
                      (self.hinge_stiffness, hinge_stiffness)]  # fmt: skip
            self.vert_hinge_start, self.vert_hinge_slot = _incidence(hinge_indices, n, loads)
        upload(loads)
        # Seam fields exist only in a scene that sews, or that may sew live (the app's
        # click-to-sew): ``seam_capacity`` springs are allocated once, ``seam_active`` (0-D)
        # holds the live count the kernels loop over, so sewing never recompiles.
        self.seam_capacity = max(int(seam_capacity), self.seam_count)
        self.has_seams = self.seam_capacity > 0
        if self.has_seams:
            k = self.seam_capacity
            self.seam_pairs = ti.Vector.field(2, ti.i32, shape=k)
            self.seam_rest = ti.field(float, shape=k)
            self.seam_stiffness = ti.field(float, shape=k)
            self.seam_active = ti.field(ti.i32, shape=())
            self.seam_limit = ti.field(float, shape=k)
            """How far each stitch may open now [m], kept by the solver's seam hold once the
            stitch has been caught (it came within a few :attr:`seam_hold_m`); -1 for one
            still being sewn by its spring alone. Reset when the springs are set."""
            self.vert_seam_start = ti.field(ti.i32, shape=n + 1)
            self.vert_seam_slot = ti.field(ti.i32, shape=2 * k)
            empty = np.zeros((0, 2), np.int64)
            self.set_seams(
                empty if seam_pairs is None else seam_pairs,
                np.zeros(0) if seam_rest is None else seam_rest,
                np.zeros(0) if seam_stiffness is None else seam_stiffness,
            )

    def set_seams(self, pairs: np.ndarray, rest: np.ndarray, stiffness: np.ndarray) -> None:
        """Replace the seam springs (§2.4) with ``pairs`` (k, 2) particle indices, ``rest``
        (k,) rest lengths [m] and ``stiffness`` (k,) [N/m]; k <= ``seam_capacity``.

        Updates the numpy copies, the Taichi fields, the per-particle incidence lists and the
        live count; kernels already compiled keep working. See
        :func:`sandbox.sim.seams.set_seam_springs` for the checked public entry point.
        """
        pairs = np.asarray(pairs, np.int64).reshape(-1, 2)
        k = len(pairs)
        if k > self.seam_capacity:
            raise SandboxError(f"{k} seam springs do not fit the model's capacity of "
                               f"{self.seam_capacity}")  # fmt: skip
        rest = np.asarray(rest, float).reshape(k)
        stiffness = np.asarray(stiffness, float).reshape(k)
        cap, n = self.seam_capacity, self.particle_count
        pad_pairs = np.zeros((cap, 2), np.int32)
        pad_pairs[:k] = pairs
        pad_rest = np.zeros(cap)
        pad_rest[:k] = rest
        pad_k = np.zeros(cap)
        pad_k[:k] = stiffness
        start, slot = _incidence_arrays(pairs, n)
        pad_slot = np.zeros(2 * cap, np.int32)
        pad_slot[: len(slot)] = slot
        upload([(self.seam_pairs, pad_pairs), (self.seam_rest, pad_rest),
                (self.seam_stiffness, pad_k), (self.vert_seam_start, start),
                (self.vert_seam_slot, pad_slot)])  # fmt: skip
        self.seam_active[None] = k
        self.seam_limit.fill(-1.0)
        self.seam_count = k
        self.seam_version += 1  # solvers that keep a sparsity pattern rebuild it
        self.seam_pairs_np = pairs if k else None
        self.seam_rest_np = rest if k else None
        self.seam_stiffness_np = stiffness if k else None

    def set_seam_stiffness(self, stiffness: np.ndarray) -> None:
        """New stiffnesses (k,) [N/m] for the live springs (the sewing phase's ramp)."""
        pad = np.zeros(self.seam_capacity)
        pad[: self.seam_count] = np.asarray(stiffness, float).reshape(self.seam_count)
        self.seam_stiffness.from_numpy(_f(pad))

    def state(self) -> State:
        """A new State at the model's initial positions and velocities."""
        s = State(self.particle_count)
        s.set(self.initial_positions_np, self.initial_velocities_np)
        return s

    def control(self, *, gravity=(0.0, -9.80665, 0.0), damping_per_s: float = 0.0) -> Control:
        """A new Control with the given gravity [m/s^2] and damping [1/s]."""
        c = Control()
        c.gravity[None] = ti.Vector(list(gravity))
        c.damping_per_s[None] = damping_per_s
        return c


def _f(a) -> np.ndarray:
    """``a`` as numpy in Taichi's default float type (no precision warnings on copy)."""
    return np.asarray(a, dtype=runtime.float_dtype())


def _incidence_arrays(elements: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """CSR lists of element slots per particle: for particle i the slots
    ``slot[start[i]:start[i+1]]`` are ``k·e + c`` for element e whose corner c is i."""
    flat = np.asarray(elements, dtype=np.int64).ravel()
    order = np.argsort(flat, kind="stable")
    counts = np.bincount(flat, minlength=n)
    start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
    return start, order.astype(np.int32)


def _incidence(elements: np.ndarray, n: int, loads: list):
    """:func:`_incidence_arrays` as Taichi fields ``(start (n+1,), slot (max(1, k·e),))``,
    their contents appended to ``loads`` for :func:`~sandbox.sim.upload.upload`."""
    start, slot = _incidence_arrays(elements, n)
    start_f = ti.field(ti.i32, shape=n + 1)
    slot_f = ti.field(ti.i32, shape=max(1, len(slot)))
    loads += [(start_f, start), (slot_f, slot)]
    return start_f, slot_f


@ti.data_oriented
class State:
    """Time-varying particle data: positions x [m] and velocities v [m/s], shape (n, 3)."""

    def __init__(self, particle_count: int):
        self.particle_count = particle_count
        self.x = ti.Vector.field(3, float, shape=max(1, particle_count))
        self.v = ti.Vector.field(3, float, shape=max(1, particle_count))

    def set(self, x: np.ndarray, v: np.ndarray | None = None) -> None:
        if self.particle_count == 0:
            return
        self.x.from_numpy(_f(x))
        self.v.from_numpy(_f(np.zeros_like(x) if v is None else v))

    def positions(self) -> np.ndarray:
        """Positions as float64 numpy (n, 3) [m]."""
        return self.x.to_numpy()[: self.particle_count].astype(np.float64)

    def velocities(self) -> np.ndarray:
        """Velocities as float64 numpy (n, 3) [m/s]."""
        return self.v.to_numpy()[: self.particle_count].astype(np.float64)


@ti.data_oriented
class Control:
    """Inputs a UI slider or script may change between steps (0-D fields, no recompile).

    gravity        vec3 [m/s^2]
    damping_per_s  mass-proportional viscous damping γ [1/s]: F_damp = −γ m v (0 = off)
    """

    def __init__(self):
        self.gravity = ti.Vector.field(3, float, shape=())
        self.damping_per_s = ti.field(float, shape=())
