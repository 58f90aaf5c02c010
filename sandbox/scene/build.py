"""Build a runnable scene from a checked :class:`SceneSpec`.

mesh each piece (numpy) -> resolve pins -> ModelBuilder -> Model, State, Control, Solver.
All input checks happen before ``finalize()``, so bad input never reaches a kernel.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from sandbox import runtime
from sandbox.collision.self_contact_config import SelfContactConfig
from sandbox.errors import SandboxError
from sandbox.pattern.mesh2d import mesh_grid, mesh_polygon
from sandbox.scene.budget import (
    ResourceLimits,
    check_size,
    log_built,
    mesher_limits,
    scene_size,
)
from sandbox.scene.spec import ClothSpec, PinSpec, SceneSpec
from sandbox.sim.builder import ModelBuilder
from sandbox.sim.implicit_config import ImplicitConfig
from sandbox.sim.integrator import Integrator
from sandbox.sim.model import Control, Model, State
from sandbox.sim.solver import SymplecticEulerSolver

if TYPE_CHECKING:
    from sandbox.garment.build import GarmentContext

DT_SAFETY = 0.9
"""Fraction of the estimated explicit stability limit used when ``dt_s = "auto"``."""

IMPLICIT_DT_S = 1.0 / 60.0
"""``dt_s = "auto"`` with ``integrator = "implicit_euler"``: 1/60 s, or one frame if shorter."""


@dataclass
class Scene:
    """Everything one run needs. ``dt_s`` is the step actually used [s]."""

    spec: SceneSpec
    model: Model
    state: State
    control: Control
    solver: Integrator
    dt_s: float
    steps_per_frame: int
    dt_limit_s: float
    garment: GarmentContext | None = None
    """A garment scene's pattern, mannequin and settings (:func:`sandbox.garment.build_drape`);
    None for a scene file's scene."""


def mesh_cloth(c: ClothSpec, limits=None) -> tuple[np.ndarray, np.ndarray]:
    """Pattern-plane mesh of one piece: points (n, 2) [m] and triangles (m, 3); ``limits``:
    the mesher's :class:`~sandbox.pattern.limits.PatternLimits` (default: its defaults)."""
    if c.mesher == "grid":
        (x0, y0), _, (x1, y1), _ = c.outline_m
        pts, tris = mesh_grid(x1 - x0, y1 - y0, c.edge_length_m)
        return pts + np.array([x0, y0]), tris
    return mesh_polygon(np.array(c.outline_m), c.edge_length_m, where=c.where,
                        inner_segments=c.mesh_lines_m, limits=limits)  # fmt: skip


def resolve_pins(c: ClothSpec, uv: np.ndarray) -> np.ndarray:
    """Boolean mask (n,) of pinned vertices of one piece."""
    mask = np.zeros(len(uv), bool)
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    tol = 1e-6 * float(np.max(hi - lo))
    for p in c.pins:
        mask |= _pin_mask(p, uv, lo, hi, tol)
    return mask


def _pin_mask(p: PinSpec, uv, lo, hi, tol) -> np.ndarray:
    n = len(uv)
    m = np.zeros(n, bool)
    if p.vertices is not None:
        bad = [i for i in p.vertices if not 0 <= i < n]
        if bad:
            raise SandboxError(
                f"{p.where}.vertices: index {bad[0]} is out of range (the piece has {n} vertices,"
                f" 0..{n - 1})"
            )
        m[p.vertices] = True
    elif p.region_m is not None:
        (u0, v0), (u1, v1) = p.region_m
        m = (uv[:, 0] >= u0 - tol) & (uv[:, 0] <= u1 + tol)
        m &= (uv[:, 1] >= v0 - tol) & (uv[:, 1] <= v1 + tol)
        if not m.any():
            raise SandboxError(f"{p.where}.region_m: no vertex lies inside {p.region_m}")
    elif p.side is not None:
        axis, value = {"top": (1, hi[1]), "bottom": (1, lo[1]), "left": (0, lo[0]),
                       "right": (0, hi[0])}[p.side]  # fmt: skip
        m = np.abs(uv[:, axis] - value) <= tol
    else:
        corners = {"top": [(lo[0], hi[1]), (hi[0], hi[1])],
                   "bottom": [(lo[0], lo[1]), (hi[0], lo[1])],
                   "left": [(lo[0], lo[1]), (lo[0], hi[1])],
                   "right": [(hi[0], lo[1]), (hi[0], hi[1])]}  # fmt: skip
        corners["all"] = corners["top"] + corners["bottom"]
        for q in corners[p.corners]:
            m[int(np.argmin(np.linalg.norm(uv - np.array(q), axis=1)))] = True
    return m


def rotation_matrix(deg) -> np.ndarray:
    """R = Rz Ry Rx from angles in degrees about X, then Y, then Z (world axes)."""
    ax, ay, az = (math.radians(a) for a in deg)
    cx, sx, cy, sy, cz, sz = (math.cos(ax), math.sin(ax), math.cos(ay), math.sin(ay),
                              math.cos(az), math.sin(az))  # fmt: skip
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


def stable_dt_estimate(model: Model) -> float:
    """Estimated explicit stability limit [s] of symplectic Euler for this model.

    Membrane: a vertex of mass m_i tied by stiffness k ≈ Σ_t E_t a_t |∇N|² has ω² = k/m;
    bending: ω² ≈ Σ_h E_b |∇θ_b|² / m. Symplectic Euler is stable for dt·ω_max < 2
    (validation.md §6e); the estimate bounds ω_max by the per-vertex sums (Gershgorin).
    """
    n = model.particle_count
    tris = model.tri_indices_np
    rinv = model.tri_rest_inv_np
    # |∇N_i|² summed over the triangle's vertices, from the rest-shape coefficients
    cu = np.stack([-(rinv[:, 0, 0] + rinv[:, 1, 0]), rinv[:, 0, 0], rinv[:, 1, 0]], 1)
    cv = np.stack([-(rinv[:, 0, 1] + rinv[:, 1, 1]), rinv[:, 0, 1], rinv[:, 1, 1]], 1)
    e = model.tri_stiffness_np
    a = model.tri_rest_area_np
    kmax = np.maximum(np.maximum(e[:, 0], e[:, 1]), 2 * e[:, 2])[:, None]
    k_tri = (
        a[:, None]
        * kmax
        * (np.abs(cu) + np.abs(cv))
        * (np.abs(cu).sum(1, keepdims=True) + np.abs(cv).sum(1, keepdims=True))
    )
    k = np.zeros(n)
    np.add.at(k, tris.ravel(), k_tri.ravel())
    if model.hinge_count:
        h = model.hinge_indices_np
        uv = model.rest_uv_np
        alt = np.minimum(_altitude(uv, h[:, 0], h[:, 1], h[:, 2]),
                         _altitude(uv, h[:, 0], h[:, 1], h[:, 3]))  # fmt: skip
        # |∂θ/∂x| ~ 1/altitude for the opposite vertices; Gershgorin over the 4 vertices
        kb = model.hinge_stiffness_np * (2.0 / alt) * (4.0 / alt)
        np.add.at(k, h.ravel(), np.repeat(kb, 4))
    if model.seam_count:
        np.add.at(k, model.seam_pairs_np.ravel(), np.repeat(model.seam_stiffness_np, 2))
    omega = np.sqrt(k / model.mass_np)
    w = float(omega[~model.pinned_np].max()) if (~model.pinned_np).any() else 0.0
    return 2.0 / w if w > 0 else math.inf


def _altitude(uv, i0, i1, i2):
    e = uv[i1] - uv[i0]
    d = uv[i2] - uv[i0]
    return np.abs(e[:, 0] * d[:, 1] - e[:, 1] * d[:, 0]) / np.linalg.norm(e, axis=1)


def collider_mesh(c) -> tuple[np.ndarray, np.ndarray, bool]:
    """Vertices (m, 3) [m], outward triangles (k, 3) and closedness of one collider."""
    from sandbox.collision import shapes

    p = c.params
    rot = rotation_matrix(p["rotation_deg"]) if "rotation_deg" in p else None
    if c.shape == "sphere":
        return shapes.sphere(p["center_m"], p["radius_m"], p["subdivisions"])
    if c.shape == "box":
        return shapes.box(p["center_m"], p["size_m"], rot)
    if c.shape == "cylinder":
        return shapes.cylinder(p["center_m"], p["radius_m"], p["height_m"], rot)
    if c.shape == "plane":
        return shapes.plane(p["point_m"], p["normal"], p["size_m"])
    if c.shape == "mesh":
        v, f, closed = shapes.mesh_file(p["path"], where=c.where)
        return (v * p["scale"]) @ rot.T + np.asarray(p["origin_m"]), f, closed
    return shapes.mannequin(p["size"], p["measurements_cm"])


def build_collider(c, collision):
    """A BodyCollider (Taichi fields and grid) for one collider spec."""
    from sandbox.collision.body import BodyCollider

    v, f, closed = collider_mesh(c)
    return BodyCollider(
        v, f, thickness_m=collision.thickness_m, friction_static=collision.friction_static,
        friction_kinetic=collision.friction_kinetic, name=c.name, closed=closed,
        face_pass=collision.body_faces,
    )  # fmt: skip


def build_self_collider(model: Model, spec: SceneSpec,
                        config: SelfContactConfig | None = None):  # fmt: skip
    """A SelfCollider if the scene asks for one (by default: when it has a collider), with
    ``config``'s tunables (default: :class:`SelfContactConfig`'s)."""
    wanted = spec.collision.self_collision
    if wanted is None:
        wanted = bool(spec.colliders)
    if not wanted:
        return None
    from sandbox.collision.self_contact import SelfCollider

    return SelfCollider(model, thickness_m=spec.collision.thickness_m,
                        friction=spec.collision.friction_kinetic,
                        config=config or SelfContactConfig())  # fmt: skip


def build_scene(spec: SceneSpec, *, implicit: ImplicitConfig | None = None,
                self_contact: SelfContactConfig | None = None,
                start_runtime=None, limits: ResourceLimits | None = None) -> Scene:  # fmt: skip
    """Mesh, check and allocate a scene. Initialises Taichi on the CPU if nobody did.

    ``implicit`` and ``self_contact`` set the implicit solver's and the self-collision's
    tunables (default: their dataclasses' defaults); the scene's ``[simulation]
    linear_solver`` overrides ``implicit.linear_solver``. ``start_runtime``: called instead
    of :func:`sandbox.runtime.ensure_init` once the meshes and pins are checked (the CLI
    starts Taichi there with its --arch, so that bad input never waits for Taichi). A scene
    predicted over ``limits`` (default: the scene's ``[limits]``) is refused before any
    mesh is built (:mod:`sandbox.scene.budget`)."""
    limits = spec.limits if limits is None else limits
    check_size(scene_size(spec), limits, where=spec.source)
    builder = ModelBuilder()
    meshed = []
    for c in spec.colliders:
        if c.shape == "mesh":  # read (and check) collider files before Taichi starts
            collider_mesh(c)
    for c in spec.cloths:
        uv, tris = mesh_cloth(c, mesher_limits(limits))
        pins = resolve_pins(c, uv)
        meshed.append((c, uv, tris, pins))
    (start_runtime or runtime.ensure_init)()
    for c, uv, tris, pins in meshed:
        builder.add_cloth(
            name=c.name,
            pattern_uv=uv,
            triangles=tris,
            material=c.material,
            rotation=rotation_matrix(c.rotation_deg),
            translation=c.origin_m,
            grain_rad=math.radians(c.grain_deg),
            pinned=pins,
            velocity=c.velocity_m_s,
            where=c.where,
            meta={"mesher": c.mesher},
        )
    index = {c.name: i for i, c in enumerate(spec.cloths)}
    for sm in spec.seams:
        builder.add_seam(
            side_a=[(index[n], a, b) for n, a, b in sm.side_a],
            side_b=[(index[n], a, b) for n, a, b in sm.side_b],
            direction=sm.direction, stiffness_N_m=sm.stiffness_N_m, where=sm.where,
        )  # fmt: skip
    model = builder.finalize(bending=spec.simulation.bending)
    model.colliders = [build_collider(c, spec.collision) for c in spec.colliders]
    if spec.cloths:  # a mannequin's creases thickened for the coarsest cloth on it
        edge = max(c.edge_length_m for c in spec.cloths)
        for c, body in zip(spec.colliders, model.colliders, strict=True):
            if c.shape == "mannequin":
                body.follow_cloth(edge)
    model.self_collider = build_self_collider(model, spec, self_contact)
    scene = scene_from_model(spec, model, implicit)
    log_built(scene)
    return scene


def scene_from_model(spec: SceneSpec, model: Model,
                     implicit: ImplicitConfig | None = None) -> Scene:  # fmt: skip
    """The runnable Scene of a finished model (colliders and self-collider set): the step
    from ``[simulation]`` (``dt_s = "auto"``: :data:`DT_SAFETY` x the stability estimate, or
    :data:`IMPLICIT_DT_S`), a whole number of steps per frame, the control and the solver
    (``implicit``: the implicit solver's settings)."""
    sim = spec.simulation
    frame = 1.0 / sim.frame_rate_hz
    limit = stable_dt_estimate(model)
    model.strain_damping_s[None] = sim.strain_damping_s
    model.seam_damping_ratio[None] = sim.seam_damping_ratio
    model.seam_hold_m[None] = sim.seam_hold_m
    auto = min(frame, IMPLICIT_DT_S if sim.integrator == "implicit_euler" else
               DT_SAFETY * damped_step(limit, sim.strain_damping_s))  # fmt: skip
    dt = sim.dt_s if sim.dt_s is not None else auto
    steps = max(1, math.ceil(frame / dt - 1e-9))
    dt = frame / steps  # a whole number of steps per output frame
    control = model.control(gravity=sim.gravity_m_s2, damping_per_s=sim.damping_per_s)
    solver = make_solver(model, sim.integrator, sim.linear_solver, implicit)
    return Scene(spec, model, model.state(), control, solver, dt, steps, limit)


def retime(scene: Scene, limit_s: float, *, at_most: float = 2.0) -> None:
    """Set the scene's explicit step from a stability limit ``limit_s`` [s] measured on it
    (:func:`~sandbox.sim.stability.measured_stable_dt`): :data:`DT_SAFETY` x the limit,
    shortened for strain damping, at most ``at_most`` x the step it has, a whole number of
    steps per frame."""
    sim = scene.spec.simulation
    frame = 1.0 / sim.frame_rate_hz
    dt = min(DT_SAFETY * damped_step(limit_s, sim.strain_damping_s), at_most * scene.dt_s, frame)
    steps = max(1, math.ceil(frame / dt - 1e-9))
    scene.dt_s = frame / steps
    scene.steps_per_frame = steps
    scene.dt_limit_s = limit_s


def damped_step(limit_s: float, beta_s: float) -> float:
    """The explicit stable step [s] with strain-rate damping β [s]: the undamped limit
    shrinks by √(1+ζ²) − ζ, ζ = β ω_max / 2 = β / limit, for the fastest mode
    (ω_max ≈ 2 / limit; a damped oscillator's explicit limit is (2/ω)(√(1+ζ²) − ζ))."""
    zeta = beta_s / limit_s
    return limit_s * (math.sqrt(1.0 + zeta * zeta) - zeta)


def make_solver(model: Model, integrator: str, linear_solver: str = "auto",
                implicit: ImplicitConfig | None = None) -> Integrator:  # fmt: skip
    """The solver named by ``[simulation] integrator`` (and ``linear_solver``, which
    overrides ``implicit.linear_solver`` unless it is ``"auto"`` and ``implicit`` is given)."""
    if integrator == "implicit_euler":
        from sandbox.sim.implicit import ImplicitEulerSolver

        config = implicit or ImplicitConfig()
        if implicit is None or linear_solver != "auto":
            config = dataclasses.replace(config, linear_solver=linear_solver)
        return ImplicitEulerSolver(model, config=config)
    return SymplecticEulerSolver(model)
