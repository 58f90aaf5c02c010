"""``python -m sandbox batch --report DIR``: counts per status and per gate, contact sheets.

The report reads the batch folder as it is (the plan and the task folders, as the manifest
is rebuilt), so it also works while a batch runs or after one was killed. Where tasks have
a front render, it writes ``contact_accepted.png`` and ``contact_rejected.png``: a grid of
front views, each labelled with the garment, the body and (rejected) the first gate failed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sandbox.batch import manifest, store
from sandbox.batch.gates import GATES

MAX_TILES = 60
"""Most drapes on one contact sheet (the first in task order)."""
TILE_PX = 320
LABEL_CHARS = 34


def report(root, *, sheets: bool = True) -> tuple[list[str], list[Path]]:
    """The report's lines and the contact sheets written (none without renders)."""
    root = Path(root)
    rows = manifest.build_rows(root)
    status = {k: sum(r["status"] == k for r in rows) for k in store.STATUSES}
    lines = [f"{root}: {len(rows)} tasks: " + ", ".join(f"{k} {n}" for k, n in status.items())]
    lines.append("rejected or failed per gate (a task may fail several):")
    width = max(len(g) for g in GATES)
    for g in GATES:
        n = sum(g in (r["gates_failed"] or []) for r in rows)
        lines.append(f"  {g:<{width}}  {n}")
    errors = [r for r in rows if r["status"] == "failed"]
    if errors:
        lines.append("failed:")
        lines += [f"  {r['task_id']}: {r['error']}" for r in errors[:20]]
        if len(errors) > 20:
            lines.append(f"  ... and {len(errors) - 20} more (manifest.jsonl)")
    done = [r["task_wall_s"] for r in rows if r["task_wall_s"] is not None]
    if done:
        lines.append(f"task wall time: median {np.median(done):.1f} s, total {sum(done):.0f} s "
                     f"over {len(done)} tasks")  # fmt: skip
    written = write_sheets(root, rows) if sheets else []
    lines += [f"wrote {p}" for p in written]
    return lines, written


def _label(r: dict) -> str:
    text = f"{r['garment']} {r['body']}"
    if r["status"] == "rejected" and r["gates_failed"]:
        text += f": {r['gates_failed'][0]}"
    return text if len(text) <= LABEL_CHARS else text[: LABEL_CHARS - 1] + "…"


def write_sheets(root, rows: list[dict]) -> list[Path]:
    """``contact_accepted.png`` and ``contact_rejected.png`` from the tasks' ``render.png``
    (sheets without any render are not written)."""
    import imageio.v3 as iio

    from sandbox.garment.gallery import write_sheet

    root = Path(root)
    written = []
    for status in ("accepted", "rejected"):
        tiles = []
        for r in rows:
            image = root / r["folder"] / "render.png"
            if r["status"] != status or not image.is_file():
                continue
            try:
                tile = np.asarray(iio.imread(image))[:, :, :3]
            except (OSError, ValueError, IndexError):
                tile = None
            tiles.append((_label(r), tile))
            if len(tiles) == MAX_TILES:
                break
        if tiles:
            written.append(write_sheet(root / f"contact_{status}.png", tiles, tile_px=TILE_PX))
    return written
