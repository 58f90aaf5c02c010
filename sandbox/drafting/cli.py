"""``python -m sandbox pattern``: draft a library garment for a body, write the pattern file.

Standalone until wired into ``python -m sandbox``: ``python -m sandbox.drafting.cli``.

    python -m sandbox.drafting.cli --list
    python -m sandbox.drafting.cli t-shirt --size 14 --bust 95 --out out/t-shirt.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

from sandbox.errors import SandboxError
from sandbox.mannequin.cli import FLAGS, add_measurement_flags, standalone_main
from sandbox.mannequin.measurements import KEYS, size_entry, validate


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
    add_measurement_flags(p)
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
    from sandbox.preflight import check_output_file

    check_output_file(args.out, "--out")
    if args.png is not None:
        check_output_file(args.png, "--png", suffixes=(".png",))
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
    return standalone_main(add_cli, "pattern", argv)


if __name__ == "__main__":
    raise SystemExit(main())
