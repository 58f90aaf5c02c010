"""Validation scenes of the error-against-run-time report.

Each ``*_case`` function builds one scene for an integrator, a time step and a mesh size,
runs it through the guarded run loop (``sandbox.scene.run.run_scene``) with a wall-clock
cap, and returns a :class:`CaseRun`: the error against the case's reference in percent,
the wall time of the simulation loop (compile excluded), and what happened (finished,
rolled back by the guard, stopped by the wall cap, or failed).

References:
- cantilever / heavy elastica: exact tip from :mod:`sandbox.validate.elastica`, error
  |tip − exact| in % of L (validation.md §1–2);
- uniaxial strip (§6a): a strip hanging under its own weight; the model's exact extension
  δ = ρ_A g L²/(2 E_v) (no Poisson coupling in the paper's Eq. 7, so the sides stay
  straight). Error: |δ − δ_exact|/δ_exact in %. The lateral contraction is recorded next
  to the StVK prediction ε_y = −ν ε_x (ν = 0.3, §6a's first material);
- hanging sheet: the two free bottom corners and the top edge's sag against a very fine
  explicit run (finer mesh, a quarter of the automatic step), in % of the sheet size;
- friction incline: a square sliding down 30° with μ = 0.2: the acceleration against
  g (sin α − μ cos α), in %.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from sandbox import runtime
from sandbox.scene.build import build_scene, rotation_matrix
from sandbox.scene.run import SimulationDiverged, run_scene
from sandbox.scene.spec import SceneSpec, scene_from_dict
from sandbox.sim.guard import max_strain
from sandbox.sim.materials import material_from_spec
from sandbox.validate import cantilever as cl
from sandbox.validate.elastica import tip

G = 9.80665
INTEGRATORS = ("symplectic_euler", "implicit_euler")
SHORT = {"symplectic_euler": "symplectic", "implicit_euler": "implicit"}


@dataclass
class CaseRun:
    """One run of one validation scene. Errors in %, times in s, lengths in m."""

    case: str
    integrator: str
    dt_s: float
    edge_length_m: float
    vertices: int
    error_pct: float
    error_of: str
    wall_time_s: float
    compile_time_s: float
    steps: int
    sim_time_s: float
    outcome: str  # "ok", "guarded", "wall limit", "failed"
    guard_rollbacks: int = 0
    guard_final_dt_s: float | None = None
    max_strain: float | None = None
    newton_per_step: float | None = None
    cg_per_step: float | None = None
    params: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        d = asdict(self)
        for k, v in d.items():
            if isinstance(v, float) and not math.isfinite(v):
                d[k] = None  # JSON has no NaN/inf
        return d


def _execute(spec: SceneSpec, integrator: str, dt_s: float | None, wall_limit_s: float,
             on_frame=None):  # fmt: skip
    """Build and run; returns (scene, RunResult or None, error message or None, build s)."""
    runtime.recycle()  # the cases before this one are data now: free Taichi's field trees
    spec.simulation.integrator = integrator
    spec.simulation.dt_s = dt_s
    spec.stop.wall_limit_s = wall_limit_s
    t0 = time.perf_counter()
    scene = build_scene(spec)
    build_s = time.perf_counter() - t0
    try:
        return scene, run_scene(scene, progress=False, on_frame=on_frame), None, build_s
    except SimulationDiverged as exc:
        return scene, None, str(exc), build_s


def _finish(case, integrator, h, scene, result, failure, error, of, params, extra=None):
    if result is None:
        return CaseRun(case, integrator, scene.dt_s, h, scene.model.particle_count, math.nan,
                       of, math.nan, math.nan, 0, 0.0, "failed", params=params,
                       extra={"message": failure, **(extra or {})})  # fmt: skip
    m = result.metrics
    outcome = "ok"
    if m["stop_reason"] == "wall-clock limit":
        outcome = "wall limit"
    elif m["guard_fired"]:
        outcome = "guarded"
    stats = scene.solver.stats()
    newton = cg = None
    if stats and stats["steps"]:
        newton = stats["newton_iterations"] / stats["steps"]
        cg = stats["cg_iterations"] / stats["steps"]
        extra = {**(extra or {}), "unconverged_steps": stats["unconverged_steps"]}
    return CaseRun(
        case=case, integrator=integrator, dt_s=scene.dt_s, edge_length_m=h,
        vertices=scene.model.particle_count, error_pct=error, error_of=of,
        wall_time_s=m["wall_time_s"], compile_time_s=m["compile_time_s"], steps=m["steps"],
        sim_time_s=m["sim_time_s"], outcome=outcome, guard_rollbacks=m["guard_rollbacks"],
        guard_final_dt_s=m["guard_final_dt_s"],
        max_strain=max_strain(scene.model, result.positions),
        newton_per_step=newton, cg_per_step=cg, params=params,
        extra={"converged": m["converged"], "stop_reason": m["stop_reason"], **(extra or {})},
    )  # fmt: skip


# ---------------------------------------------------------------------------- cantilever
def cantilever_case(lam: float, h: float, integrator: str, dt_s: float | None = None,
                    wall_limit_s: float = 120.0) -> CaseRun:  # fmt: skip
    """Heavy elastica, λ = wL³/B; error |tip − exact| in % of L (as ``validate cantilever``)."""
    spec = cl.cantilever_spec(lam, h)
    scene, result, failure, _ = _execute(spec, integrator, dt_s, wall_limit_s)
    params = {"lambda": lam}
    if result is None:
        return _finish("cantilever", integrator, h, scene, None, failure, math.nan, "tip % L",
                       params)  # fmt: skip
    x = result.positions
    uv = scene.model.rest_uv_np
    root = x[np.abs(uv[:, 0]) < 1e-9].mean(axis=0)
    tip_pos = x[np.abs(uv[:, 0] - cl.LENGTH_M) < 1e-9].mean(axis=0)
    reach = (tip_pos[0] - root[0]) / cl.LENGTH_M
    drop = (root[1] - tip_pos[1]) / cl.LENGTH_M
    exact_drop, exact_reach = tip(lam)
    err = 100.0 * math.hypot(drop - exact_drop, reach - exact_reach)
    return _finish("cantilever", integrator, h, scene, result, None, err, "tip % L", params,
                   {"drop_over_L": drop, "exact_drop_over_L": exact_drop})  # fmt: skip


# ---------------------------------------------------------------------------- strip (§6a)
STRIP_L, STRIP_W, STRIP_RHO, STRIP_E = 0.2, 0.05, 0.2, 20.0
POISSON_NU = 0.3  # §6a's first material: C12/C22 = 300/1000


def strip_spec(h: float) -> SceneSpec:
    """A 5 × 20 cm strip hanging from its top edge; E_v = 20 N/m along the hang."""
    data = {
        "scene": {"name": "uniaxial-strip"},
        "simulation": {"damping_per_s": 80.0, "frame_rate_hz": 30},
        "stop": {"max_displacement_m": 3e-7, "mean_displacement_m": 1e-7, "frames": 3,
                 "min_time_s": 0.3, "time_limit_s": 3.0},
        "cloth": [{"name": "strip", "size_m": [STRIP_W, STRIP_L], "edge_length_m": h,
                   "material": {"preset": "jersey", "density_kg_m2": STRIP_RHO,
                                "stretch_u_N_m": STRIP_E, "stretch_v_N_m": STRIP_E,
                                "shear_N_m": 5.0, "bend_Nm": 1e-8},
                   "pins": [{"side": "top"}]}],
    }  # fmt: skip
    return scene_from_dict(data, source="report:uniaxial-strip")


def strip_case(h: float, integrator: str, dt_s: float | None = None,
               wall_limit_s: float = 60.0) -> CaseRun:  # fmt: skip
    spec = strip_spec(h)
    scene, result, failure, _ = _execute(spec, integrator, dt_s, wall_limit_s)
    exact = STRIP_RHO * G * STRIP_L**2 / (2.0 * STRIP_E)
    mid_strain = STRIP_RHO * G * (STRIP_L / 2) / STRIP_E
    if result is None:
        return _finish("strip", integrator, h, scene, None, failure, math.nan, "extension %", {})
    x = result.positions
    uv = scene.model.rest_uv_np
    top = np.abs(uv[:, 1] - uv[:, 1].max()) < 1e-9
    bottom = np.abs(uv[:, 1] - uv[:, 1].min()) < 1e-9
    length = x[top, 1].mean() - x[bottom, 1].mean()
    ext = length - STRIP_L
    mid = np.abs(uv[:, 1] - (uv[:, 1].min() + STRIP_L / 2)) < 0.51 * h
    width = x[mid, 0].max() - x[mid, 0].min()
    err = 100.0 * abs(ext - exact) / exact
    extra = {"extension_m": ext, "exact_extension_m": exact,
             "lateral_strain_mid": width / STRIP_W - 1.0,
             "stvk_lateral_strain_mid_nu_0.3": -POISSON_NU * mid_strain,
             "axial_strain_mid_exact": mid_strain}  # fmt: skip
    return _finish("strip", integrator, h, scene, result, None, err, "extension %", {}, extra)


# ---------------------------------------------------------------------------- hanging sheet
SHEET = 0.3


def sheet_spec(h: float, time_s: float) -> SceneSpec:
    """A 30 cm jersey sheet hanging in a vertical plane from its two top corners."""
    data = {
        "scene": {"name": "hanging-sheet"},
        "simulation": {"damping_per_s": 4.0, "frame_rate_hz": 30},
        "stop": {"time_limit_s": time_s},
        "cloth": [{"name": "sheet", "size_m": [SHEET, SHEET], "edge_length_m": h,
                   "material": "jersey", "origin_m": [-SHEET / 2, 0.0, 0.0],
                   "pins": [{"corners": "top"}]}],
    }  # fmt: skip
    spec = scene_from_dict(data, source="report:hanging-sheet")
    spec.stop.max_displacement_m = 0.0  # fixed simulated time: the stop rule never holds
    spec.stop.mean_displacement_m = 0.0
    return spec


def sheet_probe(scene, x: np.ndarray) -> np.ndarray:
    """Mesh-independent points (3, 3) [m]: the two bottom corners and the top edge's middle."""
    uv = scene.model.rest_uv_np
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    targets = [(lo[0], lo[1]), (hi[0], lo[1]), (0.5 * (lo[0] + hi[0]), hi[1])]
    out = []
    for t in targets:
        d = np.linalg.norm(uv - np.asarray(t), axis=1)
        out.append(x[int(np.argmin(d))])
    return np.array(out)


def sheet_reference(h: float, dt_factor: float, time_s: float, wall_limit_s: float) -> dict:
    """The fine explicit reference: probe points and its cost."""
    runtime.recycle()
    spec = sheet_spec(h, time_s)
    spec.simulation.integrator = "symplectic_euler"
    scene = build_scene(spec)
    spec.simulation.dt_s = scene.dt_s * dt_factor
    scene, result, failure, _ = _execute(spec, "symplectic_euler", spec.simulation.dt_s,
                                         wall_limit_s)  # fmt: skip
    if result is None:
        raise SimulationDiverged(f"hanging-sheet reference failed: {failure}")
    return {"probe": sheet_probe(scene, result.positions), "edge_length_m": h,
            "dt_s": scene.dt_s, "wall_time_s": result.metrics["wall_time_s"],
            "vertices": scene.model.particle_count,
            "max_strain": max_strain(scene.model, result.positions),
            "stop_reason": result.metrics["stop_reason"]}  # fmt: skip


def sheet_case(h: float, integrator: str, reference: dict, time_s: float,
               dt_s: float | None = None, wall_limit_s: float = 60.0) -> CaseRun:  # fmt: skip
    spec = sheet_spec(h, time_s)
    scene, result, failure, _ = _execute(spec, integrator, dt_s, wall_limit_s)
    if result is None:
        return _finish("sheet", integrator, h, scene, None, failure, math.nan, "corners % L", {})
    p = sheet_probe(scene, result.positions)
    err = 100.0 * float(np.linalg.norm(p - reference["probe"], axis=1).max()) / SHEET
    run = _finish("sheet", integrator, h, scene, result, None, err, "corners % L", {},
                  {"reference_edge_length_m": reference["edge_length_m"],
                   "reference_dt_s": reference["dt_s"]})  # fmt: skip
    run.extra["max_strain_minus_reference"] = run.max_strain - reference["max_strain"]
    return run


# ---------------------------------------------------------------------------- incline
INCLINE_DEG, INCLINE_MU, INCLINE_T = 30.0, 0.2, 0.3


def incline_spec(h: float, mu: float = INCLINE_MU) -> tuple[SceneSpec, np.ndarray]:
    """A 10 cm denim square on a 30° plane with friction μ (default 0.2); returns (spec,
    down-slope unit)."""
    alpha = math.radians(INCLINE_DEG)
    n = np.array([0.0, math.cos(alpha), math.sin(alpha)])
    gap = 0.003
    rot = [-90.0 + INCLINE_DEG, 0.0, 0.0]
    origin = rotation_matrix(rot) @ np.array([-0.05, -0.05, 0.0]) + gap * n
    data = {
        "scene": {"name": "friction-incline"},
        "simulation": {"damping_per_s": 0.0, "frame_rate_hz": 30},
        "stop": {"time_limit_s": INCLINE_T},
        "collision": {"thickness_m": gap, "friction_static": mu,
                      "friction_kinetic": mu, "self_collision": False},
        "cloth": [{"name": "square", "size_m": [0.1, 0.1], "edge_length_m": h,
                   "material": "denim", "origin_m": origin.tolist(), "rotation_deg": rot}],
        "collider": [{"name": "slope", "shape": "plane", "point_m": [0, 0, 0],
                      "normal": n.tolist(), "size_m": 4.0}],
    }  # fmt: skip
    spec = scene_from_dict(data, source="report:friction-incline")
    spec.stop.max_displacement_m = 0.0
    spec.stop.mean_displacement_m = 0.0
    down = np.array([0.0, -math.sin(alpha), math.cos(alpha)])
    down -= down.dot(n) * n
    return spec, down / np.linalg.norm(down)


def incline_case(h: float, integrator: str, dt_s: float | None = None,
                 wall_limit_s: float = 60.0, mu: float = INCLINE_MU) -> CaseRun:  # fmt: skip
    """The incline run at mesh edge ``h`` [m]: its acceleration against Coulomb's
    g (sin α − μ cos α)."""
    spec, down = incline_spec(h, mu)
    scene, result, failure, _ = _execute(spec, integrator, dt_s, wall_limit_s)
    alpha = math.radians(INCLINE_DEG)
    exact = G * (math.sin(alpha) - mu * math.cos(alpha))
    if result is None:
        return _finish("incline", integrator, h, scene, None, failure, math.nan, "accel %", {})
    x0 = scene.model.initial_positions_np.mean(axis=0)
    travelled = float((result.positions.mean(axis=0) - x0) @ down)
    t = result.metrics["sim_time_s"]
    a = 2.0 * travelled / t**2
    err = 100.0 * abs(a - exact) / exact
    return _finish("incline", integrator, h, scene, result, None, err, "accel %",
                   {"angle_deg": INCLINE_DEG, "mu": mu},
                   {"acceleration_m_s2": a, "exact_m_s2": exact})  # fmt: skip


def scaled_material(preset: str, factor: float, *, bending: bool = False):
    """A preset with stretch and shear (and bending if asked) multiplied by ``factor``."""
    m = material_from_spec(preset, where=f"material {preset!r}")
    over = {"stretch_u_N_m": m.stretch_u_N_m * factor, "stretch_v_N_m": m.stretch_v_N_m * factor,
            "shear_N_m": m.shear_N_m * factor}  # fmt: skip
    if bending:
        over.update(bend_warp_Nm=m.bend_warp_Nm * factor, bend_weft_Nm=m.bend_weft_Nm * factor,
                    bend_bias_Nm=m.bend_bias_Nm * factor)  # fmt: skip
    return replace(m, name=f"{preset} x{factor:g}", **over)


# ---------------------------------------------------------------------------- presets ×100
def preset_spec(preset: str, factor: float, time_s: float) -> SceneSpec:
    """30 × 30 cm sheet, 3 cm grid, flat and horizontal, hanging from two corners."""
    data = {
        "scene": {"name": f"preset-{preset}-x{factor:g}"},
        "simulation": {"damping_per_s": 8.0, "frame_rate_hz": 30},
        "stop": {"time_limit_s": time_s},
        "cloth": [{"name": "sheet", "size_m": [SHEET, SHEET], "edge_length_m": 0.03,
                   "mesher": "grid", "material": preset, "origin_m": [-SHEET / 2, 0.5, 0.15],
                   "rotation_deg": [-90.0, 0.0, 0.0], "pins": [{"corners": "top"}]}],
    }  # fmt: skip
    spec = scene_from_dict(data, source=f"report:preset-{preset}")
    spec.cloths[0].material = scaled_material(preset, factor)
    spec.stop.max_displacement_m = 0.0
    spec.stop.mean_displacement_m = 0.0
    return spec


def preset_x100(preset: str, time_s: float, wall_limit_s: float, factor: float = 100.0) -> dict:
    """Implicit Euler at 1/60 s against symplectic Euler at its stable step, same scene."""
    runtime.recycle()
    out = {"preset": preset, "factor": factor, "time_s": time_s}
    res = {}
    for integ in INTEGRATORS:
        scene, result, failure, _ = _execute(preset_spec(preset, factor, time_s), integ, None,
                                             wall_limit_s)  # fmt: skip
        res[integ] = (scene, result, failure)
    (rs, rr, rf), (is_, ir, if_) = res["symplectic_euler"], res["implicit_euler"]
    out["ref_dt_s"], out["implicit_dt_s"] = rs.dt_s, is_.dt_s
    nan = ir is None or not np.isfinite(ir.positions).all()
    out["nan"] = bool(nan)
    out["implicit_failure"] = if_
    out["reference_failure"] = rf
    if rr is None or ir is None:
        out.update(ref_wall_s=math.nan, implicit_wall_s=math.nan, ref_max_strain=math.nan,
                   implicit_max_strain=math.nan, ref_sag_m=math.nan, implicit_sag_m=math.nan,
                   dsag_over_L=math.inf, dstrain=math.inf, max_dx_over_L=math.inf,
                   rollbacks=-1, unconverged_steps=-1)  # fmt: skip
        return out
    xr, xi = rr.positions, ir.positions
    top = max(xr[:, 1].max(), xi[:, 1].max())
    sag_r, sag_i = float(top - xr[:, 1].min()), float(top - xi[:, 1].min())
    st = is_.solver.stats()
    out.update(
        ref_wall_s=rr.metrics["wall_time_s"], implicit_wall_s=ir.metrics["wall_time_s"],
        ref_max_strain=max_strain(rs.model, xr), implicit_max_strain=max_strain(is_.model, xi),
        ref_sag_m=sag_r, implicit_sag_m=sag_i, dsag_over_L=abs(sag_r - sag_i) / SHEET,
        max_dx_over_L=float(np.linalg.norm(xr - xi, axis=1).max()) / SHEET,
        rollbacks=ir.metrics["guard_rollbacks"], ref_rollbacks=rr.metrics["guard_rollbacks"],
        unconverged_steps=st["unconverged_steps"],
        ref_stop_reason=rr.metrics["stop_reason"], implicit_stop_reason=ir.metrics["stop_reason"],
    )  # fmt: skip
    out["dstrain"] = abs(out["ref_max_strain"] - out["implicit_max_strain"])
    return out
