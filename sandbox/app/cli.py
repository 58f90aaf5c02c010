"""``python -m sandbox gui``: the interactive sandbox, or the same session off-screen."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from sandbox.app.live_solver import DEFAULT_LIVE_SOLVER, INTEGRATORS
from sandbox.errors import SandboxError
from sandbox.precision import add_precision_flags
from sandbox.scene.budget import add_limit_flags, limits_from_args


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m sandbox gui",
        description="A garment's panels around the mannequin, simulating: resize the body "
        "with the seven measurement sliders, sew by clicking two panel edges (shift-click "
        "adds edges to a side), drag cloth vertices. --offscreen plays a JSON script of "
        "actions instead and writes PNG frames and a GIF (docs/gui.md).",
        epilog="Examples:\n  python -m sandbox gui sheath-dress --size 12\n"
        "  python -m sandbox gui sheath-dress --offscreen --script docs/gui/demo_script.json "
        "--out out/gui\n",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("garment", nargs="?", default="sheath-dress",
                   help="library garment or pattern file (default sheath-dress)")  # fmt: skip
    p.add_argument("--size", type=int, default=12, help="starting mannequin size (default 12)")
    p.add_argument("--edge-cm", type=float, default=3.0, help="mesh edge in cm (default 3)")
    p.add_argument("--fabric", default=None, help="fabric preset (default: the garment's)")
    p.add_argument("--sewn", action="store_true", help="start with the pattern's seams sewn")
    p.add_argument("--self-collision", action="store_true", help="cloth against itself")
    p.add_argument(
        "--integrator",
        default=DEFAULT_LIVE_SOLVER.integrator,
        choices=INTEGRATORS,
        help="implicit_euler (default: backward Euler with a fixed Newton budget, several "
        "times more simulated time per wall second) or symplectic_euler (the paper's Eq. 2)",
    )
    p.add_argument(
        "--newton",
        type=int,
        default=DEFAULT_LIVE_SOLVER.newton_iterations,
        metavar="N",
        help="implicit_euler: Newton iterations per step at most (default %(default)s)",
    )
    p.add_argument(
        "--steps",
        type=int,
        default=DEFAULT_LIVE_SOLVER.steps_per_frame,
        metavar="N",
        help="implicit_euler: steps per 1/30 s frame (default %(default)s)",
    )
    p.add_argument("--offscreen", action="store_true", help="no window: play --script")
    p.add_argument("--script", type=Path, default=None, help="JSON list of actions")
    p.add_argument("--out", type=Path, default=Path("out/gui"), help="output directory")
    p.add_argument("--width", type=int, default=1024, help="window or frame width in pixels, "
                   "64-8192 (default 1024)")  # fmt: skip
    p.add_argument("--height", type=int, default=768, help="window or frame height in pixels, "
                   "64-8192 (default 768)")  # fmt: skip
    p.add_argument("--fps", type=float, default=30.0,
                   help="target display rate: the simulation gets what is left of each "
                   "frame (default 30)")  # fmt: skip
    p.add_argument(
        "--sim-ms",
        type=float,
        default=None,
        help="fixed simulation wall time per displayed frame [ms] instead",
    )
    p.add_argument("--max-frames", type=int, default=None, help=argparse.SUPPRESS)
    p.add_argument("--status", type=Path, default=None, help=argparse.SUPPRESS)
    p.add_argument("--arch", default="cpu", help="Taichi arch (default cpu)")
    add_precision_flags(p)
    add_limit_flags(p)
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        from sandbox.preflight import check_gui

        actions = check_gui(args)  # every flag and the script, before Taichi starts
        limits = limits_from_args(args)
        from sandbox import runtime
        from sandbox.app.session import LiveSolver, Session

        # a caller that started Taichi keeps its precision
        runtime.init(
            args.arch, float64=runtime.is_float64() if runtime.is_initialised() else args.float64
        )
        session = Session(args.garment, size=args.size, edge_cm=args.edge_cm,
                          fabric=args.fabric, sewn=args.sewn,
                          self_collision=args.self_collision, limits=limits,
                          solver=LiveSolver(integrator=args.integrator,
                                            newton_iterations=args.newton,
                                            steps_per_frame=args.steps))  # fmt: skip
        if args.offscreen:
            from sandbox.app.script import run_script

            summary = run_script(session, actions, args.out, size=(args.width, args.height),
                                 source=str(args.script))  # fmt: skip
            print(f"wrote {args.out}/summary.json" + (f" and {summary['gif']}"
                                                       if "gif" in summary else ""))  # fmt: skip
            return 0
        from sandbox.app.gui import run_window

        budget = None if args.sim_ms is None else args.sim_ms / 1000.0
        run_window(session, size=(args.width, args.height), target_fps=args.fps,
                   frame_budget_s=budget, max_frames=args.max_frames,
                   status_path=args.status)  # fmt: skip
        return 0
    except SandboxError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
