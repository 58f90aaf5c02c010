"""Sleeves of the torso blocks: set-in sleeves whose caps fit the armholes, and the
panels and arm girths the raglan sleeve shares. All lengths in cm."""

from __future__ import annotations

import numpy as np

from sandbox.drafting.body import BodyDims
from sandbox.drafting.geometry import P, cubic, line, mirror_x, panel_dict, transform
from sandbox.drafting.torso import Draft, seam


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


def arm_girth(b: BodyDims, from_shoulder: float, cap: float) -> float:
    """Arm girth [cm] at a distance from the shoulder point (biceps -> wrist, linear)."""
    t = (from_shoulder - cap) / max(b.sleeve_length - cap, 1.0)
    t = min(max(t, 0.0), 1.0)
    return b.top_arm + (b.wrist - b.top_arm) * t


def sleeve_panels(right: list[dict], h_anchor: float) -> dict[str, dict]:
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


def add_sleeves(draft: Draft, sp: dict, b: BodyDims, arm_f: float, arm_b: float, depth: float):
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
    hem_w = arm_girth(b, total, h) + float(sp.get("hem_ease_cm", 5.0))
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
    draft.panels.update(sleeve_panels(right, h))
    draft.seams += [
        seam([("sleeve_right", "cap_front"), ("sleeve_right", "cap_back")],
              [("back", "armhole_right"), ("front", "armhole_right")], "sleeve right"),
        seam([("sleeve_left", "cap_back"), ("sleeve_left", "cap_front")],
              [("front", "armhole_left"), ("back", "armhole_left")], "sleeve left"),
    ]  # fmt: skip
    for s in ("left", "right"):
        draft.seams.append(seam([(f"sleeve_{s}", "underseam_front")],
                                 [(f"sleeve_{s}", "underseam_back")], f"underarm {s}"))  # fmt: skip
    draft.girths["biceps"] = {
        "body": round(b.top_arm, 3),
        "ease": round(wf + wb - b.top_arm, 3),
        "garment": round(wf + wb, 3),
    }
