"""Skirts: the straight / pencil / A-line skirt and the circle skirt blocks
(:mod:`sandbox.drafting.blocks`). All lengths in cm."""

from __future__ import annotations

import math

from sandbox.drafting.body import BodyDims
from sandbox.drafting.geometry import (
    P,
    arc,
    line,
    panel_dict,
    symmetric_outline,
)
from sandbox.drafting.torso import (
    DEFAULT_RULES,
    Draft,
    DraftRules,
    girths,
    hem_level,
    quarter,
    seam,
    side_and_hem,
    side_seams,
    torso_placement,
)
from sandbox.errors import SandboxError

# --------------------------------------------------------------------------------------
# Skirts


def skirt(p: dict, b: BodyDims, rules: DraftRules = DEFAULT_RULES) -> Draft:
    """Straight / pencil / A-line skirt: front and back, one waist dart per half panel
    (V notch, legs sewn), hip curve, straight or flared below the hip."""
    ease = p["ease_cm"]
    shift = float(p.get("side_shift_cm", 0.0))
    darts = p.get("darts", {})
    share = float(darts.get("share", 0.5))
    panels = {}
    c = float(p.get("clearance_cm", 2.0))
    for part, sgn, pos, neg in (("front", 1, "left", "right"), ("back", -1, "right", "left")):
        q_w = quarter(b.waist, ease["waist"], sgn * shift)
        q_h = quarter(b.hip, ease["hip"], sgn * shift)
        d = min(max(share * (q_h - q_w), 0.0), float(darts.get("max_intake_cm", 4.0)))
        x_w = q_w + d
        levels = [("waist", 0.0, x_w), ("hip", -b.waist_to_hip, q_h)]
        side, bottom, info = side_and_hem(
            levels, b, p["hem"], front=part == "front", shift=sgn * shift, rules=rules
        )
        top: list[dict] = []
        ld = min(float(darts.get(f"{part}_length_cm", 10.0)), 0.8 * b.waist_to_hip)
        if d > 0.2:
            xd = float(darts.get("position", 0.5)) * q_w
            top = [
                line("waist_{s}_side", P(x_w, 0), P(xd + d / 2, 0)),
                line("dart_{s}_a", P(xd + d / 2, 0), P(xd, -ld)),
                line("dart_{s}_b", P(xd, -ld), P(xd - d / 2, 0)),
                line("waist_{s}_centre", P(xd - d / 2, 0), P(0, 0)),
            ]
        else:
            top = [line("waist_{s}", P(x_w, 0), P(0, 0))]
        edges = symmetric_outline(side, bottom=bottom, top=top, pos=pos, neg=neg)
        landmark = "waist_front" if part == "front" else "waist_back"
        panels[part] = panel_dict(
            edges,
            placement=torso_placement(part, (0, 0), landmark, c),
            meta={"girth_levels": {"waist": -0.01, "hip": round(-b.waist_to_hip, 4)}},
        )
    seams = side_seams(side)
    for part in ("front", "back"):
        names = [e["name"] for e in panel_edges(panels[part])]
        for s in ("left", "right"):
            if f"dart_{s}_a" in names:
                seams.append(seam([(part, f"dart_{s}_a")], [(part, f"dart_{s}_b")],
                                   f"{part} dart {s}"))  # fmt: skip
    return Draft(panels, seams, girths(p, b, ("waist", "hip")))


def panel_edges(panel: dict) -> list[dict]:
    return panel["edges"]


def circle_skirt(p: dict, b: BodyDims, rules: DraftRules = DEFAULT_RULES) -> Draft:
    """Circle skirt in four gores (front, left, back, right), each on the straight grain at
    its centre. ``fullness`` is the fraction of a full circle the four gores make (1: a full
    circle, 0.5: a half circle, the default 1); waist radius = (waist + ease) / (2 pi
    fullness), so each gore is a sector of fullness x 90 degrees. No rule of ``rules``
    shapes it (no hip curve, no bodice); it takes them as every block does. Each gore's
    ``meta["circle"]`` (the circle's centre and waist radius in cm, the fullness, the side)
    lets the drape start it on a cone with folds (:mod:`sandbox.garment.circle_start`)."""
    e_w = float(p["ease_cm"]["waist"])
    full = float(p.get("fullness", 1.0))
    if not 0.1 <= full <= 1.0:
        raise SandboxError(f"fullness {full}: must be between 0.1 and 1 (a full circle)")
    r = (b.waist + e_w) / (2 * math.pi * full)
    hem = p["hem"]
    ln = -hem_level(hem, b)
    big = r + ln
    phi = full * math.pi / 4  # the gore's half angle
    sn, cs = math.sin(phi), math.cos(phi)
    c = float(p.get("clearance_cm", 2.0))
    # centre of the circles at (0, r): the waist arc's midpoint is the panel origin
    wl, wr = P(-r * sn, r - r * cs), P(r * sn, r - r * cs)
    hl, hr = P(-big * sn, r - big * cs), P(big * sn, r - big * cs)
    # neighbours of each gore's +x / -x edge (x = the viewer's right, looking from outside)
    gores = {
        "front": ("front", "waist_front", "left", "right"),
        "left": ("left", "waist_front", "back", "front"),
        "back": ("back", "waist_back", "right", "left"),
        "right": ("right", "waist_front", "front", "back"),
    }
    panels = {}
    for g, (side, landmark, plus, minus) in gores.items():
        es = [
            arc("hem", hl, hr, -big * (1 - cs)),
            line(f"to_{plus}", hr, wr),
            arc("waist", wr, wl, r * (1 - cs)),
            line(f"to_{minus}", wl, hl),
        ]
        panels[g] = panel_dict(
            es, placement=torso_placement(side, (0, 0), landmark, c),
            meta={"girth_edges": {"waist": ["waist"]},
                  "circle": {"centre": [0.0, round(r, 4)], "waist_radius": round(r, 4),
                             "fullness": full, "side": side}},
        )  # fmt: skip
    seams = []
    for a, bb in (("front", "left"), ("left", "back"), ("back", "right"), ("right", "front")):
        seams.append(seam([(a, f"to_{bb}")], [(bb, f"to_{a}")], f"{a}-{bb}"))
    g = girths(p, b, ("waist",))
    return Draft(panels, seams, g)
