"""Explicit step throughput: vertex-steps per second for square sheets (float32, CPU).

Usage: python benchmarks/bench_step.py [--sizes 1000 4000 16000 64000] [--arch cpu]

Builds a hanging cotton sheet with about N vertices through the normal scene path, times
the solver's ``advance`` (the path runs use) and the one-launch-per-step ``step`` path,
and prints the machine it ran on. Target: 20 M vertex-steps/s at 16k vertices.
"""

import argparse
import math
import os
import platform
import time

import taichi as ti

from sandbox import runtime
from sandbox.scene.build import build_scene
from sandbox.scene.spec import scene_from_dict


def sheet(n_vertices: int):
    side = 1.0
    # an irregular mesh has about 1.15 / h² vertices per m² at our mesher's settings
    h = side * math.sqrt(1.15 / n_vertices)
    return scene_from_dict(
        {
            "scene": {"name": f"bench-{n_vertices}"},
            "simulation": {"dt_s": 1e-5, "damping_per_s": 1.0},
            "cloth": [{"name": "sheet", "size_m": [side, side], "edge_length_m": h,
                       "material": "cotton", "pins": [{"side": "top"}]}],
        },
        source="bench",
    )  # fmt: skip


def time_path(scene, use_fused: bool, seconds: float = 3.0) -> float:
    """Vertex-steps per second of ``advance`` with the fused serial launch or without it."""
    from sandbox.sim.solver import SymplecticEulerSolver

    limit = 10**12 if use_fused else -1
    solver = SymplecticEulerSolver(scene.model, fused_particle_limit=limit)
    solver.advance(scene.state, scene.control, scene.dt_s, 5)  # compile + warm up
    ti.sync()
    steps, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        solver.advance(scene.state, scene.control, scene.dt_s, 50)
        steps += 50
    ti.sync()
    return scene.model.particle_count * steps / (time.perf_counter() - t0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1000, 4000, 16000, 64000])
    ap.add_argument("--arch", default="cpu")
    ap.add_argument("--seconds", type=float, default=3.0)
    args = ap.parse_args()
    runtime.init(args.arch, float64=False)  # the target is for the float32 step
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, {platform.processor() or '?'}"
          f", Python {platform.python_version()}, Taichi {'.'.join(map(str, ti.__version__))},"
          f" arch={args.arch}, float32")  # fmt: skip
    print(f"{'vertices':>9} {'triangles':>9} {'hinges':>7} {'serial fused':>14} "
          f"{'parallel step':>14}   [M vertex-steps/s]")  # fmt: skip
    for n in args.sizes:
        scene = build_scene(sheet(n))
        m = scene.model
        fused = time_path(scene, True, args.seconds) / 1e6
        par = time_path(scene, False, args.seconds) / 1e6
        row = f"{m.particle_count:9d} {m.tri_count:9d} {m.hinge_count:7d}"
        print(f"{row} {fused:14.2f} {par:14.2f}", flush=True)


if __name__ == "__main__":
    main()
