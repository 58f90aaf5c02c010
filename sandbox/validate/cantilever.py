"""Cantilever validation: the heavy elastica and the Peirce / ASTM D1388 test.

A strip of length L = 10 cm and width 2 cm (validation.md §2's suggested scene) lies on a
platform (its part with u <= 0 is pinned: a clamp with a horizontal tangent) and hangs
over the edge under its own weight. For λ = wL³/B the exact tip position comes from
:mod:`sandbox.validate.elastica`. Each run reports the tip error in % of L and its cost.

The scene goes through the same spec -> builder -> solver -> run loop as any scene file.
"""

from __future__ import annotations

import json
import math
import platform
import time
from dataclasses import dataclass

import numpy as np

from sandbox import runtime
from sandbox.errors import SandboxError
from sandbox.scene.build import build_scene
from sandbox.scene.run import SimulationDiverged, run_scene
from sandbox.scene.spec import ClothSpec, PinSpec, SceneSpec, SimulationSpec, StopSpec
from sandbox.sim.materials import Material
from sandbox.validate.elastica import bend_for, chord_angle_deg, tip

LENGTH_M = 0.10
WIDTH_M = 0.02
DENSITY_KG_M2 = 0.2
STRETCH_N_M = 500.0  # stiff enough that stretch changes the tip by < 0.05 % of L
SHEAR_N_M = 100.0
G = 9.80665
STOP_MAX_M = 2e-6  # per frame: far tighter than the paper's drape rule, for a static answer
STOP_MEAN_M = 1e-6
TIME_LIMIT_S = 30.0
# λ the simulated strip settles for: below, the explicit step (∝ λ^1/2, set by bending)
# makes runs ever longer (260 000 steps at 1e-3 and 5 mm, 30 000 at 1); above, the
# damping 2ω₁ (∝ λ^-1/2) leaves the strip swinging past TIME_LIMIT_S (λ = 1e4 settles
# after 27 s). The reference solves to 1e5.
LAMBDA_RANGE = (1e-3, 1e4)


@dataclass
class CantileverRun:
    lam: float
    edge_length_m: float
    dt_s: float
    tip_error_pct_L: float
    chord_angle_deg: float
    exact_chord_angle_deg: float
    wall_time_s: float
    steps: int
    vertex_count: int
    converged: bool

    def as_dict(self) -> dict:
        return {
            "lambda": self.lam,
            "edge_length_m": self.edge_length_m,
            "dt_s": self.dt_s,
            "tip_error_pct_L": self.tip_error_pct_L,
            "chord_angle_deg": self.chord_angle_deg,
            "exact_chord_angle_deg": self.exact_chord_angle_deg,
            "wall_time_s": self.wall_time_s,
            "steps": self.steps,
            "vertex_count": self.vertex_count,
            "converged": self.converged,
        }


def cantilever_spec(lam: float, edge_length_m: float, dt_s: float | None = None) -> SceneSpec:
    """The cantilever scene for λ, mesh size and time step (None: automatic)."""
    bend = bend_for(lam, DENSITY_KG_M2, LENGTH_M, G)
    material = Material(
        name=f"elastica-lambda-{lam:g}",
        density_kg_m2=DENSITY_KG_M2,
        stretch_u_N_m=STRETCH_N_M,
        stretch_v_N_m=STRETCH_N_M,
        shear_N_m=SHEAR_N_M,
        bend_warp_Nm=bend,
        bend_weft_Nm=bend,
        bend_bias_Nm=bend,
        source="validation.md §2 suggested strip",
    )
    clamp = 2.0 * edge_length_m
    outline = [(-clamp, 0.0), (0.0, 0.0), (LENGTH_M, 0.0), (LENGTH_M, WIDTH_M), (0.0, WIDTH_M),
               (-clamp, WIDTH_M)]  # fmt: skip
    # first bending mode ω1 = 1.875² √(B/(ρ L⁴)); damping γ = 2 ω1 damps it critically
    omega1 = 1.875**2 * math.sqrt(bend / (DENSITY_KG_M2 * LENGTH_M**4))
    cloth = ClothSpec(
        name="strip",
        outline_m=outline,
        edge_length_m=edge_length_m,
        material=material,
        rotation_deg=(-90.0, 0.0, 0.0),  # pattern v -> world -Z: the strip lies horizontal
        pins=[PinSpec(region_m=((-clamp, 0.0), (0.0, WIDTH_M)), where="cantilever clamp")],
        mesh_lines_m=[((0.0, 0.0), (0.0, WIDTH_M))],
        where="cantilever",
    )
    return SceneSpec(
        name=f"cantilever-lambda-{lam:g}",
        simulation=SimulationSpec(dt_s=dt_s, frame_rate_hz=30.0, damping_per_s=2.0 * omega1),
        stop=StopSpec(
            max_displacement_m=STOP_MAX_M,
            mean_displacement_m=STOP_MEAN_M,
            frames=3,
            time_limit_s=TIME_LIMIT_S,
            wall_limit_s=600.0,
        ),  # fmt: skip
        cloths=[cloth],
        source=f"cantilever(lambda={lam:g}, h={edge_length_m:g})",
    )


def run_cantilever(lam: float, edge_length_m: float, dt_scale: float = 1.0) -> CantileverRun:
    """Simulate one cantilever; ``dt_scale`` multiplies the automatic time step."""
    spec = cantilever_spec(lam, edge_length_m)
    scene = build_scene(spec)
    if dt_scale != 1.0:
        spec.simulation.dt_s = scene.dt_s * dt_scale
        scene = build_scene(spec)
    t0 = time.perf_counter()
    try:
        result = run_scene(scene, progress=False)
        converged = result.converged
    except SimulationDiverged:
        return CantileverRun(lam, edge_length_m, scene.dt_s, math.inf, math.nan,
                             chord_angle_deg(*tip(lam)), time.perf_counter() - t0, 0,
                             scene.model.particle_count, False)  # fmt: skip
    wall = time.perf_counter() - t0
    x = result.positions
    uv = scene.model.rest_uv_np
    free_end = np.abs(uv[:, 0] - LENGTH_M) < 1e-9
    root = x[np.abs(uv[:, 0]) < 1e-9].mean(axis=0)
    tip_pos = x[free_end].mean(axis=0)
    reach = (tip_pos[0] - root[0]) / LENGTH_M
    drop = (root[1] - tip_pos[1]) / LENGTH_M
    exact_drop, exact_reach = tip(lam)
    err = 100.0 * math.hypot(drop - exact_drop, reach - exact_reach)
    return CantileverRun(
        lam=lam,
        edge_length_m=edge_length_m,
        dt_s=scene.dt_s,
        tip_error_pct_L=err,
        chord_angle_deg=chord_angle_deg(drop, reach),
        exact_chord_angle_deg=chord_angle_deg(exact_drop, exact_reach),
        wall_time_s=wall,
        steps=result.metrics["steps"],
        vertex_count=scene.model.particle_count,
        converged=converged,
    )


def sweep(lambdas, edge_lengths, dt_scales, on_run=None) -> list[CantileverRun]:
    runs = []
    for lam in lambdas:
        for h in edge_lengths:
            for s in dt_scales:
                r = run_cantilever(lam, h, s)
                runs.append(r)
                if on_run is not None:
                    on_run(r)
    return runs


def check_lambdas(lambdas) -> None:
    """Refuse a λ outside LAMBDA_RANGE before anything is built (SandboxError, one line)."""
    lo, hi = LAMBDA_RANGE
    for lam in lambdas:
        if not lo <= lam <= hi:  # also NaN
            raise SandboxError(f"--lambdas {lam:g}: the cantilever is simulated for {lo:g} <= "
                               f"lambda <= {hi:g} (a stiffer strip needs ever smaller steps, a "
                               f"floppier one does not settle within the {TIME_LIMIT_S:g} s "
                               "time limit)")  # fmt: skip


def main(args) -> int:
    """``python -m sandbox validate cantilever [--json] [--quick] [--lambdas ...]``."""
    lambdas = args.lambdas or [1.0, 8.0, 30.0]
    check_lambdas(lambdas)
    runtime.init(args.arch, float64=args.float64)
    edges = [0.005] if args.quick else [0.005, 0.0025]
    scales = [1.0] if args.quick else [1.0, 0.5]
    if not args.json:
        print(f"Heavy-elastica cantilever, L = {LENGTH_M * 100:g} cm, width {WIDTH_M * 100:g} cm,"
              f" rho_A = {DENSITY_KG_M2} kg/m^2; symplectic Euler, "
              f"{'float64' if runtime.is_float64() else 'float32'}, {platform.machine()} "
              f"({platform.processor() or 'cpu'})")  # fmt: skip
        head = ("lambda", "h [mm]", "dt [us]", "verts", "steps", "chord", "exact", "tip err %L",
                "wall [s]")  # fmt: skip
        widths = (6, 7, 8, 6, 8, 7, 7, 10, 9)
        print(" ".join(f"{h:>{w}}" for h, w in zip(head, widths, strict=True)) + " converged")

    def show(r: CantileverRun):
        if args.json:
            print(json.dumps(r.as_dict()), flush=True)
        else:
            print(f"{r.lam:6g} {r.edge_length_m * 1e3:7.2f} {r.dt_s * 1e6:8.2f} "
                  f"{r.vertex_count:6d} {r.steps:8d} {r.chord_angle_deg:7.2f} "
                  f"{r.exact_chord_angle_deg:7.2f} {r.tip_error_pct_L:10.3f} "
                  f"{r.wall_time_s:9.2f} {r.converged}", flush=True)  # fmt: skip

    sweep(lambdas, edges, scales, on_run=show)
    return 0
