"""Wall time of one drape: ``python benchmarks/bench_drape.py [GARMENT ...] [--edge-cm 1]``.

Default garments: the library's pencil skirt and T-shirt. Each drape runs in its own output
directory, ``out/bench_drape/GARMENT_sizeN_Ecm``, and prints one line of JSON: vertices,
steps, dt, sewing and draping time (simulated, wall), compile time, convergence, seam gap,
contact counts, ease, hem rise, folded area, acceptance. The sewing flags set fields of
:class:`sandbox.garment.SewingConfig` (``--sew-gravity 1``: tops and dresses sewn under full
gravity; ``--integrator implicit_euler --edge-cm 3 --no-sew-at-rest``: the implicit solver
keeps its velocities between sewing frames). ``--size 8 12 18`` drapes each garment on each
size; ``--table`` ends with a Markdown table of the acceptance checks.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from sandbox.precision import add_precision_flags

ROOT = Path(__file__).resolve().parents[1]
KEYS = ("vertex_count", "fabric", "dt_s", "steps", "sew_sim_time_s", "sew_wall_time_s",
        "sew_frames", "sew_gap_m", "sew_dt_s", "sew_gravity_fraction", "sew_stalled",
        "sew_at_rest", "strain_damping_s", "sim_time_s",
        "wall_time_s", "total_wall_time_s", "compile_time_s", "build_time_s",
        "converged", "stop_reason", "max_displacement_m", "mean_displacement_m",
        "seam_gap_max_m", "vertices_inside_body",
        "intersecting_triangle_pairs", "ease_bust_cm", "ease_waist_cm", "ease_hip_cm",
        "top_below_anchor_m", "hem_rise_m", "folded_area_pct", "rolled_up",
        "meets_acceptance")  # fmt: skip


def markdown_table(rows: list[dict]) -> str:
    """The acceptance checks of bench rows as a Markdown table (one line per drape)."""
    from sandbox.garment.gallery import ACCEPTANCE_HEAD, acceptance_cells

    lines = [
        "| garment | size | fabric | vertices | wall (s) | " + ACCEPTANCE_HEAD + " |",
        "|" + "---|" * 12,
    ]
    for r in rows:
        lines.append(
            f"| {Path(r['garment']).stem} | {r['size']} | {r.get('fabric')} "
            f"| {r.get('vertex_count')} | {r.get('total_wall_time_s') or 0:.0f} "
            f"| {acceptance_cells(r)} |"
        )
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("garments", nargs="*")
    p.add_argument("--edge-cm", type=float, default=1.0)
    p.add_argument("--size", type=int, nargs="+", default=[12],
                   help="database size(s), e.g. --size 8 12 18 (default 12)")  # fmt: skip
    p.add_argument("--fabric", default=None)
    p.add_argument("--no-self-collision", action="store_true")
    add_precision_flags(p)
    p.add_argument(
        "--sew-gravity",
        type=float,
        default=None,
        help="gravity fraction while a top or dress is sewn "
        "(SewingConfig.gravity_fraction_tops, default 0.3)",
    )
    p.add_argument(
        "--sew-speed-limit",
        type=float,
        default=None,
        help="largest particle speed while sewing [m/s] (SewingConfig.speed_limit_m_s, "
        "default 3); 0: none",
    )
    p.add_argument(
        "--strain-damping",
        type=float,
        default=None,
        help="the membrane's strain-rate damping [s] (DrapeConfig.strain_damping_s, "
        "default 4e-6; 0: off)",
    )
    p.add_argument(
        "--integrator",
        choices=("symplectic_euler", "implicit_euler"),
        default="symplectic_euler",
        help="the drape's integrator (implicit_euler: use --edge-cm 3)",
    )
    p.add_argument(
        "--no-sew-at-rest",
        action="store_true",
        help="implicit_euler: keep the velocities between sewing frames "
        "(SewingConfig.at_rest_implicit off)",
    )
    p.add_argument(
        "--table",
        action="store_true",
        help="after the JSON lines, a Markdown table of the acceptance checks",
    )
    args = p.parse_args(argv)

    from sandbox import runtime
    from sandbox.garment import DrapeConfig, SewingConfig, drape, make_mannequin

    sewing = {"self_collision": not args.no_self_collision,
              "at_rest_implicit": not args.no_sew_at_rest}  # fmt: skip
    if args.sew_speed_limit is not None:
        sewing["speed_limit_m_s"] = args.sew_speed_limit
    if args.sew_gravity is not None:
        sewing["gravity_fraction_tops"] = args.sew_gravity
    options = {"integrator": args.integrator, "self_collision": not args.no_self_collision,
               "sewing": SewingConfig(**sewing)}  # fmt: skip
    if args.strain_damping is not None:
        options["strain_damping_s"] = args.strain_damping
    config = DrapeConfig(**options)

    runtime.init("cpu", float64=args.float64)
    garments = args.garments or ["pencil-skirt", "t-shirt"]
    rows = []
    for size in args.size:
        mannequin = make_mannequin(size)
        for g in garments:
            t0 = time.perf_counter()
            # one directory per garment, size and mesh, so runs side by side do not clash
            out = ROOT / "out" / "bench_drape" / f"{Path(g).stem}_size{size}_{args.edge_cm:g}cm"
            res = drape(g, mannequin=mannequin, out_dir=out, edge_length_m=args.edge_cm / 100,
                        fabric=args.fabric, progress=False, config=config)  # fmt: skip
            row = {
                "garment": g,
                "edge_cm": args.edge_cm,
                "size": size,
                "sew_speed_limit_m_s": config.sewing.speed_limit_m_s,
                "sew_gravity_fraction_tops": config.sewing.gravity_fraction_tops,
                "integrator": args.integrator,
                "sew_at_rest_implicit": config.sewing.at_rest_implicit,
            }
            row.update({k: res.metrics.get(k) for k in KEYS})
            row["command_wall_s"] = time.perf_counter() - t0
            rows.append(row)
            print(json.dumps(row), flush=True)
    if args.table:
        print(markdown_table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
