"""The peer's sheet on a sphere under backward Euler: is it at rest, and where not?

Usage: python benchmarks/bench_peer_sheet.py [--newton N] [--time S] [--compression]

Runs ``sandbox/scenes/sheet_on_sphere_peer.toml`` with ``integrator = "implicit_euler"``,
matrix-free CG (``linear_solver = "cg"``), 1/60 s steps and at most N Newton iterations a
step (default 3), for S simulated seconds (default 2) or to its stop rule, then prints the
wall time and the equilibrium residual (:mod:`sandbox.sim.residual`): its mean, the mean
over vertices in contact with the sphere and over the others, and the ten worst vertices
with their distance to the sphere and the normal and tangential parts of their net force,
in vertex weights. ``--compression`` keeps the compressed columns' negative stiffness in
the Newton matrix (``ImplicitConfig.compression_stiffness``). docs/performance.md says
what the figures mean.
"""

import argparse
import dataclasses
import time

import numpy as np

SCENE = "sandbox/scenes/sheet_on_sphere_peer.toml"
SPHERE_RADIUS_M = 0.3


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--newton", type=int, default=3, help="Newton iterations a step at most")
    p.add_argument("--time", type=float, default=2.0, help="simulated seconds at most")
    p.add_argument("--compression", action="store_true", help="compression stiffness on")
    args = p.parse_args()

    from sandbox import runtime

    runtime.init("cpu")
    from sandbox.scene.build import build_scene
    from sandbox.scene.run import run_scene
    from sandbox.scene.spec import load_scene
    from sandbox.sim import residual
    from sandbox.sim.implicit_config import ImplicitConfig
    from sandbox.sim.solver import SymplecticEulerSolver

    spec = load_scene(SCENE)
    sim = dataclasses.replace(
        spec.simulation, integrator="implicit_euler", linear_solver="cg", strain_damping_s=0.0
    )
    stop = dataclasses.replace(spec.stop, time_limit_s=args.time)
    spec = dataclasses.replace(spec, simulation=sim, stop=stop, multilevel=None)
    config = ImplicitConfig(max_newton=args.newton, compression_stiffness=args.compression)
    scene = build_scene(spec, implicit=config)
    t0 = time.perf_counter()
    result = run_scene(scene, progress=False)
    wall = time.perf_counter() - t0
    m = result.metrics
    print(f"{m['steps']} steps, {m['sim_time_s']:.2f} s simulated, {wall:.1f} s wall "
          f"(compilation {m['compile_time_s']:.1f} s): {m['stop_reason']}")  # fmt: skip
    print(f"residual over weight: mean {m['residual_mean_over_weight']:.2f}, "
          f"max {m['residual_max_over_weight']:.0f}")  # fmt: skip

    model, x = scene.model, scene.state.positions()
    f = SymplecticEulerSolver(model).static_forces(scene.state.x, scene.control.gravity)
    weight = model.particle_mass.to_numpy()[: len(x)] * 9.80665
    body = model.colliders[0]
    count, n1, n2 = residual.contact_normals(body, x, 2.0 * float(body.thickness[None]))
    held = residual._supported(f.copy(), n1, n2, count, float(body.mu_s[None]))
    ratio = np.minimum(np.linalg.norm(f, axis=1), held) / weight
    touching = count > 0
    print(f"in contact: {int(touching.sum())} vertices, mean {ratio[touching].mean():.1f}; "
          f"the others: mean {ratio[~touching].mean():.1f}")  # fmt: skip
    out = x / np.linalg.norm(x, axis=1, keepdims=True)  # outward from the sphere's centre
    fn = np.einsum("ij,ij->i", f, out)
    ft = np.linalg.norm(f - fn[:, None] * out, axis=1)
    print(
        "worst vertices: residual, distance to the sphere [mm], height [m], normal and "
        "tangential force [weights] (normal > 0: outward)"
    )
    for i in np.argsort(-ratio)[:10]:
        gap = 1000.0 * (np.linalg.norm(x[i]) - SPHERE_RADIUS_M)
        print(f"  {i:5d} {ratio[i]:8.0f} {gap:6.1f} {x[i, 1]:6.3f} {fn[i] / weight[i]:8.0f} "
              f"{ft[i] / weight[i]:8.0f}")  # fmt: skip


if __name__ == "__main__":
    main()
