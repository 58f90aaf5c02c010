"""Landmarks of an external body mesh, found from horizontal sections (best effort).

For a standing body, Y up, front +Z, arms away from the torso below the armpits:

* crotch: the lowest level whose section has a loop around the body axis;
* armpit: the first level above mid-torso where that loop suddenly widens (arms join);
* hip: largest girth in the 15% of height above the crotch; waist: smallest girth
  between hip and armpit; bust: largest girth between waist and armpit;
* neck base: the lowest level above the armpit whose section is at most 1.3 times the
  narrowest width above the armpit (neck or neck stub); side neck points are its
  lateral extremes, the back neck point its back-most point near x = 0;
* shoulder points: the up-and-out corners (largest |x| + y) between armpit and neck base;
* back armhole points: on the back of the section at half the armscye depth below the
  nape, at the torso's armpit half width.

These rules are for the tape measure on meshes that come without landmarks; they are
not as exact as the landmarks our own mannequin carries (see docs/mannequin.md).
"""

from __future__ import annotations

import numpy as np

from sandbox.errors import SandboxError
from sandbox.mannequin.tape import _hull, _inside, section_polylines


def _axis_loop(v, f, y, axis):
    best = None
    for pts, closed in section_polylines(v, f, (0.0, y, 0.0), (0.0, 1.0, 0.0)):
        if closed and len(pts) > 3 and _inside(pts[:, [0, 2]], axis):
            hull = _hull(pts[:, [0, 2]])
            if hull is not None and (best is None or hull.volume > best[1].volume):
                best = (pts, hull)
    return best


def detect_landmarks(vertices: np.ndarray, triangles: np.ndarray) -> dict[str, np.ndarray]:
    """Named landmarks (3,) [m] of a closed body mesh; :class:`SandboxError` if not found."""
    v = np.asarray(vertices, float)
    f = np.asarray(triangles, np.int64)
    y0, y1 = float(v[:, 1].min()), float(v[:, 1].max())
    height = y1 - y0
    band = v[(v[:, 1] > y0 + 0.5 * height) & (v[:, 1] < y0 + 0.6 * height)]
    if len(band) == 0:
        raise SandboxError("body mesh: no vertices at mid height")
    axis = np.array([np.median(band[:, 0]), np.median(band[:, 2])])
    ys = np.arange(y0 + 0.3 * height, y1 - 0.005, 0.005)
    girth = np.full(len(ys), np.nan)
    width = np.full(len(ys), np.nan)
    loops = {}
    for i, y in enumerate(ys):
        hit = _axis_loop(v, f, y, axis)
        if hit is not None:
            girth[i] = hit[1].area
            width[i] = np.ptp(hit[0][:, 0])
            loops[i] = hit[0]
    found = np.nonzero(~np.isnan(girth))[0]
    if len(found) < 20:
        raise SandboxError("body mesh: no closed torso sections around the body axis")
    i_crotch = int(found[0])
    mid = np.searchsorted(ys, y0 + 0.62 * height)
    i_armpit = None
    for i in range(max(mid, i_crotch + 1), len(ys) - 1):
        if np.isnan(width[i + 1]) or width[i + 1] > 1.25 * width[i]:
            i_armpit = i
            break
    if i_armpit is None:
        raise SandboxError("body mesh: cannot find the armpits (arms must hang free)")
    hip_hi = min(i_armpit, i_crotch + int(0.15 * height / 0.005))
    i_hip = i_crotch + int(np.nanargmax(girth[i_crotch:hip_hi]))
    i_waist = i_hip + 5 + int(np.nanargmin(girth[i_hip + 5 : i_armpit - 10]))
    i_bust = i_waist + 5 + int(np.nanargmax(girth[i_waist + 5 : i_armpit + 1]))
    above = [i for i in range(i_armpit + 1, len(ys)) if i in loops]
    if not above:
        raise SandboxError("body mesh: nothing above the armpits (no neck)")
    narrow = min(width[i] for i in above)
    i_neck = next(i for i in above if width[i] <= 1.3 * narrow)
    neck = loops[i_neck]
    lm: dict[str, np.ndarray] = {}
    lm["side_neck_point_left"] = neck[np.argmax(neck[:, 0])]
    lm["side_neck_point_right"] = neck[np.argmin(neck[:, 0])]
    near = neck[np.abs(neck[:, 0] - axis[0]) < 0.02]
    lm["back_neck_point"] = near[np.argmin(near[:, 2])]
    lm["front_neck_point"] = near[np.argmax(near[:, 2])]
    y_arm, y_neck = ys[i_armpit], ys[i_neck]
    box = v[(v[:, 1] > y_arm) & (v[:, 1] < y_neck)]
    lm["shoulder_point_left"] = box[np.argmax(box[:, 0] + box[:, 1])]
    lm["shoulder_point_right"] = box[np.argmax(-box[:, 0] + box[:, 1])]
    y_bw = 0.5 * (lm["back_neck_point"][1] + y_arm)
    sec = _axis_loop(v, f, y_bw, axis)
    arm_loop = loops[i_armpit]
    half = 0.5 * np.ptp(arm_loop[:, 0])
    if sec is None:
        raise SandboxError("body mesh: no section at the back-width level")
    pts = sec[0]
    back = pts[pts[:, 2] < axis[1]]
    for side, sign in (("left", 1.0), ("right", -1.0)):
        target = axis[0] + sign * half
        lm[f"back_armhole_point_{side}"] = back[np.argmin(np.abs(back[:, 0] - target))]
    for name, i in (("waist", i_waist), ("hip", i_hip)):
        loop = loops[i]
        near = loop[np.abs(loop[:, 0] - axis[0]) < 0.03]
        lm[f"{name}_front"] = near[np.argmax(near[:, 2])]
        lm[f"{name}_back"] = near[np.argmin(near[:, 2])]
    bust = loops[i_bust]
    left, right = bust[bust[:, 0] > axis[0]], bust[bust[:, 0] <= axis[0]]
    lm["bust_point_left"] = left[np.argmax(left[:, 2])]
    lm["bust_point_right"] = right[np.argmax(right[:, 2])]
    lm["underarm_point_left"] = arm_loop[np.argmax(arm_loop[:, 0])]
    lm["underarm_point_right"] = arm_loop[np.argmin(arm_loop[:, 0])]
    lm["crotch_point"] = np.array([axis[0], ys[i_crotch], axis[1]])
    return {k: np.asarray(p, float).copy() for k, p in lm.items()}
