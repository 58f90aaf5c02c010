"""``python -m sandbox mannequin``: build a mannequin by size and/or the seven measurements.

Standalone until wired into ``python -m sandbox``: ``python -m sandbox.mannequin.cli``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from sandbox.errors import SandboxError
from sandbox.mannequin.measurements import KEYS, SUPPORTED_RANGE_CM, size_entry

FLAGS = {
    "bust_girth": "--bust",
    "waist_girth": "--waist",
    "hip_girth": "--hip",
    "shoulder_width": "--shoulder-width",
    "back_width": "--back-width",
    "shoulder_length": "--shoulder-length",
    "back_length": "--back-length",
}


def add_cli(subparsers) -> argparse.ArgumentParser:
    """Add the ``mannequin`` sub-command to an argparse ``subparsers`` object."""
    p = subparsers.add_parser(
        "mannequin",
        help="build a dress form resized by the paper's 7 measurements (cm)",
        description="Build the parametric mannequin (Leong et al. 2011, §2.1.4): the closest "
        "database size, resized to the given measurements in cm (any flag left out comes "
        "from --size). Writes the mesh, landmarks.json, measurements.json and a PNG.",
    )
    _add_arguments(p)
    p.set_defaults(func=run)
    return p


def add_measurement_flags(p: argparse.ArgumentParser) -> None:
    """``--size`` and the seven measurement flags (cm); shared by every body command."""
    p.add_argument("--size", type=int, default=None, help="database size 6-26 (default 12)")
    for key in KEYS:
        lo, hi = SUPPORTED_RANGE_CM[key]
        p.add_argument(
            FLAGS[key],
            dest=key,
            type=float,
            default=None,
            metavar="CM",
            help=f"{key.replace('_', ' ')} in cm (supported {lo:g}-{hi:g})",
        )


def standalone_main(add_cli, command: str, argv: list[str] | None) -> int:
    """Run one sub-command on its own (``python -m sandbox.<pkg>.cli ...``)."""
    parser = argparse.ArgumentParser(prog="python -m sandbox")
    sub = parser.add_subparsers(dest="command")
    add_cli(sub)
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] != command:
        argv = [command, *argv]
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except SandboxError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


def _add_arguments(p: argparse.ArgumentParser) -> None:
    add_measurement_flags(p)
    p.add_argument(
        "--body",
        type=Path,
        default=None,
        help="measure an external body mesh (OBJ/PLY/GLB/STL) and use it instead",
    )
    p.add_argument(
        "--resolution", type=int, default=None, help="torso columns, a multiple of 16 (default 48)"
    )
    p.add_argument("--mesh-format", choices=("obj", "ply"), default="obj")
    p.add_argument("--no-png", action="store_true", help="skip the off-screen PNG")
    p.add_argument("--out", type=Path, required=True, help="output directory")


def run(args: argparse.Namespace) -> int:
    """Handler of ``mannequin``; raises :class:`SandboxError` on bad input."""
    from sandbox.mannequin.io import load_body_mesh, write_mannequin
    from sandbox.mannequin.model import DEFAULT_RESOLUTION, build_mannequin
    from sandbox.preflight import check_mannequin

    given = {k: getattr(args, k) for k in KEYS if getattr(args, k) is not None}
    if args.body is not None and (given or args.size is not None):
        raise SandboxError("--body: cannot be combined with --size or measurement flags")
    check_mannequin(args)  # every flag and --out, before a mesh is built
    resolution = DEFAULT_RESOLUTION if args.resolution is None else args.resolution
    if args.body is not None:
        mannequin = load_body_mesh(args.body)
    else:
        base = size_entry(args.size if args.size is not None else 12)
        target = base.measurements.replace(**given)
        mannequin = build_mannequin(
            target,
            size=args.size,
            resolution=resolution,
            flag_names=FLAGS,
        )
    written = write_mannequin(
        mannequin, args.out, png=not args.no_png, mesh_name=f"mannequin.{args.mesh_format}"
    )
    for path in written:
        print(path)
    return 0


def main(argv: list[str] | None = None) -> int:
    return standalone_main(add_cli, "mannequin", argv)


if __name__ == "__main__":
    raise SystemExit(main())
