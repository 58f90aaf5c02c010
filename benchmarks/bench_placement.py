"""How the library garments start: ``python benchmarks/bench_placement.py [GARMENT ...]``.

For each garment (default: all 14) meshed at ``--edge-cm`` (default 1) and placed on the
database size ``--size`` (default 12), prints one line: vertices, crossing triangle pairs
of the placed garment (exact test; contact handling keeps a start crossing for good), the
principal stretches of every triangle against its pattern shape (largest, smallest, the
share off by more than 10 %), the smallest distance to the body [mm] and the placement's
wall time. ``--no-untangle`` places without :func:`sandbox.pattern.placement.repair.untangle` and
with each panel's relaxation kept only where it adds no crossing, for comparison.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("garments", nargs="*")
    p.add_argument("--edge-cm", type=float, default=1.0)
    p.add_argument("--size", type=int, default=12)
    p.add_argument("--no-untangle", action="store_true")
    args = p.parse_args(argv)

    from sandbox.collision.body_probe import body_inside_check
    from sandbox.garment import garment_names, make_mannequin, resolve_pattern
    from sandbox.pattern.panel_mesh import mesh_pattern
    from sandbox.pattern.placement.body import PlacementBody
    from sandbox.pattern.placement.config import PlacementConfig
    from sandbox.pattern.placement.place import place_pattern
    from sandbox.pattern.placement.repair import crossings, start_stretches

    config = PlacementConfig(untangle_rounds=0) if args.no_untangle else PlacementConfig()
    mannequin = make_mannequin(args.size)
    body = PlacementBody(mannequin, config)
    probe = body_inside_check(mannequin.vertices, mannequin.triangles)
    print(f"edge {args.edge_cm} cm, size {args.size}, untangle {not args.no_untangle}")
    print(f"{'garment':18s} {'vertices':>8s} {'crossings':>9s} {'max str':>7s} "
          f"{'min str':>7s} {'>10 %':>6s} {'body mm':>7s} {'wall s':>6s}")  # fmt: skip
    for g in args.garments or garment_names():
        pattern = resolve_pattern(g, mannequin)
        meshes = mesh_pattern(pattern, args.edge_cm / 100)
        t0 = time.perf_counter()
        placed = place_pattern(pattern, meshes, body)
        wall = time.perf_counter() - t0
        s = start_stretches(meshes, placed)
        off = np.mean((s[:, 0] > 1.1) | (s[:, 1] < 0.9)) * 100
        x = np.vstack(list(placed.values()))
        print(f"{g:18s} {len(x):8d} {crossings(placed, meshes):9d} {s[:, 0].max():7.2f} "
              f"{s[:, 1].min():7.2f} {off:5.1f}% {probe.signed_distance(x).min() * 1e3:7.1f} "
              f"{wall:6.1f}", flush=True)  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
