"""Command line: ``python -m sandbox <command> ...``.

The CLI only parses arguments and calls the same scene, solver and writers a script
would use; it holds no physics. Errors a user can fix are printed as one line, without a
traceback, and exit with status 2.
"""

from __future__ import annotations

import argparse
import logging
import sys
from importlib import resources
from pathlib import Path

from sandbox.errors import SandboxError

log = logging.getLogger("sandbox")

DEFAULT_SCENE = "hanging_sheet.toml"


def default_scene_path() -> Path:
    """The scene the demo runs (packaged in ``sandbox/scenes``)."""
    return Path(str(resources.files("sandbox") / "scenes" / DEFAULT_SCENE))


def _add_runtime_flags(p: argparse.ArgumentParser) -> None:
    p.add_argument("--arch", default="cpu", choices=["cpu", "gpu", "cuda", "vulkan"],
                   help="Taichi backend (default: cpu)")  # fmt: skip
    p.add_argument("--float64", action="store_true", help="simulate in double precision")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress bar or summary")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m sandbox",
        description="Garment simulation sandbox (Leong, Kuo, Fang 2011) on Taichi.",
        epilog="Examples:\n"
        "  python -m sandbox demo --out out/demo\n"
        "  python -m sandbox run my_scene.toml --out out/my_scene\n"
        "  python -m sandbox validate cantilever --json\n"
        "  python -m sandbox fabrics\n"
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
    _add_runtime_flags(p)

    p = sub.add_parser("demo", help="run the built-in default scene (a hanging sheet)",
                       description="Run the packaged default scene "
                       f"(sandbox/scenes/{DEFAULT_SCENE}) and write its outputs.")  # fmt: skip
    p.add_argument("--out", type=Path, default=Path("out/demo"), help="default: out/demo")
    p.add_argument("--no-render", action="store_true", help="skip the PNG")
    _add_runtime_flags(p)

    p = sub.add_parser(
        "validate",
        help="compare the simulator with physical references",
        description="Run a validation case and print error against run time.",
    )
    p.add_argument("case", choices=["cantilever"], help="cantilever: heavy elastica, ASTM D1388")
    p.add_argument("--json", action="store_true", help="one JSON object per run, one per line")
    p.add_argument("--quick", action="store_true", help="fewer meshes and time steps")
    p.add_argument("--lambdas", type=float, nargs="+", default=None,
                   help="λ = wL³/B values (default 1 8 30)")  # fmt: skip
    _add_runtime_flags(p)

    sub.add_parser("fabrics", help="list the fabric presets and their parameters")

    try:
        from sandbox.mannequin.cli import add_cli
    except ImportError:
        add_cli = None
    if add_cli is not None:
        add_cli(sub)
    return parser


def cmd_run(scene_path: Path, args) -> int:
    from sandbox import runtime
    from sandbox.scene.build import build_scene
    from sandbox.scene.output import write_outputs
    from sandbox.scene.run import run_scene
    from sandbox.scene.spec import load_scene

    spec = load_scene(scene_path)  # every input check happens before Taichi starts
    runtime.init(args.arch, float64=args.float64)
    scene = build_scene(spec)
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
        print("wrote:")
        for p in paths.values():
            print(f"  {p}")
    return 0


def main(argv: list[str] | None = None) -> int:
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    try:
        if args.command == "run":
            return cmd_run(args.scene, args)
        if args.command == "demo":
            return cmd_run(default_scene_path(), args)
        if args.command == "validate":
            from sandbox.validate.cantilever import main as cantilever_main

            return cantilever_main(args)
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
