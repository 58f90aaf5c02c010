"""Wall time of one drape: ``python benchmarks/bench_drape.py [GARMENT ...] [--edge-cm 1]``.

Default garments: the library's pencil skirt and T-shirt (or the test skirt if the library
is missing). Each drape runs in its own output directory, ``out/bench_drape/GARMENT_sizeN_Ecm``, and
prints one line of JSON: vertices, steps, dt, sewing and draping time (simulated, wall),
the sewing step and cloth softening, compile time, convergence, seam gap, contact counts,
ease, hem rise, folded area, acceptance. ``--sew-max-dt-ms 0`` sews without softening a stiff cloth
(the code before 2 Dec 2026), for comparison with the default (``SEW_MAX_DT_S``);
``--sew-gravity 1`` sews tops and dresses under full gravity (default 0.3);
``--integrator implicit_euler --edge-cm 3 --no-sew-at-rest`` sews a skirt with the implicit
solver keeping its velocities between sewing frames (before 4 Dec 2026). ``--size 8 12
18`` drapes each garment on each size; ``--table`` ends with a Markdown table of the
acceptance checks.
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
        "sew_frames", "sew_gap_m", "sew_dt_s", "sew_cloth_stiffness_factor",
        "sew_gravity_fraction", "sew_stalled", "sew_at_rest", "strain_damping_s", "sim_time_s",
        "wall_time_s", "total_wall_time_s", "compile_time_s", "build_time_s",
        "converged", "stop_reason", "max_displacement_m", "mean_displacement_m",
        "seam_gap_max_m", "vertices_inside_body",
        "intersecting_triangle_pairs", "ease_bust_cm", "ease_waist_cm", "ease_hip_cm",
        "top_below_anchor_m", "hem_rise_m", "folded_area_pct", "rolled_up",
        "meets_acceptance")  # fmt: skip


def markdown_table(rows: list[dict]) -> str:
    """The acceptance checks of bench rows as a Markdown table (one line per drape)."""
    from sandbox.scene.gallery import ACCEPTANCE_HEAD, acceptance_cells

    lines = [
        "| garment | size | fabric | vertices | wall (s) | " + ACCEPTANCE_HEAD + " |",
        "|" + "---|" * 11,
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
        "--sew-max-dt-ms",
        type=float,
        default=None,
        help="sewing step cap [ms] (sandbox.scene.drape.SEW_MAX_DT_S); 0: no softening",
    )
    p.add_argument(
        "--sew-gravity",
        type=float,
        default=None,
        help="gravity fraction while a top or dress is sewn (sandbox.scene.drape."
        "SEW_GRAVITY_TOPS, default 0.3)",
    )
    p.add_argument(
        "--sew-speed-limit",
        type=float,
        default=None,
        help="largest particle speed while sewing [m/s] (sandbox.scene.drape."
        "SEW_SPEED_LIMIT_M_S); 0: none",
    )
    p.add_argument(
        "--sew-friction",
        type=float,
        default=None,
        help="body and cloth friction while sewing (sandbox.scene.drape.SEW_FRICTION; "
        "default: the scene's own)",
    )
    p.add_argument(
        "--strain-damping",
        type=float,
        default=None,
        help="the membrane's strain-rate damping [s] (sandbox.scene.drape."
        "DRAPE_STRAIN_DAMPING_S, default 4e-6; 0: off)",
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
        "(sandbox.scene.drape.SEW_AT_REST_IMPLICIT off, the code before 4 Dec 2026)",
    )
    p.add_argument(
        "--table",
        action="store_true",
        help="after the JSON lines, a Markdown table of the acceptance checks",
    )
    args = p.parse_args(argv)

    from sandbox import runtime
    from sandbox.scene import drape as drape_module
    from sandbox.scene.drape import drape, garment_names, make_mannequin

    if args.sew_max_dt_ms is not None:
        drape_module.SEW_MAX_DT_S = args.sew_max_dt_ms / 1000.0
    if args.sew_speed_limit is not None:
        drape_module.SEW_SPEED_LIMIT_M_S = args.sew_speed_limit
    if args.sew_gravity is not None:
        drape_module.SEW_GRAVITY_TOPS = args.sew_gravity
    if args.sew_friction is not None:
        drape_module.SEW_FRICTION = args.sew_friction
    if args.strain_damping is not None:
        drape_module.DRAPE_STRAIN_DAMPING_S = args.strain_damping
    if args.no_sew_at_rest:
        drape_module.SEW_AT_REST_IMPLICIT = False

    runtime.init("cpu", float64=args.float64)
    garments = args.garments or (
        ["pencil-skirt", "t-shirt"]
        if garment_names()
        else [str(ROOT / "tests" / "data" / "drape_skirt.json")]
    )
    rows = []
    for size in args.size:
        mannequin = make_mannequin(size)
        for g in garments:
            t0 = time.perf_counter()
            # one directory per garment, size and mesh, so runs side by side do not clash
            out = ROOT / "out" / "bench_drape" / f"{Path(g).stem}_size{size}_{args.edge_cm:g}cm"
            res = drape(g, mannequin=mannequin, out_dir=out, edge_length_m=args.edge_cm / 100,
                        fabric=args.fabric, progress=False, integrator=args.integrator,
                        self_collision=not args.no_self_collision)  # fmt: skip
            row = {
                "garment": g,
                "edge_cm": args.edge_cm,
                "size": size,
                "sew_max_dt_s": drape_module.SEW_MAX_DT_S,
                "sew_speed_limit_m_s": drape_module.SEW_SPEED_LIMIT_M_S,
                "sew_friction": drape_module.SEW_FRICTION,
                "integrator": args.integrator,
                "sew_at_rest_implicit": drape_module.SEW_AT_REST_IMPLICIT,
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
