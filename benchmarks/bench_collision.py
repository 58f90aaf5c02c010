"""Step time without collision, with body collision, and with self-collision too.

Usage: python benchmarks/bench_collision.py [--vertices 10000] [--settle 0.3 1.0 3.0]

The sheet (1.2 x 1.2 m, jersey) starts flat above the shoulders and falls onto the default
mannequin (~17k triangles). After each ``--settle`` time (simulated seconds of draping with
self-collision: at 0.3 s the sides still fall at up to 5 m/s, at 3 s the sheet hangs in
folds around the body, its fastest vertex below 0.6 m/s), we time solver steps with the
body collider, with the body collider and self-collision, and the same steps with none.
Targets: body collision adds at most 50 % to the step, self-collision at most
150 %.
"""

import argparse
import math
import time

import numpy as np
import taichi as ti

from sandbox import runtime
from sandbox.scene.build import build_scene
from sandbox.scene.spec import scene_from_dict


def spec(n_vertices: int, with_body: bool, with_self: bool = False):
    side = 1.2
    h = side * math.sqrt(1.15 / n_vertices)
    data = {
        "scene": {"name": "bench-collision"},
        "simulation": {"damping_per_s": 1.0},
        "cloth": [{"name": "sheet", "size_m": [side, side], "edge_length_m": h,
                   "material": "jersey", "origin_m": [-0.6, 1.55, 0.6],
                   "rotation_deg": [-90.0, 0.0, 0.0]}],
    }  # fmt: skip
    if with_body:
        data["collider"] = [{"name": "body", "shape": "mannequin", "size": 12}]
        data["collision"] = {"self_collision": with_self}
    return scene_from_dict(data, source="bench")


def measure(runs, steps: int, rounds: int = 25) -> dict:
    """ms per step of each scene (median over ``rounds`` interleaved rounds of
    steps // rounds steps each), and each scene's total time over the first's. This VM's
    speed drifts by +-30 % over seconds; the scenes take turns every few steps, so they see
    the same speeds and the ratio of totals is far steadier than the times. Totals, not
    medians: the self-collision list's rebuilds (every ~50 steps) are counted in full."""
    times = {name: [] for name, _ in runs}
    per = max(1, steps // rounds)
    for _ in range(rounds):
        for name, sc in runs:
            ti.sync()
            t0 = time.perf_counter()
            sc.solver.advance(sc.state, sc.control, sc.dt_s, per)
            ti.sync()
            times[name].append((time.perf_counter() - t0) / per)
    first = times[runs[0][0]]
    ms = {k: 1e3 * float(np.median(v)) for k, v in times.items()}
    ratio = {k: float(np.sum(v) / np.sum(first)) for k, v in times.items()}
    return ms, ratio


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vertices", type=int, default=10000)
    ap.add_argument("--settle", type=float, nargs="+", default=[0.3, 1.0, 3.0],
                    help="simulated seconds of draping (with self-collision) before each "
                    "measurement (default: 0.3 1.0 3.0, falling to draped)")  # fmt: skip
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--profile", action="store_true",
                    help="then also 20 self-collision steps under Taichi's kernel profiler: "
                    "time per loop of the list rebuild and the contact passes")  # fmt: skip
    args = ap.parse_args()
    runtime.init("cpu", float64=False, profile=args.profile)  # float32, as bench_step
    both = build_scene(spec(args.vertices, True, True))
    body = build_scene(spec(args.vertices, True))
    free = build_scene(spec(args.vertices, False))
    free.dt_s = body.dt_s = both.dt_s
    runs = (("no collision", free), ("body collision", body), ("body + self", both))
    for _, sc in runs:
        sc.solver.warm_up(sc.state, sc.control)  # compile every kernel, before any timing
    sc_self = both.model.self_collider
    collider = body.model.colliders[0]
    verts = collider.body_x.to_numpy().astype(float)
    collider.update(verts * 1.01)  # a resize, as a slider would do (first call warms up)
    t0 = time.perf_counter()
    for _ in range(5):
        collider.update(verts)
    ti.sync()
    rebuild = (time.perf_counter() - t0) / 5
    print(f"sheet: {body.model.particle_count} vertices; mannequin: {collider.tri_count} "
          f"triangles; dt = {both.dt_s:.3g} s; body grid rebuild {rebuild * 1e3:.1f} ms; "
          "ms per step, targets: body adds <= 50 %, self <= 150 %")  # fmt: skip
    print(f"{'draped for':>10s} {'none':>8s} {'body':>8s} {'+ self':>8s} {'body adds':>10s} "
          f"{'self adds':>10s} {'pairs':>7s} {'rebuilds':>9s} {'refreshes':>9s}")  # fmt: skip
    simulated = 0.0
    for t_settle in args.settle:
        steps = max(0, round((t_settle - simulated) / both.dt_s))
        both.solver.advance(both.state, both.control, both.dt_s, steps)
        simulated += steps * both.dt_s
        for sc in (free, body):
            sc.state.set(both.state.positions(), both.state.velocities())
        rebuilds0, refreshes0 = sc_self.rebuilds[None], sc_self.refreshes[None]
        ms, ratio = measure(runs, args.steps)
        simulated += args.steps * both.dt_s
        extra = ratio["body collision"] - 1.0
        extra_self = ratio["body + self"] - 1.0
        print(f"{t_settle:9.1f}s {ms['no collision']:8.2f} {ms['body collision']:8.2f} "
              f"{ms['body + self']:8.2f} {100 * extra:9.0f}% {100 * extra_self:9.0f}% "
              f"{sc_self.pair_count[None]:7d} {sc_self.rebuilds[None] - rebuilds0:5d}/"
              f"{args.steps // 25 * 25} {sc_self.refreshes[None] - refreshes0:9d}",
              flush=True)  # fmt: skip
    if args.profile:
        ti.profiler.clear_kernel_profiler_info()
        both.solver.advance(both.state, both.control, both.dt_s, 20)
        ti.sync()
        print(
            "\nTaichi kernel profiler, 20 steps with self-collision (the rebuild's loops are "
            "_rebuild_kernel tasks in source order: ... vertex-triangle, edge-edge last):"
        )
        ti.profiler.print_kernel_profiler_info("count")


if __name__ == "__main__":
    main()
