"""A log-log scatter plot drawn with numpy and Pillow (no matplotlib dependency).

``loglog_png(points, path, ...)`` draws points (x, y) > 0 grouped by colour (one per
series, e.g. an integrator) and by marker (one per case), with decade grid lines, tick
labels and a legend. Non-positive or non-finite values are skipped (and counted in the
caption).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from sandbox.atomic import atomic_path

COLOURS = [(31, 119, 180), (214, 39, 40), (44, 160, 44), (148, 103, 189), (255, 127, 14)]
MARKERS = ["o", "s", "^", "D", "v", "x"]


def _font(size: int):
    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1
        return ImageFont.load_default()


def _decades(lo: float, hi: float) -> tuple[int, int]:
    a, b = math.floor(math.log10(lo)), math.ceil(math.log10(hi))
    return a, max(b, a + 1)


def _marker(d: ImageDraw.ImageDraw, kind: str, x: float, y: float, r: float, colour):
    if kind == "o":
        d.ellipse([x - r, y - r, x + r, y + r], outline=colour, width=2)
    elif kind == "s":
        d.rectangle([x - r, y - r, x + r, y + r], outline=colour, width=2)
    elif kind == "^":
        d.polygon([(x, y - r), (x - r, y + r), (x + r, y + r)], outline=colour, width=2)
    elif kind == "v":
        d.polygon([(x, y + r), (x - r, y - r), (x + r, y - r)], outline=colour, width=2)
    elif kind == "D":
        d.polygon([(x, y - r), (x + r, y), (x, y + r), (x - r, y)], outline=colour, width=2)
    else:
        d.line([x - r, y - r, x + r, y + r], fill=colour, width=2)
        d.line([x - r, y + r, x + r, y - r], fill=colour, width=2)


def loglog_png(
    points: list[tuple[float, float, str, str]],
    path: str | Path,
    *,
    title: str,
    xlabel: str,
    ylabel: str,
    hline: float | None = None,
    size: tuple[int, int] = (1000, 700),
) -> int:
    """Write the plot; ``points`` are (x, y, series, marker group). Returns points drawn."""
    good = [p for p in points if p[0] > 0 and p[1] > 0 and math.isfinite(p[0] * p[1])]
    series = sorted({p[2] for p in points})
    groups = sorted({p[3] for p in points})
    w, h = size
    left, right, top, bottom = 90, 230, 50, 70
    img = Image.new("RGB", size, "white")
    d = ImageDraw.Draw(img)
    font, small = _font(16), _font(13)
    xs = np.array([p[0] for p in good] or [1.0])
    ys = np.array([p[1] for p in good] or [1.0])
    if hline:
        ys = np.append(ys, hline)
    x0, x1 = _decades(xs.min(), xs.max())
    y0, y1 = _decades(ys.min(), ys.max())

    def px(x):
        return left + (math.log10(x) - x0) / (x1 - x0) * (w - left - right)

    def py(y):
        return h - bottom - (math.log10(y) - y0) / (y1 - y0) * (h - top - bottom)

    for e in range(x0, x1 + 1):
        X = px(10.0**e)
        d.line([X, top, X, h - bottom], fill=(220, 220, 220))
        d.text((X - 14, h - bottom + 6), f"1e{e}", fill="black", font=small)
        for k in range(2, 10):
            if e < x1:
                Xm = px(k * 10.0**e)
                d.line([Xm, h - bottom, Xm, h - bottom - 5], fill="black")
    for e in range(y0, y1 + 1):
        Y = py(10.0**e)
        d.line([left, Y, w - right, Y], fill=(220, 220, 220))
        d.text((left - 45, Y - 7), f"1e{e}", fill="black", font=small)
        for k in range(2, 10):
            if e < y1:
                Ym = py(k * 10.0**e)
                d.line([left, Ym, left + 5, Ym], fill="black")
    d.rectangle([left, top, w - right, h - bottom], outline="black")
    if hline:
        Y = py(hline)
        for X in range(left, w - right, 12):
            d.line([X, Y, min(X + 6, w - right), Y], fill=(120, 120, 120), width=1)
        d.text((w - right - 120, Y - 18), f"{hline:g} % target", fill=(90, 90, 90), font=small)
    for x, y, s, g in good:
        colour = COLOURS[series.index(s) % len(COLOURS)]
        _marker(d, MARKERS[groups.index(g) % len(MARKERS)], px(x), py(y), 6, colour)
    d.text((left, 15), title, fill="black", font=font)
    d.text(((left + w - right) / 2 - 60, h - 35), xlabel, fill="black", font=font)
    label = Image.new("RGB", (400, 24), "white")
    ImageDraw.Draw(label).text((0, 2), ylabel, fill="black", font=font)
    label = label.rotate(90, expand=True)
    img.paste(label, (15, top + 40))
    ly = top + 10
    for s in series:
        colour = COLOURS[series.index(s) % len(COLOURS)]
        d.line([w - right + 20, ly + 8, w - right + 45, ly + 8], fill=colour, width=4)
        d.text((w - right + 52, ly), s, fill="black", font=small)
        ly += 22
    ly += 10
    for g in groups:
        _marker(d, MARKERS[groups.index(g) % len(MARKERS)], w - right + 32, ly + 8, 6, "black")
        d.text((w - right + 52, ly), g, fill="black", font=small)
        ly += 22
    skipped = len(points) - len(good)
    if skipped:
        d.text((w - right + 20, ly + 10), f"{skipped} run(s) without a\nfinite error not drawn",
               fill=(120, 0, 0), font=small)  # fmt: skip
    with atomic_path(path) as tmp:
        img.save(tmp, format="PNG")
    return len(good)
