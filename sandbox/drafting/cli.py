"""``python -m sandbox pattern``: draft a library garment for a body, write the pattern file.

Standalone until wired into ``python -m sandbox``: ``python -m sandbox.drafting.cli``.

    python -m sandbox.drafting.cli --list
    python -m sandbox.drafting.cli t-shirt --size 14 --bust 95 --out out/t-shirt.json
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from sandbox.errors import SandboxError
from sandbox.mannequin.cli import FLAGS
from sandbox.mannequin.measurements import KEYS, SUPPORTED_RANGE_CM, size_entry, validate


def add_cli(subparsers) -> argparse.ArgumentParser:
    """Add the ``pattern`` sub-command to an argparse ``subparsers`` object."""
    p = subparsers.add_parser(
        "pattern",
        help="draft a library garment (paper Fig. 7) to a size / measurements (cm)",
        description="Draft GARMENT from the garment library (garments/*.json) for the body "
        "of --size (default 12) with any of the seven measurements overridden (cm), and "
        "write the sandbox-pattern/1 JSON file (cm) to --out. --list prints the garments.",
    )
    p.add_argument("garment", nargs="?", help="garment name (see --list) or a garment .json")
    p.add_argument("--list", action="store_true", help="print the garment names and exit")
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
    p.add_argument(
        "--mannequin",
        action="store_true",
        help="build the mannequin and take heights, neck and shoulder slope from its "
        "landmarks (slower; default: the size table)",
    )
    p.add_argument("--png", type=Path, default=None, help="also draw the panels to this PNG")
    p.add_argument("--out", type=Path, default=None, help="output pattern file (.json)")
    p.set_defaults(func=run)
    return p


def run(args: argparse.Namespace) -> int:
    """Handler of ``pattern``; raises :class:`SandboxError` on bad input."""
    from sandbox.drafting.garments import draft, garment_names, load_garment

    if args.list:
        for name in garment_names():
            print(name)
        return 0
    if not args.garment:
        raise SandboxError("pattern: name a GARMENT (or use --list)")
    if args.out is None:
        raise SandboxError("pattern: --out FILE.json is required")
    garment = load_garment(args.garment)
    given = {k: getattr(args, k) for k in KEYS if getattr(args, k) is not None}
    base = size_entry(args.size if args.size is not None else 12)
    target = base.measurements.replace(**given)
    validate(target, flag_names=FLAGS)
    mannequin = None
    if args.mannequin:
        from sandbox.mannequin import build_mannequin

        mannequin = build_mannequin(target, size=args.size, flag_names=FLAGS)
    pattern = draft(garment, target, mannequin=mannequin)
    from sandbox.pattern.spec import save_pattern

    path = save_pattern(pattern, args.out)
    print(path)
    if args.png is not None:
        from sandbox.drafting.sheet import draw_pattern

        print(draw_pattern(pattern, args.png, title=f"{garment.title} ({garment.fabric})"))
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sandbox.drafting.cli")
    sub = parser.add_subparsers(dest="command")
    add_cli(sub)
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] != "pattern":
        argv = ["pattern", *argv]
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except SandboxError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
