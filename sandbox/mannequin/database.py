"""Build the size database from the Aldrich size table.

Run ``python -m sandbox.mannequin.database [SOURCE] [OUT ...]``. Defaults: the source
``../shared/data/body_sizes.json`` beside the repository (needed only to regenerate; loading
the database never reads it) and two identical outputs, the canonical
``mannequins/sizes.json`` and the copy shipped in the package,
``sandbox/data/mannequin_sizes.json`` (what :func:`load_size_table` reads).

The table (Aldrich, sizes 6-26, cm) gives bust, waist, hip, back width, shoulder length,
nape to waist and the extra values the shape rules use, but no across-shoulder width. We
derive it: each size is built with its neck base from the table's neck size (an ellipse of
that perimeter, width/depth 1.12), its shoulder length from the table along a 20 degree
shoulder slope and its back width from the table; the tape measure then reads the
shoulder width over the back neck point on that body. The one missing value in the
source (sleeve length of size 12) is the mean of sizes 10 and 14.
"""

from __future__ import annotations

import argparse
import json
import logging
from pathlib import Path

from sandbox.atomic import write_json
from sandbox.errors import SandboxError
from sandbox.mannequin.measurements import (
    KEYS,
    REPO_SIZE_TABLE_PATH,
    Measurements,
    SizeEntry,
)
from sandbox.mannequin.model import BASE_SIZE, DEFAULT_RESOLUTION
from sandbox.mannequin.resize import Corrector, fit_shape
from sandbox.mannequin.shape import shape_from_size
from sandbox.mannequin.surface import BodyTemplate

log = logging.getLogger(__name__)

DEFAULT_SOURCE = Path(__file__).resolve().parents[3] / "shared" / "data" / "body_sizes.json"
PACKAGE_SIZE_TABLE_PATH = Path(__file__).resolve().parents[1] / "data" / "mannequin_sizes.json"
DEFAULT_OUTPUTS = (REPO_SIZE_TABLE_PATH, PACKAGE_SIZE_TABLE_PATH)
EXTRA_KEYS = (
    "neck_size",
    "chest",
    "armscye_depth",
    "waist_to_hip",
    "body_rise",
    "waist_to_knee",
    "waist_to_floor",
    "top_arm",
    "wrist",
    "dart",
    "sleeve_length",
)


def _rows(source: Path) -> list[dict]:
    try:
        data = json.loads(source.read_text(encoding="utf-8"))
        rows = data["sizes"]
    except (OSError, json.JSONDecodeError, KeyError) as exc:
        raise SandboxError(f"{source}: cannot read the size table: {exc}") from exc
    rows = sorted(rows, key=lambda r: r["size_uk_old_coding"])
    for i, row in enumerate(rows):
        for k in EXTRA_KEYS:
            if row["extra"].get(k) is None:
                nb = [rows[j]["extra"][k] for j in (i - 1, i + 1) if 0 <= j < len(rows)]
                row["extra"][k] = sum(nb) / len(nb)
                log.info("size %s: %s missing, using %.2f", row["size_uk_old_coding"], k, nb)
    return rows


def _entry(row: dict, shoulder_width: float) -> SizeEntry:
    m = Measurements(
        bust_girth=float(row["bust_girth"]),
        waist_girth=float(row["waist_girth"]),
        hip_girth=float(row["hip_girth"]),
        shoulder_width=shoulder_width,
        back_width=float(row["back_width_across"]),
        shoulder_length=float(row["shoulder_length"]),
        back_length=float(row["back_length_nape_to_waist"]),
    )
    return SizeEntry(int(row["size_uk_old_coding"]), m, {k: row["extra"][k] for k in EXTRA_KEYS})


def build_database(source: Path = DEFAULT_SOURCE) -> dict:
    """The database as a JSON-ready dict (cm), shoulder widths derived with the tape."""
    rows = _rows(Path(source))
    # the same mesh as the mannequins (model._structure): base size 14, diagonals checked
    # on the smallest and largest sizes, default resolution
    base = _entry(min(rows, key=lambda r: abs(r["size_uk_old_coding"] - BASE_SIZE)), 40.0)
    extremes = tuple(shape_from_size(_entry(r, 40.0)) for r in (rows[0], rows[-1]))
    template = BodyTemplate(shape_from_size(base), DEFAULT_RESOLUTION, samples=extremes)
    corrector = Corrector(template, template.landmark_indices())
    sizes = []
    for row in rows:
        provisional = _entry(row, 40.0)
        s = fit_shape(template, corrector, provisional.measurements, provisional, keep_neck=True)
        got = corrector.upper(s)
        sw = round(100.0 * got["shoulder_width"], 1)
        entry = _entry(row, sw)
        sizes.append(
            {
                "size": entry.size,
                "measurements": entry.measurements.to_dict(),
                "extra": entry.extra,
            }
        )
    return {
        "units": "cm",
        "description": "Mannequin size database: the seven measurements of Leong et al. 2011 "
        "§2.1.4 per size, plus the extra Aldrich values the body shape rules use.",
        "source": "Aldrich standard body measurements, sizes 6-26, from "
        "../shared/data/body_sizes.json (see its 'source' for provenance)",
        "shoulder_width_derivation": "Not in the source. Measured with the tape measure "
        "(shoulder point over the back neck point to shoulder point) on each size built "
        "with its neck base from neck_size, shoulder_length at a 20 degree slope and "
        "back_width from the table (python -m sandbox.mannequin.database).",
        "keys": list(KEYS),
        "sizes": sizes,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("source", nargs="?", type=Path, default=DEFAULT_SOURCE)
    parser.add_argument("out", nargs="*", type=Path, default=list(DEFAULT_OUTPUTS))
    args = parser.parse_args(argv)
    data = build_database(args.source)
    for out in args.out:
        write_json(out, data)
        print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
