"""Tops and dresses: the bodice (with set-in sleeves), raglan, camisole and halter blocks
(:mod:`sandbox.drafting.blocks`). All lengths in cm."""

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
    rigid,
    symmetric_outline,
    transform,
)
from sandbox.drafting.sleeves import add_sleeves, arm_girth, sleeve_panels
from sandbox.drafting.torso import (
    DEFAULT_RULES,
    Draft,
    DraftRules,
    girths,
    levels_meta,
    measured_girths,
    seam,
    side_and_hem,
    side_levels,
    side_seams,
    torso_placement,
)
from sandbox.errors import SandboxError
from sandbox.pattern.curves import bezier_point

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


def _frame(p: dict, b: BodyDims, armhole_drop: float, rules: DraftRules) -> _Frame:
    """The construction points of one body, the armhole ``armhole_drop`` [cm] below the
    body's armscye depth."""
    a = math.radians(b.shoulder_slope_deg)
    d = np.array([math.cos(a), -math.sin(a)])
    snp = P(b.neck_half_width + rules.neck_ease_cm, b.back_length + b.neck_rise)
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


def _placements(fr: _Frame, p: dict) -> tuple[dict, dict]:
    c = float(p.get("clearance_cm", 2.0))
    return (
        torso_placement("front", (0, fr.y_fnp), "front_neck_point", c),
        torso_placement("back", (0, fr.y_bnp), "back_neck_point", c),
    )


def bodice(p: dict, b: BodyDims, rules: DraftRules = DEFAULT_RULES) -> Draft:
    """Tops and dresses: front and back bodice (to any length), set-in sleeves if
    ``params["sleeve"]``. Parameters: see docs/garments.md."""
    fr = _frame(p, b, float(p.get("armhole_drop_cm", 1.0)), rules)
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
        levels = side_levels(p, b, fr.y_ua, sgn * shift)
        side, bottom, info = side_and_hem(
            levels, b, p["hem"], front=part == "front", shift=sgn * shift, rules=rules
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
            meta=levels_meta(levels, fr.y_ua, info["corner"][1]),
        )
    seams = side_seams(side)
    for s in ("left", "right"):
        seams.append(seam([("front", f"shoulder_{s}")], [("back", f"shoulder_{s}")],
                           f"shoulder {s}"))  # fmt: skip
    draft = Draft(panels, seams, girths(p, b, measured_girths(panels)))
    if p.get("sleeve"):
        add_sleeves(draft, p["sleeve"], b, arm["front"], arm["back"], sp2[1] - fr.y_ua)
    return draft


# --------------------------------------------------------------------------------------
# Raglan


def raglan(p: dict, b: BodyDims, rules: DraftRules = DEFAULT_RULES) -> Draft:
    """Raglan top: front and back with raglan lines from the neck to the underarm, and
    one-piece raglan sleeves whose raglan edges are the bodice's raglan curves moved
    rigidly (identical lengths)."""
    fr = _frame(p, b, float(p.get("armhole_drop_cm", 2.0)), rules)
    neck = p.get("neckline", {})
    rg = p.get("raglan", {})
    shift = float(p.get("side_shift_cm", 0.5))
    panels, rag = {}, {}
    pl_front, pl_back = _placements(fr, p)
    for part, sgn, pos, neg in (("front", 1, "left", "right"), ("back", -1, "right", "left")):
        levels = side_levels(p, b, fr.y_ua, sgn * shift)
        side, bottom, info = side_and_hem(
            levels, b, p["hem"], front=part == "front", shift=sgn * shift, rules=rules
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
        w_pt = P(min(x_w, u[0] - 1.0), fr.y_ua + rules.width_level * (fr.sp[1] - fr.y_ua))
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
            meta=levels_meta(levels, fr.y_ua, info["corner"][1]),
        )
    seams = side_seams(side)
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
    hem_w = arm_girth(b, total, y_sp) + float(sl.get("hem_ease_cm", 5.0))
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
    panels.update(sleeve_panels(right, y_sp))
    for s in ("left", "right"):
        seams += [
            seam([(f"sleeve_{s}", "raglan_front")], [("front", f"raglan_{s}")],
                  f"raglan front {s}"),
            seam([(f"sleeve_{s}", "raglan_back")], [("back", f"raglan_{s}")],
                  f"raglan back {s}"),
            seam([(f"sleeve_{s}", "underseam_front")], [(f"sleeve_{s}", "underseam_back")],
                  f"underarm {s}"),
        ]  # fmt: skip
    g = girths(p, b, measured_girths(panels))
    g["biceps"] = {"body": round(b.top_arm, 3), "ease": round(bic - b.top_arm, 3),
                   "garment": round(bic, 3)}  # fmt: skip
    return Draft(panels, seams, g)


# --------------------------------------------------------------------------------------
# Camisole and halter top


def camisole(p: dict, b: BodyDims, rules: DraftRules = DEFAULT_RULES) -> Draft:
    """Camisole: straight top edges above the bust (front) and at the underarm line (back),
    narrow straps cut on to both panels and joined on the shoulder line."""
    fr = _frame(p, b, float(p.get("armhole_drop_cm", 1.0)), rules)
    st = p.get("strap", {})
    sw = float(st.get("width_cm", 2.0))
    xc = fr.snp[0] + float(st.get("from_neck_cm", 4.0))
    xo, xi = xc + sw / 2, xc - sw / 2
    top = p.get("top_edge", {})
    shift = float(p.get("side_shift_cm", 0.5))
    panels = {}
    pl_front, pl_back = _placements(fr, p)
    for part, sgn, pos, neg in (("front", 1, "left", "right"), ("back", -1, "right", "left")):
        levels = side_levels(p, b, fr.y_ua, sgn * shift)
        side, bottom, info = side_and_hem(
            levels, b, p["hem"], front=part == "front", shift=sgn * shift, rules=rules
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
            meta=levels_meta(levels, fr.y_ua, info["corner"][1]),
        )
    seams = side_seams(side)
    for s in ("left", "right"):
        seams.append(seam([("front", f"strap_{s}")], [("back", f"strap_{s}")], f"strap {s}"))
    return Draft(panels, seams, girths(p, b, measured_girths(panels)))


def halter(p: dict, b: BodyDims, rules: DraftRules = DEFAULT_RULES) -> Draft:
    """Halter top: the front rises to two straps at the neck, joined behind the neck by a
    neckband; the back is cut straight across below the shoulder blades."""
    fr = _frame(p, b, float(p.get("armhole_drop_cm", 1.0)), rules)
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
        levels = side_levels(p, b, min(fr.y_ua, y_back), sgn * shift)
        side, bottom, info = side_and_hem(
            levels, b, p["hem"], front=part == "front", shift=sgn * shift, rules=rules
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
            pl_back = torso_placement("back", (0, 0), "waist_back", pl_back["clearance"])
        panels[part] = panel_dict(
            edges,
            placement=pl_front if part == "front" else pl_back,
            meta=levels_meta(levels, levels[0][1], info["corner"][1]),
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
        placement=torso_placement("back", (0, 0), "back_neck_point",
                                   float(p.get("clearance_cm", 2.0))),
    )  # fmt: skip
    seams = side_seams(side)
    for s in ("left", "right"):
        seams.append(seam([("front", f"strap_{s}")], [("neckband", f"end_{s}")], f"strap {s}"))
    return Draft(panels, seams, girths(p, b, measured_girths(panels)))
