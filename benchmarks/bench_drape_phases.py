"""Where a drape's time goes, phase by phase, from a profile of one drape.

Usage:
    python benchmarks/bench_drape_phases.py [GARMENT] [--method direct|coarse_to_fine]
        [--edge-cm 1] [--out FILE.json]

Drapes the garment (default the t-shirt, size 12, its own fabric, no files written) under
cProfile and prints the cumulative wall time of each phase: placement, the coarse level
(its build, sewing and drape), the fine level's build and run, the stop-rule checks
(equilibrium residual), the measured stability limit, Taichi's kernel compilation (its
Python front end and LLVM), the kernels' own run time (all launches), the self-collision
list rebuilds, host traffic (fields copied to and from numpy) and the metrics. Phases
nest (a kernel launch happens inside the sewing), so the rows do not add up to the total.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import platform
import pstats
import sys
import time
from pathlib import Path

# (label, file suffix, function name): cumulative time of every matching function
PHASES = (
    ("placement (place_pattern)", "placement/place.py", "place_pattern"),
    ("build a level (mesh, model, colliders)", "garment/build.py", "build_drape"),
    ("sewing", "garment/sewing.py", "sew"),
    ("run to the stop rule (run_scene)", "scene/run.py", "run_scene"),
    ("coarse level, all of it", "garment/pipeline.py", "run_drape"),
    ("carry the coarse shape over", "garment/multilevel.py", "carry"),
    ("untangle crossings", "garment/repair.py", "untangle_state"),
    ("measured stability limit", "sim/stability.py", "dominant_eigenvalue"),
    ("equilibrium residual", "sim/residual.py", "scene_residual"),
    ("self-collision list rebuilds", "collision/self_contact.py", "build_list"),
    ("Taichi front end (kernel ASTs)", "taichi/lang/kernel_impl.py", "taichi_ast_generator"),
    ("LLVM compilation", "", "compile_kernel"),
    ("kernels running (all launches)", "", "launch_kernel"),
    ("host traffic: fields to numpy", "taichi/lang/field.py", "to_numpy"),
    ("host traffic: numpy to fields", "taichi/lang/field.py", "from_numpy"),
    ("drape metrics (ease, fold, hang)", "garment/metrics.py", "drape_metrics"),
    ("contact metrics (inside body, crossing pairs)", "scene/run.py", "contact_metrics"),
)


def phase_times(stats: pstats.Stats) -> dict[str, float]:
    """Cumulative seconds per :data:`PHASES` label (the outermost call of each function)."""
    out = {label: 0.0 for label, _, _ in PHASES}
    for (path, _, name), (_, _, _, cum, _) in stats.stats.items():
        for label, suffix, fn in PHASES:
            builtin = not suffix and path == "~" and fn in name
            if builtin or (suffix and name == fn and path.endswith(suffix)):
                out[label] += cum
    return out


def markdown(result: dict) -> str:
    """One run's phases as a Markdown table, with what was draped and where."""
    lines = [
        f"# Where the time goes: {result['garment']}, {result['method']}, {result['edge_cm']:g} cm",
        "",
        f"{result['machine']}, {result['date']}. Command: `python benchmarks/"
        f"bench_drape_phases.py {result['garment']} --method {result['method']} --edge-cm "
        f"{result['edge_cm']:g}`. Profiled (cProfile adds to the Python-side phases); phases "
        f"nest, so they do not add up. Total {result['total_s']:.1f} s; "
        f"{result['vertex_count']} vertices, converged {result['converged']}, meets the "
        f"acceptance {result['meets_acceptance']}.",
        "",
        "| phase | s |",
        "|---|---:|",
    ]
    lines += [f"| {label} | {sec:.1f} |" for label, sec in result["phases_s"].items()]
    return "\n".join(lines) + "\n"


def _write(path: Path, text: str) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(text)
    tmp.replace(path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("garment", nargs="?", default="t-shirt")
    ap.add_argument("--method", default="coarse_to_fine")
    ap.add_argument("--edge-cm", type=float, default=1.0)
    ap.add_argument(
        "--out",
        type=Path,
        default=None,
        help="also write the figures as JSON, and as a Markdown table beside it",
    )
    args = ap.parse_args()
    from sandbox import runtime

    runtime.init("cpu")
    from sandbox.garment import DrapeConfig, drape

    config = DrapeConfig(method=args.method)
    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.enable()
    r = drape(args.garment, size=12, out_dir=Path("/tmp") / f"phases_{os.getpid()}",
              edge_length_m=args.edge_cm / 100.0, config=config, render=False, meshes=False,
              progress=False)  # fmt: skip
    prof.disable()
    total = time.perf_counter() - t0
    phases = phase_times(pstats.Stats(prof))
    m = r.metrics
    keys = ("vertex_count", "coarse_vertex_count", "sew_sim_time_s", "coarse_sim_time_s",
            "sim_time_s", "steps", "dt_s", "fine_dt_bound_s", "converged", "meets_acceptance",
            "residual_mean_over_weight", "residual_max_over_weight")  # fmt: skip
    result = {
        "garment": args.garment,
        "method": args.method,
        "edge_cm": args.edge_cm,
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, Python "
        f"{platform.python_version()}",
        "date": time.strftime("%Y-%m-%d"),
        "total_s": total,
        "phases_s": phases,
        **{k: m.get(k) for k in keys},
    }
    print(
        f"{args.garment}, {args.method}, {args.edge_cm:g} cm: {total:.1f} s in all "
        f"(profiled; {result['machine']})"
    )
    for label, seconds in phases.items():
        print(f"  {label:48s} {seconds:7.1f} s")
    print(json.dumps({k: result[k] for k in keys if k in result}))
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        _write(args.out, json.dumps(result, indent=1))
        _write(args.out.with_suffix(".md"), markdown(result))
    sys.stdout.flush()


if __name__ == "__main__":
    main()
