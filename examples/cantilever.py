"""The Peirce cantilever (ASTM D1388) against the exact heavy elastica.

A strip 10 cm long and 2 cm wide is clamped flat at one end and bends down under its own
weight. How far it bends depends on one number, λ = w L³ / B (weight per length w, length
L, flexural rigidity B). At λ = 8 the chord from the clamp to the tip makes 41.5° with the
horizontal: that is the ASTM D1388 test, where the overhang at 41.5° is twice the fabric's
bending length c = (B / w)^(1/3).

The package builds the strip (sandbox.validate.cantilever), simulates it to rest with
symplectic Euler, and the reference is the exact elastica solved by shooting
(sandbox.validate.elastica). The error is the distance between the two tips in % of L.

    python examples/cantilever.py [--arch cpu] [--lam 8] [--edge-mm 5] [--out DIR]
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

from sandbox import runtime
from sandbox.render import render_png
from sandbox.scene.build import build_scene
from sandbox.scene.run import run_scene
from sandbox.validate.cantilever import DENSITY_KG_M2, LENGTH_M, cantilever_spec
from sandbox.validate.elastica import bend_for, chord_angle_deg, tip

G = 9.80665  # [m/s²]
LAMBDA = 8.0  # ASTM D1388: the chord at 41.5°
EDGE_MM = 5.0  # mesh size; 2.5 mm cuts the error about 3x and costs about 7x


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arch", default="cpu", help="Taichi arch: cpu, gpu, cuda, vulkan")
    parser.add_argument("--lam", type=float, default=LAMBDA, help="λ = w L³ / B")
    parser.add_argument("--edge-mm", type=float, default=EDGE_MM, help="mesh edge length [mm]")
    parser.add_argument("--out", type=Path, help="write a PNG of the bent strip here")
    args = parser.parse_args()

    # 1. Set up: the strip's scene from the package, for this λ and mesh size.
    runtime.init(args.arch)
    bend = bend_for(args.lam, DENSITY_KG_M2, LENGTH_M, G)
    scene = build_scene(cantilever_spec(args.lam, args.edge_mm * 1e-3))
    model = scene.model
    print(f"strip: L = {LENGTH_M * 100:g} cm, rho_A = {DENSITY_KG_M2} kg/m², "
          f"B = {bend * 1e6:.2f} uN·m (lambda = {args.lam:g}), bending length "
          f"c = {(bend / (DENSITY_KG_M2 * G)) ** (1 / 3) * 100:.2f} cm")  # fmt: skip
    print(f"mesh: {model.particle_count} vertices, h = {args.edge_mm:g} mm; "
          f"dt = {scene.dt_s * 1e6:.2f} us")  # fmt: skip

    # 2. Simulate until the strip is at rest (a tight stop rule: 2 µm per frame).
    t0 = time.perf_counter()
    result = run_scene(scene, progress=False)
    wall = time.perf_counter() - t0
    x = result.positions

    # 3. Measure the tip against the clamp, and compare with the exact elastica.
    u = model.rest_uv_np[:, 0]  # distance along the strip from the clamp [m]
    root = x[np.abs(u) < 1e-9].mean(axis=0)
    tip_xyz = x[np.abs(u - LENGTH_M) < 1e-9].mean(axis=0)
    drop, reach = root[1] - tip_xyz[1], tip_xyz[0] - root[0]  # [m]
    exact_drop, exact_reach = (LENGTH_M * r for r in tip(args.lam))
    error = math.hypot(drop - exact_drop, reach - exact_reach) / LENGTH_M * 100.0
    chord, exact_chord = chord_angle_deg(drop, reach), chord_angle_deg(exact_drop, exact_reach)

    m = result.metrics
    print(f"at rest: {m['converged']} after {m['steps']} steps, {m['sim_time_s']:.2f} s "
          f"simulated, {wall:.1f} s wall")  # fmt: skip
    print(f"tip deflection: simulated {drop * 1e3:.2f} mm, reference {exact_drop * 1e3:.2f} mm")
    print(f"tip reach:      simulated {reach * 1e3:.2f} mm, reference {exact_reach * 1e3:.2f} mm")
    print(f"chord angle:    simulated {chord:.2f} deg, reference {exact_chord:.2f} deg "
          f"(ASTM D1388 asks for 41.5 +- 0.5 at lambda = 8)")  # fmt: skip
    print(f"tip error {error:.3f} % of L")

    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        chord_line = np.array([root, root + [exact_reach, -exact_drop, 0.0]])  # exact chord
        png = render_png(args.out / "cantilever.png",
                         [{"vertices": x, "triangles": model.tri_indices_np}],
                         lines=[{"points": chord_line, "color": (0.8, 0.1, 0.1)}],
                         views=("front",), width=600, height=400)  # fmt: skip
        print(f"wrote {png}")


if __name__ == "__main__":
    main()
