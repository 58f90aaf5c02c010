"""A sheet pinned at two corners settles under gravity (symplectic Euler, paper Eq. 2).

The scene is the package's default one, written out here as TOML: a 50 x 50 cm denim
sheet hung by its two top corners. The run loop advances it one frame (1/30 s) at a time
and stops with the paper's rule (§2.2): over one frame, the largest displacement of a free
vertex < 1.5 mm and the mean < 0.1 mm (here for 3 frames in a row).

Printed: frames and simulated time to rest, how far the sheet sags below its pins, and the
warp/weft strain S - 1 of Eq. 6 over the triangles.

    python examples/hanging_sheet.py [--arch cpu] [--quick] [--out DIR]
"""

from __future__ import annotations

import argparse
import time
import tomllib
from pathlib import Path

import numpy as np

from sandbox import runtime
from sandbox.render import render_png
from sandbox.scene.build import build_scene
from sandbox.scene.run import run_scene
from sandbox.scene.spec import scene_from_dict
from sandbox.sim.guard import triangle_stretch

SIZE_M = 0.5  # the sheet is SIZE_M x SIZE_M
EDGE_M = 0.02  # target edge length of the irregular mesh
QUICK_EDGE_M = 0.05  # --quick: a coarse mesh for a smoke test

SCENE = """
[scene]
name = "hanging_sheet"

[simulation]
integrator = "symplectic_euler"   # paper Eq. 2: v += dt F/m, then x += dt v
dt_s = "auto"                     # 0.9 x the estimated explicit stability limit
frame_rate_hz = 30
damping_per_s = 2.0

[stop]                            # the paper's rule, measured over one frame
max_displacement_m = 1.5e-3
mean_displacement_m = 1.0e-4
frames = 3
time_limit_s = 20.0

[[cloth]]
name = "sheet"
size_m = [{size}, {size}]
edge_length_m = {edge}
material = "denim"
origin_m = [{x0}, 0.5, 0.0]          # the pattern's (0, 0) corner in the world
rotation_deg = [-10.0, 0.0, 0.0]    # tilted a little so that it swings
pins = [{{ corners = "top" }}]
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arch", default="cpu", help="Taichi arch: cpu, gpu, cuda, vulkan")
    parser.add_argument("--quick", action="store_true", help="a coarse mesh (seconds)")
    parser.add_argument("--out", type=Path, help="write a PNG of the final sheet here")
    args = parser.parse_args()

    # 1. Set up: Taichi, then the scene from its TOML text (checked before anything runs).
    runtime.init(args.arch)
    edge = QUICK_EDGE_M if args.quick else EDGE_M
    text = SCENE.format(size=SIZE_M, edge=edge, x0=-SIZE_M / 2)
    scene = build_scene(scene_from_dict(tomllib.loads(text), source="hanging_sheet"))
    model = scene.model
    pins = model.initial_positions_np[model.pinned_np]
    print(f"sheet: {model.particle_count} vertices, {model.tri_count} triangles, "
          f"{model.hinge_count} hinges; dt = {scene.dt_s * 1e6:.1f} us "
          f"({scene.steps_per_frame} steps per frame)")  # fmt: skip

    # 2. Simulate until the stop rule holds (or the 20 s limit).
    t0 = time.perf_counter()
    result = run_scene(scene, progress=False)
    wall = time.perf_counter() - t0
    m = result.metrics
    x = result.positions

    # 3. Report: time to rest, sag below the pins, strain (Eq. 6) over the triangles.
    pin_y = pins[:, 1].mean()
    top = np.abs(model.rest_uv_np[:, 1] - SIZE_M) < 1e-9  # the top edge in the pattern
    top_mid = x[top][np.argmin(np.abs(x[top, 0]))]  # its vertex nearest the middle
    s = triangle_stretch(x, model.tri_indices_np, model.tri_rest_inv_np) - 1.0
    print(f"stop rule met: {m['converged']} ({m['stop_reason']}) after {m['frames']} frames, "
          f"{m['steps']} steps")  # fmt: skip
    print(f"simulated time {m['sim_time_s']:.2f} s, wall time {wall:.1f} s "
          f"(compile {m['compile_time_s']:.1f} s)")  # fmt: skip
    print(f"last frame: max displacement {m['max_displacement_m'] * 1e3:.3f} mm "
          f"(< 1.5), mean {m['mean_displacement_m'] * 1e3:.4f} mm (< 0.1)")  # fmt: skip
    print(f"sag: top edge middle {(pin_y - top_mid[1]) * 100:.1f} cm below the pins, "
          f"lowest point {(pin_y - x[:, 1].min()) * 100:.1f} cm below them")  # fmt: skip
    print(
        f"strain S-1: warp max {s[:, 0].max() * 100:.2f} %, mean {s[:, 0].mean() * 100:.3f} %;"
        f" weft max {s[:, 1].max() * 100:.2f} %, mean {s[:, 1].mean() * 100:.3f} %"
    )

    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        png = render_png(args.out / "hanging_sheet.png",
                         [{"vertices": x, "triangles": model.tri_indices_np}],
                         views=("front", "side"), width=400, height=400)  # fmt: skip
        print(f"wrote {png}")


if __name__ == "__main__":
    main()
