"""A sheet dropped on a sphere, held by friction (body collision, paper §2.5).

A 40 x 40 cm jersey sheet falls from 5 cm above a ball of radius 20 cm, 3 cm off centre,
so more of it hangs down one side and pulls it that way. The collider keeps every vertex
a contact thickness (3 mm) outside the sphere's triangles: continuously, so no step
crosses a face, and by proximity, with Coulomb friction (a vertex sticks while its
tangential speed is at most μ_s times its normal speed change, and otherwise loses μ_k of
it). The run ends with the paper's stop rule.

Printed: vertices inside the sphere (counted by a test independent of the solver's own
detection; it must be 0), how far the sheet's centre slid sideways, and when it came to
rest. Try `--friction 0`: nothing then holds the sheet, and it slides off.

    python examples/sheet_on_sphere.py [--arch cpu] [--friction 0.4] [--out DIR]
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

SIZE_M = 0.4  # the sheet
RADIUS_M = 0.2  # the ball, centred at the origin
OFFSET_M = 0.03  # the sheet's centre starts this far to +X of the ball's top
MU_STATIC = 0.4  # Coulomb friction; the kinetic coefficient is 3/4 of it

SCENE = """
[scene]
name = "sheet_on_sphere"

[simulation]
damping_per_s = 2.0

[stop]                        # the paper's rule, for 3 frames in a row
max_displacement_m = 1.5e-3
mean_displacement_m = 1.0e-4
frames = 3
time_limit_s = 3.0

[collision]
thickness_m = 0.003
friction_static = {mu_s}
friction_kinetic = {mu_k}
self_collision = false        # a sheet on a ball hardly folds onto itself; on, it costs 5x

[[cloth]]
name = "sheet"
size_m = [{size}, {size}]
edge_length_m = 0.025
material = "jersey"
origin_m = [{x0}, {y0}, {z0}]  # the pattern's (0, 0) corner
rotation_deg = [-90.0, 0.0, 0.0]   # pattern plane -> horizontal (pattern y -> world -Z)

[[collider]]
name = "ball"
shape = "sphere"
center_m = [0.0, 0.0, 0.0]
radius_m = {radius}
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arch", default="cpu", help="Taichi arch: cpu, gpu, cuda, vulkan")
    parser.add_argument("--friction", type=float, default=MU_STATIC, help="static μ (≥ 0)")
    parser.add_argument("--out", type=Path, help="write a PNG of the sheet on the ball here")
    args = parser.parse_args()

    # 1. Set up: the scene, with the ball as a collider.
    runtime.init(args.arch)
    text = SCENE.format(mu_s=args.friction, mu_k=0.75 * args.friction, size=SIZE_M,
                        x0=OFFSET_M - SIZE_M / 2, y0=RADIUS_M + 0.05, z0=SIZE_M / 2,
                        radius=RADIUS_M)  # fmt: skip
    scene = build_scene(scene_from_dict(tomllib.loads(text), source="sheet_on_sphere"))
    model = scene.model
    uv = model.rest_uv_np
    centre = int(np.argmin(np.linalg.norm(uv - SIZE_M / 2, axis=1)))  # the sheet's middle
    x0 = scene.state.positions()
    print(f"sheet: {model.particle_count} vertices; ball r = {RADIUS_M * 100:g} cm; "
          f"friction mu_s = {args.friction:g}, mu_k = {0.75 * args.friction:g}")  # fmt: skip

    # 2. Drop it and let it settle.
    t0 = time.perf_counter()
    result = run_scene(scene, progress=False)
    wall = time.perf_counter() - t0
    x = result.positions
    m = result.metrics

    # 3. Report: contact (from the package's independent check), slide, time to rest.
    slid = np.linalg.norm((x[centre] - x0[centre])[[0, 2]])  # horizontal, [m]
    distance = np.linalg.norm(x, axis=1)  # from the ball's centre
    rest = f"at rest after {m['sim_time_s']:.2f} s" if m["converged"] else "not at rest"
    print(f"{rest} (stop rule: {m['converged']}; {m['steps']} steps, {wall:.1f} s wall)")
    print(f"inside the sphere: {m['vertices_inside_body']} vertices "
          f"(deepest {m['penetration_max_m'] * 1e3:.2f} mm)")  # fmt: skip
    print(f"closest vertex {(distance.min() - RADIUS_M) * 1e3:.2f} mm from the ball's surface "
          f"(the contact thickness is 3 mm)")  # fmt: skip
    print(f"the sheet's centre slid {slid * 100:.1f} cm sideways; it hangs down to "
          f"y = {x[:, 1].min() * 100:.1f} cm (the ball's equator is at y = 0)")  # fmt: skip
    if distance.min() > RADIUS_M + 0.05:
        print("the sheet slid off the ball")

    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        ball = model.colliders[0]
        meshes = [{"vertices": x, "triangles": model.tri_indices_np, "color": (0.3, 0.45, 0.75)},
                  {"vertices": ball.body_x.to_numpy(), "triangles": ball.triangles_np,
                   "color": (0.8, 0.75, 0.65)}]  # fmt: skip
        png = render_png(args.out / "sheet_on_sphere.png", meshes, views=("front", "side"),
                         width=400, height=400)  # fmt: skip
        print(f"wrote {png}")


if __name__ == "__main__":
    main()
