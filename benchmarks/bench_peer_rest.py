"""The peer's sheet on a sphere to rest: coarse to fine against the direct run.

Usage: python benchmarks/bench_peer_rest.py [--out docs/results/peer_sheet_rest]

Runs ``sandbox/scenes/sheet_on_sphere_peer.toml`` as shipped (its ``[multilevel]`` table:
the sheet falls and wraps the sphere as a 17 x 17 grid, then the 65 x 65 grid settles)
and directly (the 65 x 65 grid from the start, as ``run --direct``), each to the scene's
stop rule (the displacement rule and a mean equilibrium residual under 0.25 vertex
weights), in one process, one after the other. Prints and writes (Markdown and JSON) each
run's levels, wall times (building and compilation included), residuals, and how far the
two rest shapes lie apart.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import time
from pathlib import Path

import numpy as np

SCENE = Path(__file__).resolve().parents[1] / "sandbox/scenes/sheet_on_sphere_peer.toml"
SPHERE_RADIUS_M = 0.3


def _run(spec, multilevel: bool) -> dict:
    from sandbox.scene.build import build_scene
    from sandbox.scene.multilevel import run_multilevel
    from sandbox.scene.run import run_scene

    t0 = time.perf_counter()
    if multilevel:
        scene, result = run_multilevel(spec, build_scene, progress=False)
    else:
        scene = build_scene(dataclasses.replace(spec, multilevel=None))
        result = run_scene(scene, progress=False)
    wall = time.perf_counter() - t0
    m = result.metrics
    x = scene.state.positions().astype(np.float64)
    keys = ("steps", "dt_s", "sim_time_s", "stop_reason", "converged",
            "residual_mean_over_weight", "residual_max_over_weight", "compile_time_s")  # fmt: skip
    return {"wall_s": wall, "levels": m.get("levels"), **{k: m.get(k) for k in keys},
            "x": x}  # fmt: skip


def _shape(x: np.ndarray) -> dict:
    gap = np.linalg.norm(x, axis=1) - SPHERE_RADIUS_M
    return {"mean_height_m": float(x[:, 1].mean()), "lowest_m": float(x[:, 1].min()),
            "touching": int((gap < 0.0078).sum())}  # fmt: skip


def markdown(r: dict) -> str:
    ml, d = r["coarse_to_fine"], r["direct"]
    lines = [
        "# The peer's sheet on a sphere, to rest",
        "",
        f"{r['machine']}, {r['date']}. Command: `python benchmarks/bench_peer_rest.py`. "
        "Scene: `sandbox/scenes/sheet_on_sphere_peer.toml` (1 x 1 m, 65 x 65 grid, "
        "0.2 kg/m², 5,333 N/m, shear 2,000 N/m, bending 1e-5 N·m, a 0.3 m sphere, "
        "friction 0.5, 3.9 mm thickness, 1/60 s frames). Stop: the paper's displacement "
        "rule and a mean equilibrium residual under 0.25 vertex weights. Wall times include "
        "building the meshes and compiling the kernels; both runs in one process, one after "
        f"the other. Load: {r.get('load') or 'nothing else ran on the machine'}.",
        "",
        "| run | level | vertices | steps | step µs | simulated s | wall s | stop | "
        "residual mean |",
        "|---|---|---:|---:|---:|---:|---:|---|---:|",
    ]
    for lv in ml["levels"]:
        edge = "own mesh" if lv["edge_length_m"] is None else f"{lv['edge_length_m'] * 100:g} cm"
        lines.append(f"| coarse to fine | {edge} | {lv['vertex_count']} | {lv['steps']} | "
                     f"{lv['dt_s'] * 1e6:.0f} | {lv['sim_time_s']:.2f} | "
                     f"{lv['wall_time_s']:.1f} | {lv['stop_reason']} | "
                     f"{lv['residual_mean_over_weight']:.3f} |")  # fmt: skip
    lines.append(f"| direct | own mesh | 4225 | {d['steps']} | {d['dt_s'] * 1e6:.1f} | "
                 f"{d['sim_time_s']:.2f} | {d['wall_s']:.1f} | {d['stop_reason']} | "
                 f"{d['residual_mean_over_weight']:.3f} |")  # fmt: skip
    s = r["shapes"]
    lines += [
        "",
        f"**Coarse to fine: at rest in {ml['wall_s']:.1f} s wall** (residual mean "
        f"{ml['residual_mean_over_weight']:.3f}, max {ml['residual_max_over_weight']:.2f} "
        f"weights); direct: {d['wall_s']:.1f} s (mean {d['residual_mean_over_weight']:.3f}, "
        f"max {d['residual_max_over_weight']:.2f}).",
        "",
        f"The two rest shapes: vertices {s['distance_mean_m'] * 100:.1f} cm apart on average "
        f"(95th percentile {s['distance_95_m'] * 100:.1f} cm); mean height "
        f"{s['coarse_to_fine']['mean_height_m'] * 100:.1f} against "
        f"{s['direct']['mean_height_m'] * 100:.1f} cm, lowest point "
        f"{s['coarse_to_fine']['lowest_m'] * 100:.1f} against "
        f"{s['direct']['lowest_m'] * 100:.1f} cm, vertices within two thicknesses of the "
        f"sphere {s['coarse_to_fine']['touching']} against {s['direct']['touching']}.",
    ]
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("docs/results/peer_sheet_rest"),
                    help="write OUT.md and OUT.json")  # fmt: skip
    ap.add_argument("--load", default="", help="what else the machine ran meanwhile, or how "
                    "its speed compared, for the table's header")  # fmt: skip
    args = ap.parse_args()
    from sandbox import runtime

    runtime.init("cpu")
    from sandbox.scene.spec import load_scene

    spec = load_scene(SCENE)
    runs = {"coarse_to_fine": _run(spec, True), "direct": _run(spec, False)}
    a, b = runs["coarse_to_fine"].pop("x"), runs["direct"].pop("x")
    dist = np.linalg.norm(a - b, axis=1)
    result = {
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, Python "
        f"{platform.python_version()}",
        "date": time.strftime("%Y-%m-%d"),
        "load": args.load,
        **runs,
        "shapes": {
            "distance_mean_m": float(dist.mean()),
            "distance_95_m": float(np.percentile(dist, 95)),
            "coarse_to_fine": _shape(a),
            "direct": _shape(b),
        },  # fmt: skip
    }
    text = markdown(result)
    print(text)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    for suffix, body in ((".md", text), (".json", json.dumps(result, indent=1))):
        path = args.out.with_suffix(suffix)
        tmp = path.with_suffix(path.suffix + ".tmp")
        tmp.write_text(body)
        tmp.replace(path)


if __name__ == "__main__":
    main()
