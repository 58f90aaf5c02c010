"""2D check pictures of drafted patterns (Pillow, no matplotlib).

Panels are drawn side by side in their own frames (y up), seamed edges coloured by seam
with the seam's number at the middle of each edge, the grain as an arrow and the placement
anchor as a dot. ``python -m sandbox.drafting.sheet`` redraws docs/garments/*.png.
"""

from __future__ import annotations

import colorsys
from pathlib import Path

import numpy as np

from sandbox.atomic import atomic_path
from sandbox.drafting.geometry import edges_of, sample

MARGIN_CM = 6.0


def _colour(k: int) -> tuple[int, int, int]:
    r, g, b = colorsys.hsv_to_rgb((k * 0.618034) % 1.0, 0.85, 0.8)
    return int(r * 255), int(g * 255), int(b * 255)


def draw_pattern(pattern: dict, path: str | Path, *, px_per_cm: float = 4.0,
                 title: str | None = None) -> Path:  # fmt: skip
    """Write a PNG of the pattern's panels (cm) to ``path``; returns the path."""
    from PIL import Image, ImageDraw, ImageFont

    seam_of: dict[tuple[str, str], int] = {}
    for i, s in enumerate(pattern.get("seams", [])):
        for ref in (*s["a"], *s["b"]):
            seam_of[(ref["panel"], ref["edge"])] = i
    boxes, x0 = {}, MARGIN_CM
    for name, p in pattern["panels"].items():
        v = np.asarray(p["vertices"], float)
        pts = np.vstack([sample(e, 1.0) for e in edges_of(p).values()] + [v])
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        boxes[name] = (x0 - lo[0], lo, hi)
        x0 += hi[0] - lo[0] + MARGIN_CM
    y_lo = min(b[1][1] for b in boxes.values()) - MARGIN_CM
    y_hi = max(b[2][1] for b in boxes.values()) + MARGIN_CM * 1.5
    w, h = int(x0 * px_per_cm) + 1, int((y_hi - y_lo) * px_per_cm) + 1
    img = Image.new("RGB", (w, h), (255, 255, 255))
    dr = ImageDraw.Draw(img)
    font = ImageFont.load_default(size=max(10, int(2.6 * px_per_cm)))

    def px(p, dx):
        return ((p[0] + dx) * px_per_cm, (y_hi - p[1]) * px_per_cm)

    for name, p in pattern["panels"].items():
        dx, lo, hi = boxes[name]
        es = edges_of(p)
        outline = np.vstack([sample(e, 0.5)[:-1] for e in es.values()])
        dr.polygon([px(q, dx) for q in outline], fill=(236, 240, 246), outline=(60, 60, 60))
        for en, e in es.items():
            q = sample(e, 0.5)
            k = seam_of.get((name, en))
            colour = (60, 60, 60) if k is None else _colour(k)
            dr.line([px(t, dx) for t in q], fill=colour, width=3 if k is not None else 1)
            if k is not None:
                m = q[len(q) // 2]
                dr.text(px(m, dx), str(k), fill=colour, font=font, anchor="mm")
        c = 0.5 * (lo + hi)
        g = np.asarray(p.get("grain", [0, 1]), float)
        g = g / np.linalg.norm(g) * 0.25 * (hi[1] - lo[1])
        a, b = c - g / 2, c + g / 2
        dr.line([px(a, dx), px(b, dx)], fill=(120, 120, 120), width=2)
        n = np.array([-g[1], g[0]]) * 0.15
        dr.polygon([px(b, dx), px(b - 0.3 * g + n, dx), px(b - 0.3 * g - n, dx)],
                   fill=(120, 120, 120))  # fmt: skip
        pl = p.get("placement", {})
        if "anchor" in pl:
            ax, ay = px(pl["anchor"], dx)
            r = 0.9 * px_per_cm
            dr.ellipse([ax - r, ay - r, ax + r, ay + r], fill=(200, 30, 30))
        dr.text(
            px(((lo[0] + hi[0]) / 2, hi[1] + 2.5), dx), name, fill=(0, 0, 0), font=font, anchor="mm"
        )
    if title:
        dr.text((6, 4), title, fill=(0, 0, 0), font=font)
    with atomic_path(path) as tmp:
        img.save(tmp)
    return Path(path)


def main(argv: list[str] | None = None) -> int:
    """Redraw docs/garments/<name>.png for every library garment at size 12."""
    import argparse

    from sandbox.drafting.garments import draft, garment_names, load_garment
    from sandbox.mannequin.measurements import size_entry

    ap = argparse.ArgumentParser(prog="python -m sandbox.drafting.sheet")
    ap.add_argument("--size", type=int, default=12)
    ap.add_argument(
        "--out", type=Path, default=Path(__file__).resolve().parents[2] / "docs" / "garments"
    )
    ap.add_argument("--px-per-cm", type=float, default=3.0)
    args = ap.parse_args(argv)
    m = size_entry(args.size).measurements
    for name in garment_names():
        g = load_garment(name)
        d = draft(g, m)
        path = draw_pattern(d, args.out / f"{name}.png", px_per_cm=args.px_per_cm,
                            title=f"{g.title}, size {args.size} ({g.fabric})")  # fmt: skip
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
