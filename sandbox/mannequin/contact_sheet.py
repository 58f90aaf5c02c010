"""Contact sheet of every database size: ``python -m sandbox.mannequin.contact_sheet [OUT]``.

Writes ``docs/mannequin_sizes.png`` by default: the bodies of sizes 6-26 side by side
(front view), 25 cm apart, each with its feature lines.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from sandbox.mannequin.io import BODY_COLOR, _line_color, render_mannequin_png
from sandbox.mannequin.measurements import load_size_table
from sandbox.mannequin.model import build_mannequin

DEFAULT_OUT = Path(__file__).resolve().parents[2] / "docs" / "mannequin_sizes.png"


def contact_sheet(out: Path = DEFAULT_OUT, *, spacing_m: float = 1.1) -> Path:
    """Render all database sizes in a row (front view) into ``out``."""
    meshes, lines = [], []
    for i, entry in enumerate(load_size_table()):
        body = build_mannequin(size=entry.size)
        shift = np.array([i * spacing_m, 0.0, 0.0])
        meshes.append(
            {"vertices": body.vertices + shift, "triangles": body.triangles, "color": BODY_COLOR}
        )
        for name, pts in body.feature_lines.items():
            lines.append({"points": pts + shift, "color": _line_color(name)})
    return render_mannequin_png(out, meshes, lines, views=("front",), width=2400, height=420)


if __name__ == "__main__":
    print(contact_sheet(Path(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT_OUT))
