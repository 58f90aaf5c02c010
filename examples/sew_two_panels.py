"""Two panels facing each other are sewn along one side (paper §2.4, Fig. 5).

A front and a back panel, 20 x 30 cm, hang 10 cm apart facing each other, as the panels of
a garment do around a body, and their left edges are sewn. The package applies the
paper's two rules:

* direction (Fig. 5a): with P1, P2 the ends of one edge and P3, P4 those of the other,
  sew P1-P3 and P2-P4 if L1 + L2 < L3 + L4, otherwise P1-P4 and P2-P3. The two edges are
  given here running opposite ways (the front's down, the back's up), so the rule turns
  one round; forced the other way (direction = "same") the seam would cross over itself;
* parametric matching (Fig. 5b): each point of the edge with fewer points is tied to the
  point of equal arc-length parameter on the other edge (zero-length spring), or, between
  two points, to both of them with rest lengths that add up to the gap. The panels are
  meshed at different sizes (2 and 1.5 cm), so both kinds occur.

The springs then pull the seam closed; there is no gravity, as in a sewing step. The
panels end as an open book, hinged at the seam.

    python examples/sew_two_panels.py [--arch cpu] [--out DIR]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from sandbox import runtime
from sandbox.render import render_png
from sandbox.scene.build import build_scene
from sandbox.scene.run import run_scene
from sandbox.scene.spec import scene_from_dict
from sandbox.sim.seams import edge_vertices, seam_direction_same, seam_openings

WIDTH_M, HEIGHT_M = 0.20, 0.30  # each panel
GAP_M = 0.10  # distance between the panels before sewing
W, H = WIDTH_M, HEIGHT_M
FRONT_EDGE, BACK_EDGE = 3, 1  # outline sides (corner i to i+1): front's runs down, back's up


def panel(name: str, edge_m: float, z: float, turned: bool) -> dict:
    """A panel at depth z; the back one is turned 180° about Y so that it faces the front."""
    return {"name": name, "size_m": [W, H], "edge_length_m": edge_m, "material": "jersey",
            "origin_m": [W / 2 if turned else -W / 2, 0.0, z],
            "rotation_deg": [0.0, 180.0 if turned else 0.0, 0.0]}  # fmt: skip


SCENE = {
    "scene": {"name": "two_panels"},
    "simulation": {"gravity_m_s2": [0.0, 0.0, 0.0], "damping_per_s": 5.0},
    "stop": {"time_limit_s": 5.0, "frames": 3},
    "cloth": [panel("front", 0.02, GAP_M / 2, False), panel("back", 0.015, -GAP_M / 2, True)],
    "seam": [{"name": "left side", "a": [{"cloth": "front", "edge": FRONT_EDGE}],
              "b": [{"cloth": "back", "edge": BACK_EDGE}]}],
}  # fmt: skip


def edge_particles(model, cloth: str, a, b) -> np.ndarray:
    """Global indices of the vertices of ``cloth`` on its pattern segment a -> b, in order."""
    piece = next(p for p in model.pieces if p.name == cloth)
    first = piece.particle_start
    uv = model.rest_uv_np[first : first + piece.particle_count]
    return edge_vertices(uv, a, b, where=cloth) + first


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arch", default="cpu", help="Taichi arch: cpu, gpu, cuda, vulkan")
    parser.add_argument("--out", type=Path, help="write a PNG of the sewn panels here")
    args = parser.parse_args()

    # 1. Set up: the scene; the builder sews every [[seam]] by Fig. 5.
    runtime.init(args.arch)
    spec = scene_from_dict(SCENE, source="sew_two_panels")
    scene = build_scene(spec)
    model = scene.model
    x0 = scene.state.positions()
    front, back = model.pieces
    print(f"panels: front {front.particle_count} vertices, back {back.particle_count} "
          f"vertices; {model.seam_count} seam springs")  # fmt: skip

    # 2. What Fig. 5(a) decided for the seam: its edges' ends P1, P2 and P3, P4 in the world.
    seam = spec.seams[0]
    ends = [x0[edge_particles(model, *side[0])[[0, -1]]] for side in (seam.side_a, seam.side_b)]
    (p1, p2), (p3, p4) = ends
    near = np.linalg.norm(p1 - p3) + np.linalg.norm(p2 - p4)
    cross = np.linalg.norm(p1 - p4) + np.linalg.norm(p2 - p3)
    rule = "P1-P3, P2-P4" if seam_direction_same(*ends) else "P1-P4, P2-P3"
    print(f"seam {seam.name!r}: L1+L2 = {near * 100:.1f} cm, L3+L4 = {cross * 100:.1f} cm "
          f"-> sew {rule}")  # fmt: skip
    zero = int((model.seam_rest_np == 0).sum())
    print(f"matching: {zero} zero-length springs (equal parameter), "
          f"{model.seam_count - zero} springs to points between")  # fmt: skip

    # 3. Sew: simulate until the stop rule holds.
    gap_before = seam_openings(model.seam_pairs_np, model.seam_rest_np, x0).max()
    t0 = time.perf_counter()
    result = run_scene(scene, progress=False)
    wall = time.perf_counter() - t0
    x = result.positions
    m = result.metrics

    # 4. Report the seam gap (distance between the seam's two sides at equal parameter).
    print(f"sewn: {m['converged']} after {m['sim_time_s']:.2f} s simulated ({m['steps']} steps, "
          f"{wall:.1f} s wall)")  # fmt: skip
    print(f"seam gap before {gap_before * 1e3:.1f} mm, after {m['seam_gap_max_m'] * 1e3:.2f} mm")
    free_front = x[edge_particles(model, "front", (W, 0.0), (W, H))].mean(axis=0)
    free_back = x[edge_particles(model, "back", (0.0, 0.0), (0.0, H))].mean(axis=0)
    print(
        f"the free edges, opposite the seam, are {np.linalg.norm(free_front - free_back) * 100:.1f}"
        f" cm apart (an open book; they started {GAP_M * 100:g} cm apart)"
    )

    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        pieces = [(p.particle_start, p.tri_start, p.tri_count) for p in model.pieces]
        meshes = [{"vertices": x, "triangles": model.tri_indices_np[t : t + n], "color": c}
                  for (_, t, n), c in zip(pieces, [(0.3, 0.45, 0.75), (0.8, 0.5, 0.3)],
                                          strict=True)]  # fmt: skip
        png = render_png(args.out / "sew_two_panels.png", meshes, views=("front", "side"),
                         width=400, height=400)  # fmt: skip
        print(f"wrote {png}")


if __name__ == "__main__":
    main()
