"""Command line: ``python -m sandbox <command> ...``.

The CLI only parses arguments and calls the same scene, solver and writers a script
would use; it holds no physics. Errors a user can fix are printed as one line, without a
traceback, and exit with status 2.
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import sys
from importlib import resources
from pathlib import Path

from sandbox import preflight
from sandbox.errors import SandboxError
from sandbox.precision import add_precision_flags
from sandbox.scene.budget import add_limit_flags, limits_from_args, show_sizes
from sandbox.scene.spec import INTEGRATORS

log = logging.getLogger("sandbox")

DEFAULT_SCENE = "hanging_sheet.toml"
DEFAULT_GARMENT = "sheath-dress"
DEFAULT_EDGE_CM = 1.75  # the seam gap grows with the spacing: 2.01 mm at 2 cm (limit 2)


def default_scene_path() -> Path:
    """The scene the demo runs (packaged in ``sandbox/scenes``)."""
    return Path(str(resources.files("sandbox") / "scenes" / DEFAULT_SCENE))


def _add_runtime_flags(p: argparse.ArgumentParser) -> None:
    p.add_argument("--arch", default="cpu", choices=["cpu", "gpu", "cuda", "vulkan"],
                   help="Taichi backend (default: cpu)")  # fmt: skip
    add_precision_flags(p)
    p.add_argument("--quiet", "-q", action="store_true", help="no progress bar or summary")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m sandbox",
        description="Garment simulation sandbox (Leong, Kuo, Fang 2011) on Taichi.",
        epilog="Examples:\n"
        "  python -m sandbox demo --out out/demo\n"
        "  python -m sandbox run my_scene.toml --out out/my_scene\n"
        "  python -m sandbox validate cantilever --json\n"
        "  python -m sandbox validate cusick --quick\n"
        "  python -m sandbox fabrics\n"
        "  python -m sandbox drape t-shirt --size 12 --out out/t-shirt\n"
        "  python -m sandbox pattern a-line-skirt --bust 92 --out skirt.json\n"
        "  python -m sandbox gui sheath-dress --size 12\n"
        "  python -m sandbox batch examples/batch_small.toml --out out/batch\n"
        "  python -m sandbox render out/t-shirt --turntable\n"
        "  python -m sandbox report --quick\n"
        "  python -m sandbox figures\n"
        "Scene files are documented in docs/scene_format.md.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("run", help="simulate a scene file headless and write the results",
                       description="Simulate SCENE (a TOML file, see docs/scene_format.md) until "
                       "the stop rule holds or a time limit is reached, then write mesh.obj, "
                       "mesh.ply (UVs = pattern coordinates in metres), render.png and "
                       "metrics.json into --out.")  # fmt: skip
    p.add_argument("scene", type=Path, help="scene file (.toml)")
    p.add_argument("--out", type=Path, required=True, help="output directory (created)")
    p.add_argument("--no-render", action="store_true", help="skip the PNG")
    p.add_argument(
        "--direct",
        action="store_true",
        help="ignore the scene's [multilevel] table: run its own mesh from the start",
    )
    _add_runtime_flags(p)
    add_limit_flags(p)

    p = sub.add_parser("demo", help=f"drape the default garment ({DEFAULT_GARMENT}) on the "
                       "default mannequin (size 12)",
                       description=f"Drape {DEFAULT_GARMENT} (the garment library) on the size "
                       f"12 mannequin with {DEFAULT_EDGE_CM:g} cm mesh edges, like `drape`, and "
                       "write garment and body meshes, front and back renders and "
                       "metrics.json. --scene runs the packaged hanging sheet "
                       f"(sandbox/scenes/{DEFAULT_SCENE}) instead.")  # fmt: skip
    p.add_argument("--out", type=Path, default=Path("out/demo"), help="default: out/demo")
    p.add_argument("--garment", default=DEFAULT_GARMENT, help=f"default: {DEFAULT_GARMENT}")
    p.add_argument("--edge-cm", type=float, default=DEFAULT_EDGE_CM,
                   help=f"mesh edge in cm (default {DEFAULT_EDGE_CM:g})")  # fmt: skip
    p.add_argument("--scene", action="store_true", help="run the hanging-sheet scene instead")
    p.add_argument("--no-render", action="store_true", help="skip the PNG")
    _add_runtime_flags(p)
    add_limit_flags(p)

    p = sub.add_parser(
        "validate",
        help="compare the simulator with physical references",
        description="Run a validation case and print error against run time.",
    )
    p.add_argument("case", choices=["cantilever", "cusick"],
                   help="cantilever: heavy elastica, ASTM D1388; cusick: Cusick drape test, "
                   "BS 5058, every fabric preset")  # fmt: skip
    p.add_argument("--json", action="store_true", help="one JSON object per run, one per line")
    p.add_argument("--quick", action="store_true", help="fewer meshes and time steps")
    p.add_argument("--lambdas", type=float, nargs="+", default=None,
                   help="cantilever: λ = wL³/B values (default 1 8 30)")  # fmt: skip
    p.add_argument("--out", type=Path, default=None,
                   help="cusick: directory for the table and shadows (default "
                   "out/validate-cusick)")  # fmt: skip
    p.add_argument("--presets", nargs="+", default=None,
                   help="cusick: fabric presets to run (default: all)")  # fmt: skip
    _add_runtime_flags(p)

    sub.add_parser("fabrics", help="list the fabric presets and their parameters")

    _add_drape_parsers(sub)

    from sandbox.drafting.cli import add_cli as add_pattern_cli
    from sandbox.mannequin.cli import add_cli as add_mannequin_cli

    add_mannequin_cli(sub)
    add_pattern_cli(sub)
    from sandbox.batch.cli import add_cli as add_batch_cli

    add_batch_cli(sub)  # `batch`: drapes on Ray (docs/batch.md)
    p = sub.add_parser("check-pattern", add_help=False,
                       help="validate and mesh pattern files; print panels and seams")  # fmt: skip
    p.add_argument("argv", nargs=argparse.REMAINDER)
    p = sub.add_parser("import-garmentcode", add_help=False,
                       help="convert a GarmentCode pattern specification JSON")  # fmt: skip
    p.add_argument("argv", nargs=argparse.REMAINDER)
    for command, text in FORWARDED_HELP.items():
        p = sub.add_parser(command, add_help=False, help=text)
        p.add_argument("argv", nargs=argparse.REMAINDER)
    return parser


FORWARDED = {
    "check-pattern": "sandbox.pattern.panel_mesh",
    "import-garmentcode": "sandbox.pattern.garmentcode",
    "gui": "sandbox.app.cli",
    "render": "sandbox.render.studio",
    "report": "sandbox.validate.report",
    "figures": "sandbox.validate.figures",
}
"""Sub-commands that are a module's own ``main(argv)``; their options are theirs."""

FORWARDED_HELP = {
    "gui": "the interactive sandbox: mannequin sliders, click-to-sew, drag (or --offscreen)",
    "render": "Open3D renders of saved results: front, back, turntable PNG and video",
    "report": "error-against-run-time and stability reports (docs/error-vs-runtime.md)",
    "figures": "the README's table of figures, read from the generated files (docs/figures.md)",
}


def _forward(module: str, command: str, argv: list[str]) -> int:
    """Run a module's own ``main(argv)`` as a sub-command (its help under this name)."""
    import importlib
    import sys as _sys

    mod = importlib.import_module(module)
    old = _sys.argv[0]
    _sys.argv[0] = f"python -m sandbox {command}"
    try:
        return int(mod.main(list(argv)) or 0)
    finally:
        _sys.argv[0] = old


def _add_drape_parsers(sub) -> None:
    from sandbox.garment.config import DRAPE_METHODS  # imports Taichi: not for check-pattern
    from sandbox.mannequin.cli import add_measurement_flags

    p = sub.add_parser(
        "drape",
        help="drape a garment (library name or pattern .json) on the mannequin",
        description="Mesh the garment's panels, place them around the mannequin, sew them "
        "(without gravity), then drape under gravity until the paper's stop rule (1.5 mm max, "
        "0.1 mm mean per frame). Writes garment.obj/.ply, body.obj, render.png (front), "
        "render_back.png and metrics.json (ease in cm, contact metrics) into --out. "
        "See docs/drape.md.",
    )
    p.add_argument("garment", nargs="?", help="a library garment name (see --list) or a "
                   "pattern file (.json, docs/pattern_format.md)")  # fmt: skip
    p.add_argument("--list", action="store_true", help="print the library's garments, one a line")
    add_measurement_flags(p)
    p.add_argument("--garmentcode-body", type=Path, default=None, metavar="YAML",
                   help="size the mannequin from a GarmentCode body file (its bust, waist, "
                   "hips and nape-to-waist, its arm pose, its head; the rest from the "
                   "closest size; docs/garmentcode.md); not with --size or measurement "
                   "flags")  # fmt: skip
    p.add_argument("--arm-angle", type=float, default=None, metavar="DEG",
                   help="the mannequin's arms at this angle from the vertical, 16-55 "
                   "(default: 16, opened until they clear the torso; with "
                   "--garmentcode-body, the body file's arm pose)")  # fmt: skip
    p.add_argument("--head-cm", type=float, default=None, metavar="CM",
                   help="a head on the mannequin, its crown this far above the nape, 18-35 "
                   "(default: none, or the body file's head_l with --garmentcode-body, or "
                   "the pattern's meta.head_length_cm: what a hood rests on)")  # fmt: skip
    p.add_argument("--fabric", default=None, help="fabric preset (default: the garment's own)")
    p.add_argument("--edge-cm", type=float, default=None,
                   help="mesh edge length in cm (default 1; 3 with --integrator "
                   "implicit_euler)")  # fmt: skip
    p.add_argument("--time-limit", type=float, default=None, metavar="S",
                   help="simulated time limit in s (default 8)")  # fmt: skip
    p.add_argument("--no-self-collision", action="store_true", help="cloth passes through itself")
    p.add_argument("--no-fit-check", action="store_true",
                   help="drape a pattern even if its girth at the bust, waist or hip is well "
                   "short of the body's (docs/drape.md)")  # fmt: skip
    p.add_argument("--fast-sew", action="store_true",
                   help="no self-collision while sewing: about 3x faster, but panels may "
                   "pass through each other and keep those crossings")  # fmt: skip
    p.add_argument(
        "--config",
        type=Path,
        default=None,
        metavar="FILE",
        help="a TOML file of drape settings (DrapeConfig's fields, with [sewing], "
        "[repair] and [acceptance] tables; docs/drape.md); the flags below win",
    )
    p.add_argument("--integrator", choices=INTEGRATORS, default=None,
                   help="symplectic_euler (the paper's Eq. 2, default) or implicit_euler "
                   "(backward Euler at 1/60 s steps, docs/implicit.md; it meshes at 3 cm unless "
                   "--edge-cm says otherwise: finer, Newton does not converge and a drape "
                   "takes hours; at 3 cm all 14 garments meet the acceptance, "
                   "docs/gallery-implicit)")  # fmt: skip
    p.add_argument("--method", choices=DRAPE_METHODS, default=None,
                   help="coarse_to_fine (default: sew and drape a 3 cm mesh, carry its shape to "
                   "the fine mesh and let it settle, docs/performance.md) or direct (sew and "
                   "drape the fine mesh itself, the paper's way and the reference)")  # fmt: skip
    p.add_argument("--strain-damping", type=float, default=None, metavar="S",
                   help="the membrane's strain-rate damping in s (default 4e-6; 0: off; it "
                   "settles stiff fabrics' contact chatter, docs/drape.md)")  # fmt: skip
    p.add_argument("--out", type=Path, default=None, help="output directory (created)")
    p.add_argument("--no-render", action="store_true", help="skip the PNGs")
    p.add_argument("--no-meshes", action="store_true",
                   help="no garment.obj/.ply or body.obj: renders and metrics only")  # fmt: skip
    _add_runtime_flags(p)
    add_limit_flags(p)

    p = sub.add_parser(
        "gallery",
        help="drape every library garment and write a contact sheet and a table",
        description="Drape all garments of the library on one mannequin and write "
        "gallery.png (front views in a grid with names, like the paper's Fig. 7), gallery.md "
        "(vertices, wall time, convergence, seam gap, contact metrics, ease) and each "
        "garment's renders and metrics into --out.",
    )
    p.add_argument("--out", type=Path, default=Path("docs/gallery"), help="default: docs/gallery")
    p.add_argument("--quick", action="store_true",
                   help="3 cm meshes, jersey everywhere, 4 s limit (a smoke test)")  # fmt: skip
    p.add_argument("--size", type=int, default=12, help="mannequin database size (default 12)")
    p.add_argument("--only", nargs="+", default=None, metavar="GARMENT", help="a subset")
    p.add_argument("--edge-cm", type=float, default=None,
                   help="mesh edge in cm (default 1; 3 with --integrator "
                   "implicit_euler)")  # fmt: skip
    p.add_argument("--integrator", choices=INTEGRATORS,
                   default="symplectic_euler",
                   help="symplectic_euler (default) or implicit_euler "
                   "(docs/implicit.md)")  # fmt: skip
    p.add_argument(
        "--method",
        choices=DRAPE_METHODS,
        default="coarse_to_fine",
        help="coarse_to_fine (default) or direct (docs/performance.md)",
    )
    p.add_argument("--meshes", action="store_true", help="also write each garment's meshes")
    p.add_argument("--resume", action="store_true",
                   help="read back the garments already draped in --out with the same size, "
                   "mesh edge, fabric and integrator instead of draping them again")  # fmt: skip
    p.add_argument("--jobs", "-j", type=int, default=1, metavar="N",
                   help="drape N garments at once, each in its own process with the CPU's "
                   "threads shared out (default 1)")  # fmt: skip
    _add_runtime_flags(p)


def drape_config_from_args(args, base=None):
    """The drape's :class:`~sandbox.garment.DrapeConfig`: ``base`` (a ``--config`` file's, or
    the defaults) with the command line's flags applied on top."""
    from sandbox.garment import DrapeConfig

    config = base or DrapeConfig()
    changes = {}
    if args.integrator is not None:
        changes["integrator"] = args.integrator
    if args.method is not None:
        changes["method"] = args.method
    if args.no_self_collision:
        changes["self_collision"] = False
    if getattr(args, "no_fit_check", False):
        changes["fit"] = dataclasses.replace(config.fit, enabled=False)
    if args.fast_sew or args.no_self_collision:
        changes["sewing"] = dataclasses.replace(config.sewing, self_collision=False)
    if args.time_limit is not None:
        if not args.time_limit > 0:
            raise SandboxError(f"--time-limit {args.time_limit}: must be positive")
        changes["time_limit_s"] = args.time_limit
    if args.strain_damping is not None:
        if not args.strain_damping >= 0:
            raise SandboxError(f"--strain-damping {args.strain_damping}: must be >= 0 s")
        changes["strain_damping_s"] = args.strain_damping
    return dataclasses.replace(config, **changes)


def guard_summary(metrics: dict) -> str:
    from sandbox.sim.guard import summary_line

    return summary_line(metrics)


def cmd_drape(args) -> int:
    from sandbox.garment import check_garment, default_edge_m, drape, garment_names
    from sandbox.garment.config import load_drape_config
    from sandbox.mannequin.measurements import KEYS

    if args.list:  # before Taichi starts: its banner would mix into the list
        for name in garment_names():
            print(name)
        return 0
    from sandbox import runtime

    if not args.garment:
        raise SandboxError("drape: name a garment (see --list) or a pattern .json file")
    check_garment(args.garment)
    if args.out is None:
        raise SandboxError("drape: --out DIR is required")
    config = drape_config_from_args(args, load_drape_config(args.config) if args.config else None)
    config = dataclasses.replace(config, limits=limits_from_args(args, config.limits))
    if args.edge_cm is None:  # implicit drapes converge only on coarser meshes
        args.edge_cm = default_edge_m(config.integrator) * 100.0
    if not args.edge_cm > 0:
        raise SandboxError(f"--edge-cm {args.edge_cm}: must be a positive length in cm")
    measurements = {k: getattr(args, k) for k in KEYS if getattr(args, k) is not None}
    if args.garmentcode_body is not None:
        from sandbox.pattern.garmentcode_body import load_garmentcode_body

        if measurements or args.size is not None:
            raise SandboxError("--garmentcode-body sizes the mannequin: drop --size and the "
                               "measurement flags")  # fmt: skip
        body = load_garmentcode_body(args.garmentcode_body)
        args.size, measurements = body.size, dict(body.measurements)
        if args.arm_angle is None:
            args.arm_angle = body.arm_angle_deg
        if args.head_cm is None:
            args.head_cm = body.head_length_cm
        if not args.quiet:
            print(
                f"{body.source}: size {body.size} resized to "
                + ", ".join(f"{k} {v:g}" for k, v in measurements.items())
                + " cm"
            )
            for note in body.notes:
                print(f"  {note}")
    preflight.check_drape(args)
    runtime.init(args.arch, float64=args.float64)
    res = drape(args.garment, size=args.size, measurements=measurements or None,
                fabric=args.fabric, out_dir=args.out, edge_length_m=args.edge_cm / 100.0,
                config=config, render=not args.no_render, meshes=not args.no_meshes,
                progress=None if not args.quiet else False, arm_angle_deg=args.arm_angle,
                head_length_cm=args.head_cm)  # fmt: skip
    if not args.quiet:
        m = res.metrics
        state = "converged" if m["converged"] else f"stopped ({m['stop_reason']})"

        def cm(v):
            return "-" if v is None else f"{v:+.1f} cm"

        print(f"{m['garment']}: {m['vertex_count']} vertices on size {m['mannequin_size']}, "
              f"{m['fabric']}; dt = {m['dt_s']:.3g} s; sewn in {m['sew_sim_time_s']:.2f} s, "
              f"{state} after {m['sim_time_s']:.2f} s simulated, "
              f"{m['total_wall_time_s']:.1f} s wall")  # fmt: skip
        print(guard_summary(m))
        if m.get("method") == "coarse_to_fine":
            print(f"coarse to fine: {m['coarse_edge_length_m'] * 100:g} cm level "
                  f"({m['coarse_vertex_count']} vertices) sewn and draped in "
                  f"{m['coarse_sim_time_s']:.2f} s simulated, {m['coarse_wall_time_s']:.1f} s "
                  f"wall; fine level settled in {m['fine_sim_time_s']:.2f} s simulated, "
                  f"{m['fine_wall_time_s']:.1f} s wall")  # fmt: skip
        if m.get("coarse_fallback"):
            print(f"{m['coarse_fallback']} ({m['coarse_wall_time_s']:.1f} s wall spent on it)")
        if m.get("residual_mean_over_weight") is not None:
            print(f"equilibrium residual: mean {m['residual_mean_over_weight']:.3f}, max "
                  f"{m['residual_max_over_weight']:.2f} of a vertex's weight")  # fmt: skip
        gap = m.get("seam_gap_max_m")
        print(f"seam gap max {0.0 if gap is None else gap * 1e3:.2f} mm, penetration "
              f"{(m['penetration_max_m'] or 0.0) * 1e3:.2f} mm, vertices inside body "
              f"{m['vertices_inside_body']}, body vertices through the cloth "
              f"{m.get('body_through_cloth_vertices')} (deepest "
              f"{(m.get('body_through_cloth_max_m') or 0.0) * 1e3:.1f} mm), "
              f"intersecting triangle pairs "
              f"{m['intersecting_triangle_pairs']}; ease bust {cm(m['ease_bust_cm'])}, "
              f"waist {cm(m['ease_waist_cm'])}, hip {cm(m['ease_hip_cm'])}")  # fmt: skip
        for r in m.get("untangle") or []:
            if r["pairs_before"]:
                print(f"untangled {r['when']}: {r['pairs_before']} -> {r['pairs_after']} "
                      f"crossing triangle pairs ({r['vertices_moved']} vertices moved, at most "
                      f"{r['largest_move_m'] * 1e3:.1f} mm)")  # fmt: skip
        verdict = "meets" if m.get("meets_acceptance") else "does not meet"
        print(f"{verdict} the acceptance (meets_acceptance in metrics.json)")
        print("wrote:")
        for path in res.paths.values():
            print(f"  {path}")
    return 0


def cmd_gallery(args) -> int:
    from sandbox import runtime
    from sandbox.garment.gallery import gallery

    preflight.check_gallery(args)
    runtime.init(args.arch, float64=args.float64)
    paths = gallery(args.out, quick=args.quick, size=args.size, names=args.only,
                    edge_length_m=None if args.edge_cm is None else args.edge_cm / 100.0,
                    meshes=args.meshes, progress=not args.quiet,
                    resume=args.resume, jobs=args.jobs, integrator=args.integrator,
                    method=args.method)  # fmt: skip
    for p in paths:
        print(p)
    return 0


def cmd_run(scene_path: Path, args) -> int:
    from sandbox import runtime
    from sandbox.scene.build import build_scene
    from sandbox.scene.output import write_outputs
    from sandbox.scene.run import run_scene
    from sandbox.scene.spec import load_scene

    preflight.check_output_dir(args.out, "--out", names=preflight.RUN_OUTPUTS)
    spec = load_scene(scene_path)  # every input check happens before Taichi starts
    if spec.multilevel is not None and getattr(args, "direct", False):
        spec = dataclasses.replace(spec, multilevel=None)

    def start():
        runtime.init(args.arch, float64=args.float64)

    def build(level):
        return build_scene(level, start_runtime=start, limits=limits_from_args(args, level.limits))

    if spec.multilevel is not None:
        from sandbox.scene.multilevel import run_multilevel

        scene, result = run_multilevel(spec, build, progress=None if not args.quiet else False)
        if not args.quiet:
            for lv in result.metrics["levels"]:
                edge = spec.cloths[0].edge_length_m if lv["edge_length_m"] is None else lv[
                    "edge_length_m"]  # fmt: skip
                print(f"  level {edge * 100:g} cm: {lv['vertex_count']} vertices, {lv['steps']} "
                      f"steps of {lv['dt_s'] * 1e6:.0f} us, {lv['sim_time_s']:.2f} s simulated, "
                      f"{lv['wall_time_s']:.1f} s wall; {lv['stop_reason']}")  # fmt: skip
    else:
        scene = build(spec)
        if not args.quiet:
            print(f"{spec.name}: {scene.model.particle_count} vertices, {scene.model.tri_count} "
                  f"triangles, {scene.model.hinge_count} hinges; dt = {scene.dt_s:.3g} s "
                  f"(stability estimate {scene.dt_limit_s:.3g} s)", flush=True)  # fmt: skip
        result = run_scene(scene, progress=None if not args.quiet else False)
    paths = write_outputs(scene, result, args.out, render=not args.no_render)
    if not args.quiet:
        m = result.metrics
        state = "converged" if result.converged else f"stopped ({result.reason})"
        print(f"{state} after {m['steps']} steps, {m['sim_time_s']:.2f} s simulated in "
              f"{m['wall_time_s']:.1f} s wall (+{m['compile_time_s']:.1f} s compile); "
              f"last frame: max displacement {m['max_displacement_m'] * 1e3:.3f} mm, "
              f"mean {m['mean_displacement_m'] * 1e3:.4f} mm")  # fmt: skip
        if m.get("residual_mean_over_weight") is not None:
            print(f"equilibrium residual: mean {m['residual_mean_over_weight']:.3f}, max "
                  f"{m['residual_max_over_weight']:.2f} vertex weights")  # fmt: skip
        if "total_wall_time_s" in m:
            print(f"method {m['method']}: {m['total_wall_time_s']:.1f} s wall over all levels, "
                  f"building and compilation included")  # fmt: skip
        print(guard_summary(m))
        print("wrote:")
        for p in paths.values():
            print(f"  {p}")
    return 0


def main(argv: list[str] | None = None) -> int:
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    argv = sys.argv[1:] if argv is None else list(argv)
    forwarded = bool(argv) and argv[0] in FORWARDED
    args = parser = None
    if not forwarded:
        parser = build_parser()
        args = parser.parse_args(argv)
        if args.command is None:
            parser.print_help()
            return 2
    # every scene that starts says its size, predicted and built (sandbox.scene.budget)
    show_sizes(argv[0] == "gui" if forwarded else
               args.command in ("run", "demo", "drape") and not args.quiet)  # fmt: skip
    try:
        if forwarded:
            return _forward(FORWARDED[argv[0]], argv[0], argv[1:])
        if args.command == "run":
            return cmd_run(args.scene, args)
        if args.command == "demo":
            if args.scene:
                return cmd_run(default_scene_path(), args)
            # the demo is `drape` with its defaults: parsed by drape's own parser, so every
            # option drape gains has its default here too
            drape = [
                "drape", args.garment, "--out", str(args.out), "--edge-cm", str(args.edge_cm),
                "--arch", args.arch,
            ]  # fmt: skip
            drape += ["--no-render"] * args.no_render + ["--float32"] * (not args.float64)
            drape += ["--quiet"] * args.quiet
            for flag, value in (("--max-vertices", args.max_vertices),
                                ("--max-memory-gb", args.max_memory_gb)):  # fmt: skip
                drape += [flag, str(value)] * (value is not None)
            return cmd_drape(parser.parse_args(drape))
        if args.command == "validate":
            preflight.check_validate(args)
            if args.case == "cusick":
                from sandbox.validate.cusick import main as cusick_main

                return cusick_main(args)
            from sandbox.validate.cantilever import main as cantilever_main

            return cantilever_main(args)
        if args.command == "drape":
            return cmd_drape(args)
        if args.command == "gallery":
            return cmd_gallery(args)
        if args.command == "fabrics":
            from sandbox.sim.materials import materials_table_markdown

            print(materials_table_markdown())
            return 0
        if hasattr(args, "func"):
            return int(args.func(args) or 0)
        parser.error(f"unknown command {args.command!r}")
    except SandboxError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted; no partial output was written", file=sys.stderr)
        return 130
    except BrokenPipeError:  # e.g. piped into `head`: stop quietly
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    return 0
