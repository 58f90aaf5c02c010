"""Pieces shared by the torso blocks (:mod:`sandbox.drafting.blocks`): the :class:`Draft`
they return, the drafting rules, seams, the side seam and hem of a torso panel, its
placement and the girths it is measured at. All lengths in cm."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from sandbox.drafting.body import BodyDims
from sandbox.drafting.geometry import (
    P,
    arc,
    line,
    quad,
    split_quadratic,
)
from sandbox.errors import SandboxError

BUST_LEVEL_BELOW_UNDERARM = 0.01  # [cm] the bust girth is read just inside the panel


@dataclasses.dataclass(frozen=True)
class DraftRules:
    """Proportions of the blocks that are the drafting system's choices, not the garment's
    parameters (``garments/<name>.json``) nor the body's measurements."""

    neck_ease_cm: float = 0.5
    """[cm] The pattern's neck half width over the body's neck base: the neckline clears the
    neck without gaping (Aldrich's close-fitting block)."""
    hip_curve_control: float = 0.4
    """[-] The hip curve's control point sits at this fraction of the waist-to-hip depth
    below the waist: the side seam leaves the waist steeply and rounds over the hip."""
    width_level: float = 0.55
    """[-] The across-back / across-chest line of a raglan, as a fraction of the way from
    the underarm line up to the shoulder point (where the raglan curve is scooped in to
    the body's width)."""


DEFAULT_RULES = DraftRules()
"""The defaults (frozen: shared as the default argument of the blocks)."""


@dataclasses.dataclass
class Draft:
    """A drafted garment: pattern-format panels, seams and the designed girths [cm]."""

    panels: dict[str, dict]
    seams: list[dict]
    girths: dict[str, dict] = dataclasses.field(default_factory=dict)


def seam(a, b, name: str) -> dict:
    """A seam between two lists of (panel, edge name), direction "auto"."""
    return {
        "name": name,
        "a": [{"panel": p, "edge": e} for p, e in a],
        "b": [{"panel": p, "edge": e} for p, e in b],
        "direction": "auto",
    }


def side_seams(side: list[dict], front: str = "front", back: str = "back") -> list[dict]:
    """Left and right side seams, each edge list in its panel's own running order (the
    right half of a panel runs bottom-up, the mirrored half top-down): front and back lines
    run opposite ways and "auto" pairs them."""
    names = [e["name"] for e in side]  # bottom-up, with {s}
    out = []
    for s in ("left", "right"):
        f = [n.replace("{s}", s) for n in (names if s == "left" else names[::-1])]
        k = [n.replace("{s}", s) for n in (names if s == "right" else names[::-1])]
        out.append(seam([(front, n) for n in f], [(back, n) for n in k], f"side seam {s}"))
    return out


def torso_placement(side: str, anchor, landmark: str, clearance: float) -> dict:
    return {
        "body": "torso",
        "side": side,
        "anchor": [round(float(anchor[0]), 4), round(float(anchor[1]), 4)],
        "landmark": landmark,
        "wrap": True,
        "clearance": clearance,
    }


def hem_level(hem: dict, b: BodyDims) -> float:
    """Centre-back hem height [cm] (negative = below the waist)."""
    refs = {"waist": 0.0, "hip": -b.waist_to_hip, "knee": -b.waist_to_knee}
    level = hem.get("level", "hip")
    if level not in refs:
        raise SandboxError(f"hem level {level!r}: use one of {', '.join(refs)}")
    return refs[level] - float(hem.get("offset_cm", 0.0))


# --------------------------------------------------------------------------------------
# Side seams and hems (shared by tops, dresses and skirts)


def quarter(girth: float, ease, shift: float) -> float | None:
    return None if ease is None else (girth + float(ease)) / 4.0 + shift


def side_and_hem(
    levels: list[tuple[str, float, float]],
    b: BodyDims,
    hem: dict,
    *,
    front: bool,
    shift: float = 0.0,
    curve_hip: bool = True,
    rules: DraftRules,
) -> tuple[list[dict], list[dict] | dict, dict]:
    """The right-half side seam (bottom-up) and the hem of a torso panel.

    ``levels``: (name, y, half width) from the top of the side seam down, at the levels the
    garment defines (the top one always, "waist" y = 0 and "hip" y = -waist_to_hip where
    the ease is given); ``rules``: the hip curve's shape. Returns (side edges from the hem
    corner up to the top, the bottom edge(s) for :func:`symmetric_outline`, info with the
    hem corner and centre heights).
    """
    y_hem = hem_level(hem, b)
    top_y = levels[0][1]
    if y_hem >= top_y - 2.0:
        raise SandboxError(f"the hem ({y_hem:.1f} cm) is above the top of the side seam")
    flare = float(hem.get("flare_cm", 0.0))
    curve = float(hem.get("curve_cm", 0.0))
    square = bool(hem.get("square_to_sides", True))
    drop = float(hem.get("front_drop_cm", 0.0)) if front else 0.0
    point = float(hem.get("front_point_cm", 0.0)) if front else 0.0

    def x_at(y: float) -> float:
        ys = [lv[1] for lv in levels]
        xs = [lv[2] for lv in levels]
        if y <= ys[-1]:
            return xs[-1]
        return float(np.interp(y, ys[::-1], xs[::-1]))

    by_name = {lv[0]: lv for lv in levels}
    from_waist = (
        hem.get("flare_from", "hip") == "waist"
        and "waist" in by_name
        and "hip" in by_name
        and y_hem < -b.waist_to_hip - 1.0
    )
    rise = curve
    y_c = y_hem + rise
    for _ in range(6):  # the hem squared to the side seam: the rise depends on the flare
        above = [lv for lv in levels if lv[1] > y_c + 1e-6]
        x_up, y_up = above[-1][2], above[-1][1]
        if from_waist:
            x_up, y_up = by_name["waist"][2], 0.0
        x_c = x_at(y_c) + (flare if y_c < -b.waist_to_hip + 1e-6 or "hip" not in by_name else 0)
        phi = math.atan2(x_c - x_up, y_up - y_c)
        rise = curve + ((x_c - shift) * math.tan(phi / 2) if square and phi > 0 else 0.0)
        y_c = y_hem + rise
    corner = P(x_c, y_c)
    names = {"top": "side_{s}", "waist": "side_{s}_hip", "hip": "side_{s}_skirt"}
    pts = [lv for lv in levels if lv[1] > y_c + 1e-6 and not (from_waist and lv[0] == "hip")]
    edges: list[dict] = []
    lower = corner
    for lv in reversed(pts):
        upper = P(lv[2], lv[1])
        name = names["top"] if lv is levels[0] else names[lv[0]]
        if lv[0] == "waist" and from_waist:
            # one smooth curve from the hem corner through the hip point to the waist
            hip = P(by_name["hip"][2], by_name["hip"][1])
            d1, d2 = np.linalg.norm(hip - lower), np.linalg.norm(upper - hip)
            t = d1 / (d1 + d2)
            ctrl = (hip - (1 - t) ** 2 * lower - t**2 * upper) / (2 * t * (1 - t))
            edges.append(quad(name, lower, ctrl, upper))
        elif lv[0] == "waist" and curve_hip and "hip" in by_name:
            xh, yh = by_name["hip"][2], by_name["hip"][1]
            ctrl = P(xh, rules.hip_curve_control * yh)
            if y_c >= yh - 1e-6 and y_c < 0:  # hem inside the hip curve: split it
                m, c1, p1 = _hip_curve_above(P(xh, yh), ctrl, upper, y_c)
                corner = m
                edges.append(quad(name, m, c1, p1))
            else:
                edges.append(quad(name, lower, ctrl, upper))
        else:
            edges.append(line(name, lower, upper))
        lower = upper
    x_c, y_c = corner
    y_cf = y_hem - drop
    if point > 0:
        bottom: list[dict] | dict = [line("hem_{s}", P(0, y_cf - point), corner)]
    else:
        bottom = arc("hem", P(-x_c, y_c), corner, -(y_c - y_cf))
    return edges, bottom, {"corner": corner, "y_hem": y_hem, "y_cf": y_cf - point}


# --------------------------------------------------------------------------------------
# Bodice


def _hip_curve_above(hip, ctrl, waist, y_c: float) -> tuple:
    """(start, control, end) of the part of the hip curve (a quadratic from the hip point
    to the waist) above height ``y_c``."""
    # y(t) = yh (1-t)^2 + 2 t (1-t) c_y on the curve from the hip (t=0) to the waist
    yh, cy = hip[1], ctrl[1]
    a, bq, cq = yh - 2 * cy, 2 * cy - 2 * yh, yh - y_c
    disc = max(bq * bq - 4 * a * cq, 0.0)
    roots = (
        [(-bq + sg * math.sqrt(disc)) / (2 * a) for sg in (1, -1)] if abs(a) > 1e-12 else [-cq / bq]
    )
    t = min((r for r in roots if -1e-9 <= r <= 1 + 1e-9), key=lambda r: abs(r - 0.5))
    _, upper = split_quadratic(hip, ctrl, waist, t)
    return upper


def side_levels(p: dict, b: BodyDims, y_top: float, shift: float) -> list[tuple[str, float, float]]:
    """Side seam levels (name, y, half width) of a torso panel; None eases are skipped
    (the side seam runs straight past them)."""
    ease = p["ease_cm"]
    out = [("bust", y_top, quarter(b.bust, ease["bust"], shift))]
    if ease.get("waist") is not None:
        out.append(("waist", 0.0, quarter(b.waist, ease["waist"], shift)))
    if ease.get("hip") is not None:
        out.append(("hip", -b.waist_to_hip, quarter(b.hip, ease["hip"], shift)))
    return out


def measured_girths(panels: dict) -> tuple[str, ...]:
    """The girths every torso panel can be measured at (levels inside the garment)."""
    keys = ("bust", "waist", "hip")
    for pn in ("front", "back"):
        lv = panels[pn].get("meta", {}).get("girth_levels", {})
        keys = tuple(k for k in keys if k in lv)
    return keys


def girths(p: dict, b: BodyDims, keys=("bust", "waist", "hip")) -> dict[str, dict]:
    out = {}
    for k in keys:
        e = p["ease_cm"].get(k)
        if e is not None:
            body = getattr(b, k)
            out[k] = {"body": round(body, 3), "ease": e, "garment": round(body + e, 3)}
    return out


def levels_meta(levels, y_top: float, y_corner: float) -> dict:
    """Panel meta: the heights where the girths are read (levels at least 1 cm above the
    hem corner; the bust just below the underarm corner)."""
    meta = {}
    for name, y, _ in levels:
        if y > y_corner + 1.0:
            meta[name] = round(y - BUST_LEVEL_BELOW_UNDERARM if y == y_top else y, 4)
    return {"girth_levels": meta}
