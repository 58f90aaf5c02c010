"""Where the explicit step's time goes: ns per triangle, per hinge and per vertex.

Usage: python benchmarks/bench_elements.py [--vertices 16000] [--noise-mm 0 0.1] [--threads 1 2]

Times the three passes of one symplectic Euler step (``SymplecticEulerSolver``'s own
functions, each in a kernel of its own: ``_membrane_forces``, ``_bending_forces`` and the
per-vertex gather of ``_velocity``) on the benchmark's hanging cotton sheet, float32:
the membrane forces of Eq. 6-8 per triangle, the bending forces per hinge, the gather and
update (Eq. 2) per vertex. ``--noise-mm`` displaces the vertices randomly (Gaussian, per
coordinate) so the hinges are bent: libm's atan2 is much faster on flat hinges, so the
flat benchmark sheet understates a draped garment's bending cost. Best of five rounds.
"""

import argparse
import os
import platform
import time

import numpy as np
import taichi as ti
from bench_step import sheet

from sandbox import runtime
from sandbox.scene.build import build_scene


def build(n_vertices: int):
    scene = build_scene(sheet(n_vertices))
    m, s, x, v = scene.model, scene.solver, scene.state.x, scene.state.v
    c = scene.control

    @ti.kernel
    def membrane():
        s._membrane_forces(x, v)

    @ti.kernel
    def bending():
        s._bending_forces(x)

    @ti.kernel
    def gather_update(dt: float):
        for i in range(m.particle_count):
            w = m.particle_inv_mass[i]
            if w > 0.0:  # Eq. 2 with the gathered force; positions not written (no drift)
                f = s._gathered_force(i)
                v[i] = v[i] + dt * (f * w + c.gravity[None] - c.damping_per_s[None] * v[i])

    return scene, membrane, bending, gather_update


def best_ms(fn, *args, rounds=5, calls=40) -> float:
    fn(*args)
    ti.sync()
    best = float("inf")
    for _ in range(rounds):
        t0 = time.perf_counter()
        for _ in range(calls):
            fn(*args)
        ti.sync()
        best = min(best, (time.perf_counter() - t0) / calls * 1e3)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vertices", type=int, default=16000)
    ap.add_argument("--noise-mm", type=float, nargs="+", default=[0.0, 0.1])
    args = ap.parse_args()
    runtime.init("cpu", float64=False)  # the float32 step, as bench_step
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python "
          f"{platform.python_version()}, Taichi {'.'.join(map(str, ti.__version__))}, float32, "
          f"parallel loops")  # fmt: skip
    scene, membrane, bending, gather_update = build(args.vertices)
    m = scene.model
    x0 = scene.state.positions()
    rng = np.random.default_rng(0)
    print(f"{m.particle_count} vertices, {m.tri_count} triangles, {m.hinge_count} hinges")
    print(f"{'noise [mm]':>10} {'triangle [ns]':>14} {'hinge [ns]':>11} {'vertex [ns]':>12} "
          f"{'step [ms]':>10} {'M vertex-steps/s':>17}")  # fmt: skip
    for noise in args.noise_mm:
        x = x0 + rng.normal(scale=noise * 1e-3, size=x0.shape)
        scene.state.set(x.astype(np.float32), np.zeros_like(x, dtype=np.float32))
        tri = best_ms(membrane)
        hinge = best_ms(bending)
        vert = best_ms(gather_update, 1e-6)
        step = tri + hinge + vert
        print(f"{noise:10.2f} {tri * 1e6 / m.tri_count:14.1f} {hinge * 1e6 / m.hinge_count:11.1f} "
              f"{vert * 1e6 / m.particle_count:12.1f} {step:10.3f} "
              f"{m.particle_count / step / 1e3:17.2f}")  # fmt: skip


if __name__ == "__main__":
    main()
