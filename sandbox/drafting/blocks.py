"""Drafting blocks (after Aldrich, Metric Pattern Cutting for Women's Wear): bodice, sleeve,
raglan, camisole, halter, skirt and circle skirt. All lengths in cm.

Every block is a function ``block(params, body) -> Draft`` taking the garment's drafting
parameters (``garments/<name>.json`` ``"params"``) and the body's :class:`BodyDims`, and
returning whole panels (the front spans the full front, the back the full back; left and
right halves are mirror images about the centre line x = 0), seams and the designed girths.

Panel frames (see docs/garments.md): torso panels have y = 0 at the waist and y up; a
front panel is seen from the front, its x towards the body's left (+X); a back panel is seen
from behind, its x towards the body's right (-X). Sleeves have y = 0 at the underarm (biceps)
line, the cap top at (0, cap height) and x across the arm, seen from outside the arm: on the
right arm x points to the front, on the left arm to the back (in every panel x is the
viewer's right hand looking at the outside of the garment). Outlines are counter-clockwise
in these frames. Edge names say the body side: ``side_left`` is the left side seam of the
body on both the front and the back panel.

No darts in bodices (whole front/back panels cannot hold a fish-eye dart, and a side bust
dart would need its own seam): the bodice is Aldrich's dartless ("flat") block, shaped at
the side seams, with the bust allowance given as extra length at the centre-front hem.
Skirts keep one waist dart per half panel (a V notch in the waist edge, its legs sewn).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from sandbox.drafting.body import BodyDims
from sandbox.drafting.geometry import (
    P,
    arc,
    cubic,
    length,
    line,
    mirror_x,
    panel_dict,
    quad,
    rigid,
    split_quadratic,
    symmetric_outline,
    transform,
)
from sandbox.errors import SandboxError
from sandbox.pattern.curves import bezier_point

NECK_EASE_CM = 0.5  # pattern neck half width over the body's neck base
BUST_LEVEL_BELOW_UNDERARM = 0.01  # the girth is read just below the underarm corner
HIP_CURVE_CONTROL = 0.4  # hip curve control point at this fraction of waist-to-hip depth
WIDTH_LEVEL = 0.55  # across-back / across-chest line, fraction from underarm to shoulder


@dataclasses.dataclass
class Draft:
    """A drafted garment: pattern-format panels, seams and the designed girths [cm]."""

    panels: dict[str, dict]
    seams: list[dict]
    girths: dict[str, dict] = dataclasses.field(default_factory=dict)


def _seam(a, b, name: str) -> dict:
    """A seam between two lists of (panel, edge name), direction "auto"."""
    return {
        "name": name,
        "a": [{"panel": p, "edge": e} for p, e in a],
        "b": [{"panel": p, "edge": e} for p, e in b],
        "direction": "auto",
    }


def _side_seams(side: list[dict], front: str = "front", back: str = "back") -> list[dict]:
    """Left and right side seams, each edge list in its panel's own running order (the
    right half of a panel runs bottom-up, the mirrored half top-down): front and back lines
    run opposite ways and "auto" pairs them."""
    names = [e["name"] for e in side]  # bottom-up, with {s}
    out = []
    for s in ("left", "right"):
        f = [n.replace("{s}", s) for n in (names if s == "left" else names[::-1])]
        k = [n.replace("{s}", s) for n in (names if s == "right" else names[::-1])]
        out.append(_seam([(front, n) for n in f], [(back, n) for n in k], f"side seam {s}"))
    return out


def _torso_placement(side: str, anchor, landmark: str, clearance: float) -> dict:
    return {
        "body": "torso",
        "side": side,
        "anchor": [round(float(anchor[0]), 4), round(float(anchor[1]), 4)],
        "landmark": landmark,
        "wrap": True,
        "clearance": clearance,
    }


def _hem_level(hem: dict, b: BodyDims) -> float:
    """Centre-back hem height [cm] (negative = below the waist)."""
    refs = {"waist": 0.0, "hip": -b.waist_to_hip, "knee": -b.waist_to_knee}
    level = hem.get("level", "hip")
    if level not in refs:
        raise SandboxError(f"hem level {level!r}: use one of {', '.join(refs)}")
    return refs[level] - float(hem.get("offset_cm", 0.0))


# --------------------------------------------------------------------------------------
# Side seams and hems (shared by tops, dresses and skirts)


def _quarter(girth: float, ease, shift: float) -> float | None:
    return None if ease is None else (girth + float(ease)) / 4.0 + shift


def _side_and_hem(
    levels: list[tuple[str, float, float]],
    b: BodyDims,
    hem: dict,
    *,
    front: bool,
    shift: float = 0.0,
    curve_hip: bool = True,
) -> tuple[list[dict], list[dict] | dict, dict]:
    """The right-half side seam (bottom-up) and the hem of a torso panel.

    ``levels``: (name, y, half width) from the top of the side seam down, at the levels the
    garment defines (the top one always, "waist" y = 0 and "hip" y = -waist_to_hip where
    the ease is given). Returns (side edges from the hem corner up to the top, the bottom
    edge(s) for :func:`symmetric_outline`, info with the hem corner and centre heights).
    """
    y_hem = _hem_level(hem, b)
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
            ctrl = P(xh, HIP_CURVE_CONTROL * yh)
            if y_c >= yh - 1e-6 and y_c < 0:  # hem inside the hip curve: split it
                # y(t) = yh (1-t)^2 + 2 t (1-t) c_y on the curve from the hip (t=0) to the waist
                cy = ctrl[1]
                a, bq, cq = yh - 2 * cy, 2 * cy - 2 * yh, yh - y_c
                disc = max(bq * bq - 4 * a * cq, 0.0)
                roots = (
                    [(-bq + sg * math.sqrt(disc)) / (2 * a) for sg in (1, -1)]
                    if abs(a) > 1e-12
                    else [-cq / bq]
                )
                t = min((r for r in roots if -1e-9 <= r <= 1 + 1e-9), key=lambda r: abs(r - 0.5))
                _, (m, c1, p1) = split_quadratic(P(xh, yh), ctrl, upper, t)
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


@dataclasses.dataclass
class _Frame:
    """The bodice frame of one body [cm]: neck, shoulder and armhole construction points."""

    d: np.ndarray  # unit shoulder direction, side neck point -> shoulder point
    down: np.ndarray  # unit direction perpendicular to the shoulder, downwards
    snp: np.ndarray  # side neck point on the pattern (neck ease included)
    sp: np.ndarray  # shoulder point (shoulder ease included)
    y_ua: float  # underarm line (armhole base)
    y_fnp: float  # the body's front neck point on the front panel
    y_bnp: float  # the body's back neck point (nape) on the back panel
    alpha: float  # shoulder slope [rad]

    def y_shoulder(self, x: float) -> float:
        """Height of the shoulder line at x."""
        return float(self.snp[1] - (x - self.snp[0]) * math.tan(self.alpha))


def _frame(p: dict, b: BodyDims, armhole_drop: float) -> _Frame:
    a = math.radians(b.shoulder_slope_deg)
    d = np.array([math.cos(a), -math.sin(a)])
    snp = P(b.neck_half_width + NECK_EASE_CM, b.back_length + b.neck_rise)
    ls = b.shoulder_length + float(p.get("shoulder", {}).get("ease_cm", 0.5))
    return _Frame(
        d=d,
        down=np.array([-math.sin(a), -math.cos(a)]),
        snp=snp,
        sp=snp + ls * d,
        y_ua=b.back_length - b.armscye_depth - armhole_drop,
        y_fnp=float(snp[1] - b.front_neck_depth),
        y_bnp=b.back_length,
        alpha=a,
    )


def _armhole(name: str, u, sp, x_width: float, fr: _Frame) -> dict:
    """Armhole from the underarm u up to the shoulder point sp: a cubic leaving u
    horizontally and meeting the shoulder line square, scooped in to x_width at most."""
    u, sp = np.asarray(u, float), np.asarray(sp, float)
    k2 = 0.45 * (sp[1] - u[1])
    c2 = sp - k2 * np.array([math.sin(fr.alpha), math.cos(fr.alpha)])
    span = max(u[0] - x_width, 0.5)

    t = np.linspace(0.0, 1.0, 65)

    def min_x(f: float) -> float:
        nodes = np.array([u, u + P(-f * span, 0), c2, sp])
        return float(bezier_point(nodes, t)[:, 0].min())

    lo, hi = 0.3, 2.0
    if min_x(lo) <= x_width:
        f = lo
    elif min_x(hi) >= x_width:
        f = hi
    else:
        for _ in range(30):
            f = 0.5 * (lo + hi)
            if min_x(f) > x_width:
                lo = f
            else:
                hi = f
        f = 0.5 * (lo + hi)
    return cubic(name, u, u + P(-f * span, 0), c2, sp)


def _neckline(shape: str, start, y_centre: float, fr: _Frame) -> list[dict]:
    """Half neckline from a point on the shoulder line to the centre line (x = 0)."""
    start = np.asarray(start, float)
    end = P(0, y_centre)
    if shape == "v":
        return [line("neckline_{s}", start, end)]
    if shape != "round":
        raise SandboxError(f"neckline shape {shape!r}: use 'round' or 'v'")
    a = 0.55 * max(start[1] - y_centre, 0.5)
    return [cubic("neckline_{s}", start, start + a * fr.down, P(0.55 * start[0], y_centre), end)]


def _levels(p: dict, b: BodyDims, y_top: float, shift: float) -> list[tuple[str, float, float]]:
    """Side seam levels (name, y, half width) of a torso panel; None eases are skipped
    (the side seam runs straight past them)."""
    ease = p["ease_cm"]
    out = [("bust", y_top, _quarter(b.bust, ease["bust"], shift))]
    if ease.get("waist") is not None:
        out.append(("waist", 0.0, _quarter(b.waist, ease["waist"], shift)))
    if ease.get("hip") is not None:
        out.append(("hip", -b.waist_to_hip, _quarter(b.hip, ease["hip"], shift)))
    return out


def _measured(panels: dict) -> tuple[str, ...]:
    """The girths every torso panel can be measured at (levels inside the garment)."""
    keys = ("bust", "waist", "hip")
    for pn in ("front", "back"):
        lv = panels[pn].get("meta", {}).get("girth_levels", {})
        keys = tuple(k for k in keys if k in lv)
    return keys


def _girths(p: dict, b: BodyDims, keys=("bust", "waist", "hip")) -> dict[str, dict]:
    out = {}
    for k in keys:
        e = p["ease_cm"].get(k)
        if e is not None:
            body = getattr(b, k)
            out[k] = {"body": round(body, 3), "ease": e, "garment": round(body + e, 3)}
    return out


def _levels_meta(levels, y_top: float, y_corner: float) -> dict:
    """Panel meta: the heights where the girths are read (levels at least 1 cm above the
    hem corner; the bust just below the underarm corner)."""
    meta = {}
    for name, y, _ in levels:
        if y > y_corner + 1.0:
            meta[name] = round(y - BUST_LEVEL_BELOW_UNDERARM if y == y_top else y, 4)
    return {"girth_levels": meta}


def _placements(fr: _Frame, p: dict) -> tuple[dict, dict]:
    c = float(p.get("clearance_cm", 2.0))
    return (
        _torso_placement("front", (0, fr.y_fnp), "front_neck_point", c),
        _torso_placement("back", (0, fr.y_bnp), "back_neck_point", c),
    )


def bodice(p: dict, b: BodyDims) -> Draft:
    """Tops and dresses: front and back bodice (to any length), set-in sleeves if
    ``params["sleeve"]``. Parameters: see docs/garments.md."""
    fr = _frame(p, b, float(p.get("armhole_drop_cm", 1.0)))
    sh = p.get("shoulder", {})
    neck = p.get("neckline", {})
    widen = float(neck.get("widen_cm", 0.0))
    snp2 = fr.snp + widen * fr.d
    if sh.get("strap_width_cm") is not None:
        sp2 = snp2 + float(sh["strap_width_cm"]) * fr.d
    else:
        sp2 = fr.sp - float(sh.get("trim_cm", 0.0)) * fr.d
    if (sp2 - snp2) @ fr.d < 1.0:
        raise SandboxError("the shoulder is shorter than 1 cm (neck widening + trim too large)")
    shift = float(p.get("side_shift_cm", 0.5))
    shape = neck.get("shape", "round")
    panels, arm = {}, {}
    pl_front, pl_back = _placements(fr, p)
    for part, sgn, pos, neg in (("front", 1, "left", "right"), ("back", -1, "right", "left")):
        levels = _levels(p, b, fr.y_ua, sgn * shift)
        side, bottom, info = _side_and_hem(
            levels, b, p["hem"], front=part == "front", shift=sgn * shift
        )
        u = P(levels[0][2], fr.y_ua)
        if part == "front":
            x_w = b.chest / 2 + 0.5
            y_n = fr.y_fnp - float(neck.get("front_depth_cm", 0.0))
        else:
            x_w = b.back_width / 2 + 0.5
            y_n = fr.y_bnp - float(neck.get("back_depth_cm", 0.0))
        x_w = min(x_w, sp2[0] - 0.5, u[0] - 1.0)
        ah = _armhole("armhole_{s}", u, sp2, x_w, fr)
        arm[part] = length(ah)
        half = side + [ah, line("shoulder_{s}", sp2, snp2)]
        top = _neckline(shape, snp2, y_n, fr)
        edges = symmetric_outline(half, bottom=bottom, top=top, pos=pos, neg=neg)
        panels[part] = panel_dict(
            edges,
            placement=pl_front if part == "front" else pl_back,
            meta=_levels_meta(levels, fr.y_ua, info["corner"][1]),
        )
    seams = _side_seams(side)
    for s in ("left", "right"):
        seams.append(_seam([("front", f"shoulder_{s}")], [("back", f"shoulder_{s}")],
                           f"shoulder {s}"))  # fmt: skip
    draft = Draft(panels, seams, _girths(p, b, _measured(panels)))
    if p.get("sleeve"):
        _add_sleeves(draft, p["sleeve"], b, arm["front"], arm["back"], sp2[1] - fr.y_ua)
    return draft


# --------------------------------------------------------------------------------------
# Sleeves


def _cap(name: str, w: float, h: float) -> dict:
    """Front sleeve cap of the right sleeve: S-curve from the underarm (w, 0) to the top
    (0, h), hollow near the underarm, full over the crown, level at the top."""
    return cubic(name, P(w, 0), P(0.55 * w, 0.12 * h), P(0.45 * w, h), P(0, h))


_GL_X, _GL_W = np.polynomial.legendre.leggauss(48)
_GL_T = 0.5 * (_GL_X + 1.0)
# The cap curve is (w a(t), h b(t)) with fixed a, b (see _cap): its speed is
# sqrt(w^2 a'^2 + h^2 b'^2), so the length needs a' and b' at the nodes once.
_CAP_A = np.array([1.0, 0.55, 0.45, 0.0])
_CAP_B = np.array([0.0, 0.12, 1.0, 1.0])


def _derivative_at_nodes(c: np.ndarray) -> np.ndarray:
    t = _GL_T
    return 3 * (
        (1 - t) ** 2 * (c[1] - c[0]) + 2 * t * (1 - t) * (c[2] - c[1]) + t**2 * (c[3] - c[2])
    )


_CAP_DA2 = _derivative_at_nodes(_CAP_A) ** 2
_CAP_DB2 = _derivative_at_nodes(_CAP_B) ** 2


def _cap_length(w: float, h: float) -> float:
    """Arc length [cm] of :func:`_cap` (48-point Gauss-Legendre on the smooth cubic)."""
    return float(0.5 * np.sum(_GL_W * np.sqrt(w * w * _CAP_DA2 + h * h * _CAP_DB2)))


def _solve_width(target: float, h: float) -> float:
    """Half width w of the cap whose curve is ``target`` long at cap height h (Newton on
    the convex, increasing L(w); w = 0.5 cm if even a narrow cap is too long)."""
    w = max(target, 1.0)
    for _ in range(40):
        q = np.sqrt(w * w * _CAP_DA2 + h * h * _CAP_DB2)
        f = 0.5 * float(np.sum(_GL_W * q)) - target
        df = 0.5 * float(np.sum(_GL_W * w * _CAP_DA2 / q))
        step = f / max(df, 1e-9)
        w = max(w - step, 0.5 * w, 0.5)
        if abs(step) < 1e-7:
            break
    return w


def _arm_girth(b: BodyDims, from_shoulder: float, cap: float) -> float:
    """Arm girth [cm] at a distance from the shoulder point (biceps -> wrist, linear)."""
    t = (from_shoulder - cap) / max(b.sleeve_length - cap, 1.0)
    t = min(max(t, 0.0), 1.0)
    return b.top_arm + (b.wrist - b.top_arm) * t


def _sleeve_panels(right: list[dict], h_anchor: float) -> dict[str, dict]:
    """Right sleeve (x to the front) and its mirror image, the left sleeve (x to the back)."""
    left = [transform(e, mirror_x, reverse=True) for e in right[::-1]]
    left = left[-1:] + left[:-1]  # start with the hem
    out = {}
    for s, es in (("left", left), ("right", right)):
        out[f"sleeve_{s}"] = panel_dict(
            es,
            placement={
                "body": f"arm_{s}",
                "side": "outer",
                "anchor": [0.0, round(h_anchor, 4)],
                "landmark": f"shoulder_point_{s}",
                "wrap": True,
                "clearance": 1.5,
            },
        )
    return out


def _add_sleeves(draft: Draft, sp: dict, b: BodyDims, arm_f: float, arm_b: float, depth: float):
    """Set-in sleeves: cap lengths = armhole lengths x (1 + cap ease), front and back apart,
    so the cap top meets the shoulder seam. The cap height is solved so that the biceps
    is top arm + ``bicep_ease_cm`` (within 25-95 % of the armhole depth), or given as
    ``cap_height_ratio`` x armhole depth."""
    ease = float(sp.get("cap_ease", 0.03))
    cap_f, cap_b = arm_f * (1 + ease), arm_b * (1 + ease)

    def widths(h: float) -> tuple[float, float]:
        return _solve_width(cap_f, h), _solve_width(cap_b, h)

    if sp.get("bicep_ease_cm") is not None:
        # cap height from the biceps: the higher the cap, the narrower the sleeve
        want = b.top_arm + float(sp["bicep_ease_cm"])
        lo, hi = 0.25 * depth, 0.95 * depth
        for _ in range(30):
            h = 0.5 * (lo + hi)
            if sum(widths(h)) > want:
                lo = h
            else:
                hi = h
        h = 0.5 * (lo + hi)
    else:
        h = float(sp.get("cap_height_ratio", 0.6)) * depth
    wf, wb = widths(h)
    total = float(sp.get("length_ratio", 1.0)) * b.sleeve_length
    lu = max(total - h, 2.0)
    hem_w = _arm_girth(b, total, h) + float(sp.get("hem_ease_cm", 5.0))
    hem_w = max(hem_w, abs(wb - wf) + 2.0)
    t = (wf + wb - hem_w) / 2
    hf, hb = wf - t, wb - t
    cf = _cap("cap_front", wf, h)
    cb = transform(_cap("cap_back", wb, h), mirror_x, reverse=True)
    right = [
        line("hem", P(-hb, -lu), P(hf, -lu)),
        line("underseam_front", P(hf, -lu), P(wf, 0)),
        cf,
        cb,
        line("underseam_back", P(-wb, 0), P(-hb, -lu)),
    ]
    draft.panels.update(_sleeve_panels(right, h))
    draft.seams += [
        _seam([("sleeve_right", "cap_front"), ("sleeve_right", "cap_back")],
              [("back", "armhole_right"), ("front", "armhole_right")], "sleeve right"),
        _seam([("sleeve_left", "cap_back"), ("sleeve_left", "cap_front")],
              [("front", "armhole_left"), ("back", "armhole_left")], "sleeve left"),
    ]  # fmt: skip
    for s in ("left", "right"):
        draft.seams.append(_seam([(f"sleeve_{s}", "underseam_front")],
                                 [(f"sleeve_{s}", "underseam_back")], f"underarm {s}"))  # fmt: skip
    draft.girths["biceps"] = {
        "body": round(b.top_arm, 3),
        "ease": round(wf + wb - b.top_arm, 3),
        "garment": round(wf + wb, 3),
    }


# --------------------------------------------------------------------------------------
# Raglan


def raglan(p: dict, b: BodyDims) -> Draft:
    """Raglan top: front and back with raglan lines from the neck to the underarm, and
    one-piece raglan sleeves whose raglan edges are the bodice's raglan curves moved
    rigidly (identical lengths)."""
    fr = _frame(p, b, float(p.get("armhole_drop_cm", 2.0)))
    neck = p.get("neckline", {})
    rg = p.get("raglan", {})
    shift = float(p.get("side_shift_cm", 0.5))
    panels, rag = {}, {}
    pl_front, pl_back = _placements(fr, p)
    for part, sgn, pos, neg in (("front", 1, "left", "right"), ("back", -1, "right", "left")):
        levels = _levels(p, b, fr.y_ua, sgn * shift)
        side, bottom, info = _side_and_hem(
            levels, b, p["hem"], front=part == "front", shift=sgn * shift
        )
        u = P(levels[0][2], fr.y_ua)
        if part == "front":
            nr = fr.snp + P(-float(rg.get("front_neck_in_cm", 2.5)), -2.0)
            x_w = b.chest / 2 + 0.5
            y_n = fr.y_fnp - float(neck.get("front_depth_cm", 1.0))
        else:
            nr = fr.snp + P(-float(rg.get("back_neck_in_cm", 2.0)), -1.0)
            x_w = b.back_width / 2 + 0.5
            y_n = fr.y_bnp - float(neck.get("back_depth_cm", 0.5))
        w_pt = P(min(x_w, u[0] - 1.0), fr.y_ua + WIDTH_LEVEL * (fr.sp[1] - fr.y_ua))
        c1 = u + P(-0.45 * (u[0] - w_pt[0]), 0)
        c2 = nr + 0.45 * (w_pt - nr)
        rl = cubic("raglan_{s}", u, c1, c2, nr)
        rag[part] = rl
        half = side + [rl]
        top = _neckline(neck.get("shape", "round"), nr, y_n, fr)
        edges = symmetric_outline(half, bottom=bottom, top=top, pos=pos, neg=neg)
        panels[part] = panel_dict(
            edges,
            placement=pl_front if part == "front" else pl_back,
            meta=_levels_meta(levels, fr.y_ua, info["corner"][1]),
        )
    seams = _side_seams(side)
    # sleeve (right arm, x to the front): underarm corners (+-w, 0), neck corners on top
    sl = p.get("sleeve", {})
    bic = b.top_arm + float(sl.get("bicep_ease_cm", 6.0))
    wf = wb = bic / 2
    t_top = float(sl.get("top_half_width_cm", 3.0))
    edges_top = []
    corners = {}
    for part, w in (("front", wf), ("back", wb)):
        e = rag[part]
        chord = float(np.linalg.norm(e["p1"] - e["p0"]))
        h = math.sqrt(max(chord**2 - (w - t_top) ** 2, 1.0))
        corners[part] = h
        edges_top.append((e, w, h))
    (ef, _, hf_), (eb, _, hb_) = edges_top
    s_f, t_f = P(wf, 0), P(t_top, hf_)
    front_edge = transform(ef, rigid(ef["p0"], ef["p1"], s_f, t_f), name="raglan_front")
    # back: mirror the bodice curve (interior on the left after mirroring + reversing)
    mb = transform(eb, mirror_x, reverse=True)  # from mirror(N_r) to mirror(U)
    s_b, t_b = P(-wb, 0), P(-t_top, hb_)
    back_edge = transform(mb, rigid(mb["p0"], mb["p1"], t_b, s_b), name="raglan_back")
    front_edge["p0"], front_edge["p1"] = s_f, t_f  # exact corners
    back_edge["p0"], back_edge["p1"] = t_b, s_b
    # shoulder point on the sleeve's centre line: the shoulder length past the raglan neck
    # point, measured down from the top
    top_mid = 0.5 * (hf_ + hb_)
    shoulder_down = max(b.shoulder_length + 0.5 - float(rg.get("front_neck_in_cm", 2.5)), 3.0)
    y_sp = top_mid - shoulder_down
    total = float(sl.get("length_ratio", 1.0)) * b.sleeve_length
    lu = max(total - y_sp, 2.0)
    hem_w = _arm_girth(b, total, y_sp) + float(sl.get("hem_ease_cm", 5.0))
    t = (wf + wb - hem_w) / 2
    h_f, h_b = wf - t, wb - t
    right = [
        line("hem", P(-h_b, -lu), P(h_f, -lu)),
        line("underseam_front", P(h_f, -lu), s_f),
        front_edge,
        line("neckline", t_f, t_b),
        back_edge,
        line("underseam_back", s_b, P(-h_b, -lu)),
    ]
    panels.update(_sleeve_panels(right, y_sp))
    for s in ("left", "right"):
        seams += [
            _seam([(f"sleeve_{s}", "raglan_front")], [("front", f"raglan_{s}")],
                  f"raglan front {s}"),
            _seam([(f"sleeve_{s}", "raglan_back")], [("back", f"raglan_{s}")],
                  f"raglan back {s}"),
            _seam([(f"sleeve_{s}", "underseam_front")], [(f"sleeve_{s}", "underseam_back")],
                  f"underarm {s}"),
        ]  # fmt: skip
    g = _girths(p, b, _measured(panels))
    g["biceps"] = {"body": round(b.top_arm, 3), "ease": round(bic - b.top_arm, 3),
                   "garment": round(bic, 3)}  # fmt: skip
    return Draft(panels, seams, g)


# --------------------------------------------------------------------------------------
# Camisole and halter top


def camisole(p: dict, b: BodyDims) -> Draft:
    """Camisole: straight top edges above the bust (front) and at the underarm line (back),
    narrow straps cut on to both panels and joined on the shoulder line."""
    fr = _frame(p, b, float(p.get("armhole_drop_cm", 1.0)))
    st = p.get("strap", {})
    sw = float(st.get("width_cm", 2.0))
    xc = fr.snp[0] + float(st.get("from_neck_cm", 4.0))
    xo, xi = xc + sw / 2, xc - sw / 2
    top = p.get("top_edge", {})
    shift = float(p.get("side_shift_cm", 0.5))
    panels = {}
    pl_front, pl_back = _placements(fr, p)
    for part, sgn, pos, neg in (("front", 1, "left", "right"), ("back", -1, "right", "left")):
        levels = _levels(p, b, fr.y_ua, sgn * shift)
        side, bottom, info = _side_and_hem(
            levels, b, p["hem"], front=part == "front", shift=sgn * shift
        )
        u = P(levels[0][2], fr.y_ua)
        y_e = fr.y_ua + float(top.get(f"{part}_above_underarm_cm", 0.0))
        end = P(xo, y_e)
        if y_e - fr.y_ua < 0.5:
            ah = line("armhole_{s}", u, end)
        else:
            ah = cubic("armhole_{s}", u, u + P(-0.55 * (u[0] - xo), 0),
                       end + P(0, -0.6 * (y_e - fr.y_ua)), end)  # fmt: skip
        so, si = P(xo, fr.y_shoulder(xo)), P(xi, fr.y_shoulder(xi))
        half = side + [
            ah,
            line("strap_{s}_outer", end, so),
            line("strap_{s}", so, si),
            line("strap_{s}_inner", si, P(xi, y_e)),
        ]
        dip = float(top.get(f"{part}_dip_cm", 0.0))
        # the top edge runs from +x to -x: a dip (downwards) is to the left: sagitta > 0
        topedge = arc("neckline", P(xi, y_e), P(-xi, y_e), dip)
        edges = symmetric_outline(half, bottom=bottom, top=topedge, pos=pos, neg=neg)
        panels[part] = panel_dict(
            edges,
            placement=pl_front if part == "front" else pl_back,
            meta=_levels_meta(levels, fr.y_ua, info["corner"][1]),
        )
    seams = _side_seams(side)
    for s in ("left", "right"):
        seams.append(_seam([("front", f"strap_{s}")], [("back", f"strap_{s}")], f"strap {s}"))
    return Draft(panels, seams, _girths(p, b, _measured(panels)))


def halter(p: dict, b: BodyDims) -> Draft:
    """Halter top: the front rises to two straps at the neck, joined behind the neck by a
    neckband; the back is cut straight across below the shoulder blades."""
    fr = _frame(p, b, float(p.get("armhole_drop_cm", 1.0)))
    st = p.get("strap", {})
    sw = float(st.get("width_cm", 3.5))
    xi = fr.snp[0] - float(st.get("inside_neck_cm", 1.0))
    xo = xi + sw
    y_t = fr.snp[1] - 1.5
    neck = p.get("neckline", {})
    shift = float(p.get("side_shift_cm", 0.5))
    panels = {}
    pl_front, pl_back = _placements(fr, p)
    y_back = fr.y_ua - float(p.get("back_top_below_underarm_cm", 0.0))
    for part, sgn, pos, neg in (("front", 1, "left", "right"), ("back", -1, "right", "left")):
        levels = _levels(p, b, min(fr.y_ua, y_back), sgn * shift)
        side, bottom, info = _side_and_hem(
            levels, b, p["hem"], front=part == "front", shift=sgn * shift
        )
        u = P(levels[0][2], levels[0][1])
        if part == "front":
            end = P(xo, y_t)
            ah = cubic("armhole_{s}", u, u + P(-0.6 * (u[0] - xo), 0),
                       end + P(0.1 * (u[0] - xo), -0.45 * (y_t - u[1])), end)  # fmt: skip
            half = side + [ah, line("strap_{s}", end, P(xi, y_t))]
            y_n = fr.y_fnp - float(neck.get("front_depth_cm", 8.0))
            top = [line("neckline_{s}", P(xi, y_t), P(0, y_n))]
            edges = symmetric_outline(half, bottom=bottom, top=top, pos=pos, neg=neg)
        else:
            topedge = line("top", u, P(-u[0], u[1]))
            edges = symmetric_outline(side, bottom=bottom, top=topedge, pos=pos, neg=neg)
            # the low back does not reach the nape: place it by the waist
            pl_back = _torso_placement("back", (0, 0), "waist_back", pl_back["clearance"])
        panels[part] = panel_dict(
            edges,
            placement=pl_front if part == "front" else pl_back,
            meta=_levels_meta(levels, levels[0][1], info["corner"][1]),
        )
    # neckband behind the neck (seen from behind: x to the body's right)
    lb = b.shoulder_width - 2 * b.shoulder_length + 2 * float(st.get("band_extra_cm", 4.0))
    band = [
        line("lower", P(-lb / 2, -sw / 2), P(lb / 2, -sw / 2)),
        line("end_right", P(lb / 2, -sw / 2), P(lb / 2, sw / 2)),
        line("upper", P(lb / 2, sw / 2), P(-lb / 2, sw / 2)),
        line("end_left", P(-lb / 2, sw / 2), P(-lb / 2, -sw / 2)),
    ]
    panels["neckband"] = panel_dict(
        band,
        placement=_torso_placement("back", (0, 0), "back_neck_point",
                                   float(p.get("clearance_cm", 2.0))),
    )  # fmt: skip
    seams = _side_seams(side)
    for s in ("left", "right"):
        seams.append(_seam([("front", f"strap_{s}")], [("neckband", f"end_{s}")], f"strap {s}"))
    return Draft(panels, seams, _girths(p, b, _measured(panels)))


# --------------------------------------------------------------------------------------
# Skirts


def skirt(p: dict, b: BodyDims) -> Draft:
    """Straight / pencil / A-line skirt: front and back, one waist dart per half panel
    (V notch, legs sewn), hip curve, straight or flared below the hip."""
    ease = p["ease_cm"]
    shift = float(p.get("side_shift_cm", 0.0))
    darts = p.get("darts", {})
    share = float(darts.get("share", 0.5))
    panels = {}
    c = float(p.get("clearance_cm", 2.0))
    for part, sgn, pos, neg in (("front", 1, "left", "right"), ("back", -1, "right", "left")):
        q_w = _quarter(b.waist, ease["waist"], sgn * shift)
        q_h = _quarter(b.hip, ease["hip"], sgn * shift)
        d = min(max(share * (q_h - q_w), 0.0), float(darts.get("max_intake_cm", 4.0)))
        x_w = q_w + d
        levels = [("waist", 0.0, x_w), ("hip", -b.waist_to_hip, q_h)]
        side, bottom, info = _side_and_hem(
            levels, b, p["hem"], front=part == "front", shift=sgn * shift
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
            placement=_torso_placement(part, (0, 0), landmark, c),
            meta={"girth_levels": {"waist": -0.01, "hip": round(-b.waist_to_hip, 4)}},
        )
    seams = _side_seams(side)
    for part in ("front", "back"):
        names = [e["name"] for e in panel_edges(panels[part])]
        for s in ("left", "right"):
            if f"dart_{s}_a" in names:
                seams.append(_seam([(part, f"dart_{s}_a")], [(part, f"dart_{s}_b")],
                                   f"{part} dart {s}"))  # fmt: skip
    return Draft(panels, seams, _girths(p, b, ("waist", "hip")))


def panel_edges(panel: dict) -> list[dict]:
    return panel["edges"]


def circle_skirt(p: dict, b: BodyDims) -> Draft:
    """Circle skirt in four gores (front, left, back, right), each on the straight grain at
    its centre. ``fullness`` is the fraction of a full circle the four gores make (1: a full
    circle, 0.5: a half circle, the default 1); waist radius = (waist + ease) / (2 pi
    fullness), so each gore is a sector of fullness x 90 degrees."""
    e_w = float(p["ease_cm"]["waist"])
    full = float(p.get("fullness", 1.0))
    if not 0.1 <= full <= 1.0:
        raise SandboxError(f"fullness {full}: must be between 0.1 and 1 (a full circle)")
    r = (b.waist + e_w) / (2 * math.pi * full)
    hem = p["hem"]
    ln = -_hem_level(hem, b)
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
            es, placement=_torso_placement(side, (0, 0), landmark, c),
            meta={"girth_edges": {"waist": ["waist"]}},
        )  # fmt: skip
    seams = []
    for a, bb in (("front", "left"), ("left", "back"), ("back", "right"), ("right", "front")):
        seams.append(_seam([(a, f"to_{bb}")], [(bb, f"to_{a}")], f"{a}-{bb}"))
    g = _girths(p, b, ("waist",))
    return Draft(panels, seams, g)


BLOCKS = {
    "bodice": bodice,
    "raglan": raglan,
    "camisole": camisole,
    "halter": halter,
    "skirt": skirt,
    "circle_skirt": circle_skirt,
}
