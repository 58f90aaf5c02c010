"""Trace a garment's sewing phase frame by frame:
``python benchmarks/bench_sewing.py [GARMENT] [--edge-cm 3] [--integrator implicit_euler]
[--no-sew-at-rest]``.

Prints one line of JSON a sewing frame (the ramp's included): the largest seam spring
stretch [mm], the fastest particle [m/s] at the frame's end (before a sewing-at-rest reset),
how far the hem (the vertices placed within 1 cm of the garment's lowest point) has risen
at most [cm], and the wall time [s]; then the sewing metrics
(:func:`sandbox.garment.sewing.sew`) and the untangling that follows (its ``pairs_before``:
the crossing pairs sewing left). Default: the circle skirt at 3 cm with implicit Euler, the
case behind ``SewingConfig.at_rest_implicit`` (docs/implicit.md); ``--no-sew-at-rest`` keeps
the velocities between frames.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("garment", nargs="?", default="circle-skirt")
    p.add_argument("--edge-cm", type=float, default=3.0)
    p.add_argument("--size", type=int, default=12)
    p.add_argument("--integrator", choices=("symplectic_euler", "implicit_euler"),
                   default="implicit_euler")  # fmt: skip
    p.add_argument(
        "--no-sew-at-rest",
        action="store_true",
        help="keep the velocities between sewing frames (SewingConfig.at_rest_implicit off)",
    )
    args = p.parse_args(argv)

    from sandbox import runtime
    from sandbox.garment import (
        DrapeConfig,
        SewingConfig,
        build_drape,
        make_mannequin,
        resolve_pattern,
    )
    from sandbox.garment.repair import untangle_state
    from sandbox.garment.sewing import sew

    config = DrapeConfig(integrator=args.integrator,
                         sewing=SewingConfig(at_rest_implicit=not args.no_sew_at_rest))  # fmt: skip
    runtime.init("cpu")
    mannequin = make_mannequin(args.size)
    pattern = resolve_pattern(args.garment, mannequin)
    scene = build_drape(pattern, mannequin, edge_length_m=args.edge_cm / 100, config=config)
    solver, state, model = scene.solver, scene.state, scene.model
    pairs, rest = model.seam_pairs_np, model.seam_rest_np
    x0 = state.positions()
    hem = x0[:, 1] < x0[:, 1].min() + 0.01
    advance, frame = solver.advance, [0]

    def traced(*a, **k):
        t0 = time.perf_counter()
        advance(*a, **k)
        x, v = state.positions(), state.velocities()
        stretch = np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1) - rest
        frame[0] += 1
        print(json.dumps({
            "frame": frame[0],
            "seam_stretch_max_mm": round(float(stretch.max()) * 1e3, 2),
            "speed_max_m_s": round(float(np.linalg.norm(v, axis=1).max()), 3),
            "hem_rise_max_cm": round(float((x[hem, 1] - x0[hem, 1]).max()) * 100, 2),
            "wall_s": round(time.perf_counter() - t0, 2),
        }), flush=True)  # fmt: skip

    solver.advance = traced
    out = sew(scene, config.sewing)
    print(json.dumps(out))
    print(json.dumps(untangle_state(scene, "after sewing", config.repair)))  # as run_drape does
    return 0


if __name__ == "__main__":
    sys.exit(main())
