"""Energy budget of a scene, frame by frame: where the energy comes from.

Usage: python benchmarks/bench_energy.py SCENE.toml [--frames 10] [--material cotton]
       [--no-self-collision] [--chunk 10]

Prints per frame the kinetic energy, the elastic energy U (membrane, bending, seams), the
gravitational energy (from the start), the energy the mass damping took out (2γ·KE
integrated over chunks of ``--chunk`` steps) and what is left: the work done on the cloth
by the contact handlers (the body's response, self-collision) [J]. A stable contact takes
energy out or adds none; energy growing in the last column comes from contact.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from sandbox import runtime
from sandbox.scene.build import build_scene
from sandbox.scene.spec import load_scene


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene")
    ap.add_argument("--frames", type=int, default=10)
    ap.add_argument("--material", default=None, help="a preset for every cloth piece")
    ap.add_argument("--no-self-collision", action="store_true")
    ap.add_argument("--chunk", type=int, default=10, help="steps between energy samples")
    ap.add_argument("--arch", default="cpu")
    args = ap.parse_args()
    runtime.init(args.arch)
    spec = load_scene(args.scene)
    if args.material:
        from sandbox.sim.materials import get_material

        mat = get_material(args.material)
        spec = dataclasses.replace(spec, cloths=[dataclasses.replace(c, material=mat)
                                                 for c in spec.cloths])  # fmt: skip
    if args.no_self_collision:
        spec = dataclasses.replace(
            spec, collision=dataclasses.replace(spec.collision, self_collision=False)
        )
    scene = build_scene(spec)
    model, solver, state, control = scene.model, scene.solver, scene.state, scene.control
    mass, gamma = model.mass_np, float(control.damping_per_s[None])
    g = -np.asarray(control.gravity[None], float)

    def energies():
        x, v = state.positions(), state.velocities()
        ke = 0.5 * float(np.sum(mass[:, None] * v * v))
        return ke, float(solver.internal_energy(state)), float(np.sum(mass * (x @ g)))

    ke0, u0, g0 = energies()
    start = ke0 + u0 + g0
    damped = 0.0
    print(f"{spec.name}: {model.particle_count} vertices, dt {scene.dt_s:.3g} s, "
          f"{scene.steps_per_frame} steps a frame, damping {gamma:g} /s")  # fmt: skip
    print(f"{'frame':>5} {'t [s]':>6} {'kinetic':>10} {'elastic':>10} {'gravity':>10} "
          f"{'damping':>10} {'contact':>10}   [J]; wall")  # fmt: skip
    step, t0 = 0, time.perf_counter()
    for frame in range(1, args.frames + 1):
        left = scene.steps_per_frame
        while left:
            n = min(args.chunk, left)
            ke_before = energies()[0]
            solver.advance(state, control, scene.dt_s, n, step)
            ke_after = energies()[0]
            damped += gamma * (ke_before + ke_after) * n * scene.dt_s  # ∫ 2γ KE dt
            step += n
            left -= n
        ke, u, grav = energies()
        contact = ke + u + grav + damped - start
        print(f"{frame:5d} {frame * scene.steps_per_frame * scene.dt_s:6.3f} {ke:10.4g} "
              f"{u:10.4g} {grav - g0:10.4g} {damped:10.4g} {contact:10.4g}   "
              f"{time.perf_counter() - t0:.0f} s", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
