"""The stability matrix: stiffness × dt × integrator, and extreme cases.

Matrix cells: a 20 × 20 cm sheet on a 2 cm mesh starts flat and horizontal and falls,
hanging from its two top corners (damping 1/s). Stiffness rows: the softest measured preset
(``sweater``, E_v = 6.5 N/m), ``denim``, and denim with stretch and shear ×10, ×100, ×1000
(bending as measured). dt columns from 1e-5 s to 1/30 s. One scene is built per row and
integrator and re-run at each dt (state reset), so Taichi compiles once per row.

Each cell runs through the guard (``sandbox.sim.guard``) with a wall-clock cap, and says:
- ``stable``: finished at the asked dt, no rollback;
- ``guarded``: the guard rolled back and shrank dt at least once, and then finished;
- ``failed``: the guard could not recover (its message names the step and the vertex);
- ``wall limit``: the cap stopped it first (the simulated time reached is recorded).
plus the largest warp/weft strain seen at any frame, the rollbacks, the final dt, the wall
time of the loop (compile excluded), and the dt warning when the explicit step asked for is
above the estimated stable limit.

Extreme cases (both integrators at their automatic dt, through the guard): slivers and
near-zero-area triangles, a sheet crumpled to 10 % of its size as the start, a 10 m/s
impact on an arm-sized cylinder, a collider resized by ±30 % in one frame under a
draped sheet (``BodyCollider.update``), and a seam whose two sides start 30 cm apart.
"""

from __future__ import annotations

import contextlib
import math
import time
from dataclasses import dataclass, field

import numpy as np

from sandbox import runtime
from sandbox.pattern.mesh2d import mesh_grid
from sandbox.scene import build as build_mod
from sandbox.scene.build import build_scene
from sandbox.scene.run import SimulationDiverged, run_scene
from sandbox.scene.spec import SceneSpec, scene_from_dict
from sandbox.sim.guard import max_strain
from sandbox.validate.cases import SHORT, scaled_material

ROWS = [("sweater", 1.0), ("denim", 1.0), ("denim", 10.0), ("denim", 100.0), ("denim", 1000.0)]
DTS = [1e-5, 1e-4, 1e-3, 1.0 / 60.0, 1.0 / 30.0]


@dataclass
class Cell:
    """One stability run."""

    case: str
    integrator: str
    dt_s: float
    outcome: str
    max_strain: float | None
    guard_fired: bool
    rollbacks: int
    final_dt_s: float | None
    wall_time_s: float
    sim_time_s: float
    vertices: int
    dt_limit_s: float
    dt_warning: str | None = None
    message: str | None = None
    extra: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        d = dict(self.__dict__)
        for k, v in d.items():
            if isinstance(v, float) and not math.isfinite(v):
                d[k] = None
        return d


def _build(spec: SceneSpec):
    """A new scene; Taichi's field trees of the finished cells are freed first."""
    runtime.recycle()
    return build_scene(spec)


def _run(scene, case: str, wall_limit_s: float, on_frame=None) -> Cell:
    scene.spec.stop.wall_limit_s = wall_limit_s
    integ = scene.spec.simulation.integrator
    scene.solver.reset_stats()
    t0 = time.perf_counter()
    try:
        r = run_scene(scene, progress=False, on_frame=on_frame)
    except SimulationDiverged as exc:
        cause = exc.__cause__
        rollbacks = getattr(cause, "rollbacks", -1)
        return Cell(case, integ, scene.dt_s, "failed", None, True, rollbacks,
                    getattr(cause, "dt_s", None), time.perf_counter() - t0, math.nan,
                    scene.model.particle_count, scene.dt_limit_s, message=str(exc),
                    extra={"failed_at_step": getattr(cause, "step", None),
                           "failed_at_vertex": getattr(cause, "vertex", None)})  # fmt: skip
    m = r.metrics
    outcome = "stable"
    if m["stop_reason"] == "wall-clock limit":
        outcome = "wall limit"
    elif m["guard_fired"]:
        outcome = "guarded"
    strain = max(m["guard_max_strain"], max_strain(scene.model, r.positions))
    extra = {}
    stats = scene.solver.stats()
    if stats:  # an integrator that counts its iterations (implicit Euler)
        extra["unconverged_steps"] = stats["unconverged_steps"]
    for k in ("seam_gap_max_m", "vertices_inside_body", "penetration_max_m",
              "intersecting_triangle_pairs"):  # fmt: skip
        if m.get(k) is not None:
            extra[k] = m[k]
    return Cell(case, integ, scene.dt_s, outcome, strain, m["guard_fired"],
                m["guard_rollbacks"], m["guard_final_dt_s"], m["wall_time_s"], m["sim_time_s"],
                scene.model.particle_count, scene.dt_limit_s, m["dt_warning"],
                extra=extra)  # fmt: skip


def _set_dt(scene, dt: float) -> None:
    """Run at ``dt`` (rounded to a whole number of steps per frame). Frames are 1/30 s, or
    200 steps for tiny dt, so the guard and the wall cap look in often enough."""
    scene.spec.simulation.frame_rate_hz = max(30.0, 1.0 / (200.0 * dt))
    frame = 1.0 / scene.spec.simulation.frame_rate_hz
    steps = max(1, math.ceil(frame / dt - 1e-9))
    scene.steps_per_frame = steps
    scene.dt_s = frame / steps
    scene.spec.simulation.dt_s = scene.dt_s


def _reset(scene) -> None:
    scene.state.set(scene.model.initial_positions_np, scene.model.initial_velocities_np)
    scene.solver.reset_watch()


def matrix_spec(preset: str, factor: float, integrator: str, time_s: float) -> SceneSpec:
    data = {
        "scene": {"name": "stability-sheet"},
        "simulation": {"integrator": integrator, "damping_per_s": 1.0, "frame_rate_hz": 30},
        "stop": {"time_limit_s": time_s},
        "cloth": [{"name": "sheet", "size_m": [0.2, 0.2], "edge_length_m": 0.02,
                   "material": preset, "origin_m": [-0.1, 0.5, 0.1],
                   "rotation_deg": [-90.0, 0.0, 0.0], "pins": [{"corners": "top"}]}],
    }  # fmt: skip
    spec = scene_from_dict(data, source=f"stability:{preset}x{factor:g}")
    spec.cloths[0].material = scaled_material(preset, factor)
    spec.stop.max_displacement_m = 0.0  # run the whole simulated time
    spec.stop.mean_displacement_m = 0.0
    return spec


def stability_matrix(rows, dts, integrators, time_s: float, wall_limit_s: float,
                     on_cell=None) -> list[Cell]:  # fmt: skip
    cells = []
    for preset, factor in rows:
        for integ in integrators:
            scene = _build(matrix_spec(preset, factor, integ, time_s))
            for dt in dts:
                _set_dt(scene, dt)
                _reset(scene)
                c = _run(scene, f"{preset} x{factor:g}", wall_limit_s)
                c.extra["asked_dt_s"] = dt
                cells.append(c)
                if on_cell:
                    on_cell(c)
    return cells


# ---------------------------------------------------------------------------- extremes
@contextlib.contextmanager
def _custom_mesh(uv: np.ndarray, tris: np.ndarray):
    """Make ``build_scene`` use this pattern mesh for every cloth (slivers on purpose)."""
    original = build_mod.mesh_cloth
    build_mod.mesh_cloth = lambda c: (uv.copy(), tris.copy())
    try:
        yield
    finally:
        build_mod.mesh_cloth = original


def _sheet(name: str, integrator: str, time_s: float, **over) -> dict:
    data = {
        "scene": {"name": name},
        "simulation": {"integrator": integrator, "damping_per_s": 1.0, "frame_rate_hz": 30},
        "stop": {"time_limit_s": time_s},
        "collision": {"self_collision": False},
        "cloth": [{"name": "sheet", "size_m": [0.2, 0.2], "edge_length_m": 0.02,
                   "material": "jersey", "origin_m": [-0.1, 0.5, 0.1],
                   "rotation_deg": [-90.0, 0.0, 0.0], "pins": [{"corners": "top"}]}],
    }  # fmt: skip
    for k, v in over.items():
        if k == "cloth":
            data["cloth"][0].update(v)
        elif isinstance(v, dict):
            data.setdefault(k, {}).update(v)
        else:
            data[k] = v
    return data


def _spec(data: dict) -> SceneSpec:
    spec = scene_from_dict(data, source=f"stability:{data['scene']['name']}")
    spec.stop.max_displacement_m = 0.0
    spec.stop.mean_displacement_m = 0.0
    return spec


def slivers_case(integrator: str, time_s: float, wall: float, dt_s=None) -> Cell:
    """A 20 cm grid whose 6th column of vertices sits 10 µm from the 5th: a row of slivers
    with near-zero area (aspect ratio 2000)."""
    uv, tris = mesh_grid(0.2, 0.2, 0.02)
    xs = np.unique(np.round(uv[:, 0], 9))
    col = np.abs(uv[:, 0] - xs[5]) < 1e-9
    uv[col, 0] = xs[4] + 1e-5
    spec = _spec(_sheet("slivers", integrator, time_s))
    spec.simulation.dt_s = dt_s
    with _custom_mesh(uv, tris):
        scene = _build(spec)
    c = _run(scene, "slivers (10 µm wide)", wall)
    area = 0.5 * np.abs(np.cross(uv[tris[:, 1]] - uv[tris[:, 0]], uv[tris[:, 2]] - uv[tris[:, 0]]))
    c.extra["min_rest_area_m2"] = float(area.min())
    return c


def crumpled_case(integrator: str, time_s: float, wall: float) -> Cell:
    """Start crumpled to 10 % of the sheet's size (random 1 cm out-of-plane), one corner
    pinned, gravity on."""
    spec = _spec(_sheet("crumpled", integrator, time_s, cloth={"pins": [{"vertices": [0]}]}))
    scene = _build(spec)
    x0 = scene.model.initial_positions_np
    centre = x0.mean(axis=0)
    rng = np.random.default_rng(7)
    x = centre + 0.1 * (x0 - centre) + rng.uniform(-0.005, 0.005, x0.shape)
    scene.state.set(x, np.zeros_like(x))
    c = _run(scene, "crumpled to 10 %", wall)
    c.extra["start_max_strain"] = max_strain(scene.model, x)
    return c


def impact_case(integrator: str, time_s: float, wall: float) -> Cell:
    """A 30 cm jersey sheet thrown at 10 m/s at an arm (cylinder r = 3 cm), no gravity."""
    data = _sheet(
        "impact",
        integrator,
        time_s,
        cloth={"size_m": [0.3, 0.3], "edge_length_m": 0.015, "origin_m": [-0.15, -0.15, 0.1],
               "rotation_deg": [0.0, 0.0, 0.0], "velocity_m_s": [0.0, 0.0, -10.0], "pins": []},
        simulation={"gravity_m_s2": [0.0, 0.0, 0.0], "damping_per_s": 0.0},
        collision={"thickness_m": 0.003},
        collider=[{"name": "arm", "shape": "cylinder", "center_m": [0, 0, 0], "radius_m": 0.03,
                   "height_m": 0.6, "rotation_deg": [0, 0, 90]}],
    )  # fmt: skip
    scene = _build(_spec(data))
    inside = []

    def watch(sc, frame):
        x = sc.state.positions()
        radial = np.linalg.norm(x[:, [1, 2]], axis=1)
        inside.append(int(((radial < 0.03) & (np.abs(x[:, 0]) < 0.3)).sum()))

    c = _run(scene, "10 m/s impact on an arm", wall, on_frame=watch)
    c.extra["max_vertices_inside_arm"] = max(inside) if inside else None
    return c


def resize_cases(integrator: str, time_s: float, wall: float, scales=(1.3, 0.7),
                 ramp_frames: int = 1) -> list[Cell]:  # fmt: skip
    """A sheet draped over a sphere (r = 8 cm); at t = time/2 the sphere is resized by the
    scale (``BodyCollider.update``) in one frame, or linearly over ``ramp_frames``."""
    data = _sheet(
        "resize",
        integrator,
        time_s,
        cloth={"size_m": [0.4, 0.4], "origin_m": [-0.2, 0.1, 0.2], "pins": []},
        collision={"thickness_m": 0.003},
        collider=[{"name": "ball", "shape": "sphere", "center_m": [0, 0, 0], "radius_m": 0.08}],
    )  # fmt: skip
    scene = _build(_spec(data))
    body = scene.model.colliders[0]
    v0 = body.body_x.to_numpy()[: body.vertex_count].astype(np.float64)
    frames = round(time_s * scene.spec.simulation.frame_rate_hz)
    cells = []
    for s in scales:
        _reset(scene)
        body.update(v0)

        def resize(sc, frame, s=s):
            k = frame - frames // 2 + 1
            if 1 <= k <= ramp_frames:
                body.update(v0 * (1.0 + (s - 1.0) * k / ramp_frames))

        how = "in one frame" if ramp_frames == 1 else f"over {ramp_frames} frames"
        c = _run(scene, f"collider resized x{s:g} {how}", wall, on_frame=resize)
        x = scene.state.positions()
        c.extra["min_distance_to_centre_over_radius"] = float(
            np.linalg.norm(x, axis=1).min() / (0.08 * s)
        )
        cells.append(c)
    body.update(v0)
    return cells


def seam_gap_case(integrator: str, time_s: float, wall: float) -> Cell:
    """Two 20 × 30 cm jersey panels whose sewn edges start 30 cm apart, no gravity."""
    data = {
        "scene": {"name": "seam-gap"},
        "simulation": {"integrator": integrator, "gravity_m_s2": [0, 0, 0],
                       "damping_per_s": 5.0},
        "stop": {"time_limit_s": time_s},
        "cloth": [
            {"name": "left", "size_m": [0.2, 0.3], "edge_length_m": 0.02, "material": "jersey",
             "origin_m": [-0.35, 0, 0]},
            {"name": "right", "size_m": [0.2, 0.3], "edge_length_m": 0.02, "material": "jersey",
             "origin_m": [0.35, 0, 0], "rotation_deg": [0, 180, 0]},
        ],
        "seam": [{"name": "middle", "a": [{"cloth": "left", "edge": 1}],
                  "b": [{"cloth": "right", "edge": 1}]}],
    }  # fmt: skip
    scene = _build(_spec(data))
    c = _run(scene, "seam with a 30 cm gap", wall)
    return c


def extremes(integrators, time_s: float, wall: float, on_cell=None, ramp: bool = False
             ) -> list[Cell]:  # fmt: skip
    cells = []

    def add(c):
        cells.append(c)
        if on_cell:
            on_cell(c)

    for integ in integrators:
        add(slivers_case(integ, time_s, wall))
        if integ == "symplectic_euler":  # the automatic dt is tiny: also at 1e-4 s, guarded
            add(slivers_case(integ, time_s, wall, dt_s=1e-4))
        add(crumpled_case(integ, time_s, wall))
        add(impact_case(integ, min(time_s, 0.1), wall))
        for c in resize_cases(integ, time_s, wall):
            add(c)
        if ramp:  # the same +30 % spread over 10 frames (1/3 s)
            for c in resize_cases(integ, time_s, wall, scales=(1.3,), ramp_frames=10):
                add(c)
        add(seam_gap_case(integ, max(time_s, 1.0), wall))
    return cells


def cell_row(c: Cell) -> str:
    strain = "—" if c.max_strain is None else f"{c.max_strain:.3g}"
    final = "—" if c.final_dt_s is None else f"{c.final_dt_s:.3g}"
    rb = "—" if c.rollbacks < 0 else str(c.rollbacks)
    return (f"| {c.case} | {SHORT[c.integrator]} | {c.dt_s:.3g} | {c.outcome} | {strain} | "
            f"{'yes' if c.guard_fired else 'no'} | {rb} | {final} | {c.wall_time_s:.2f} | "
            f"{c.sim_time_s:.3g} |")  # fmt: skip
