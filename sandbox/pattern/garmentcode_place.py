"""Landmark placements for imported GarmentCode panels.

GarmentCode lays its panels out flat around *its* body, at its arm pose (arms about 45°
below the horizontal): the torso panels stand in front of and behind the body, a flared
skirt's panels stick out a metre wide, the sleeves follow the raised arms. On the
mannequin here, whose arms hang at 16–25°, that layout sews a flared skirt round the hands
and leaves sleeves beside the arms. :func:`body_placements` turns each panel's explicit
placement into the landmark form our own garments use (``docs/pattern_format.md``,
"Placement"): the same side of the same body part, at the same height relative to the
same body level, then wrapped round the mannequin by the placer like any library panel.

What is read from GarmentCode's layout, for a panel whose 3D outline is X = R [x, y, 0] + t
(centimetres) and whose outward normal is n = R e_z:

* the body part: an **arm** when the outline's centre lies further out than half the
  body's shoulder width (``shoulder_w``) and above its hips; a **leg** (trousers) when it
  lies below the crotch and off the body's centre line: these keep GarmentCode's
  placement, as the legs of both bodies stand alike; else the **torso**;
* the side: the quadrant of n's horizontal direction (front, left, back, right);
* the height: GarmentCode's body levels (``GarmentCodeLevels``: the nape, the waist and
  the hips, from its body file) against the mannequin's landmarks at the same levels. A
  torso panel belongs to the level nearest its top. A skirt's panel is anchored at the
  point GarmentCode put at that level on the body's centre line (x = 0 for a front or back
  panel, z = 0 for a side one), at ``waist_front``/``waist_back`` or
  ``hip_front``/``hip_back``. The panels at the nape (bodices, and what GarmentCode laid
  out above them: collars, hoods) hang from the shoulders: the highest bodice top goes to
  the height of the side neck point, the others keep their heights relative to it;
* a sleeve is turned in its own plane so that the arm runs along its y axis (rotating a
  panel's outline with its grain changes nothing of the cloth) and is anchored with its
  top at the shoulder point and its middle on its side of the arm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sandbox.pattern.spec import rotation_matrix_xyz_deg


@dataclass(frozen=True)
class GarmentCodeLevels:
    """Heights [cm] of a GarmentCode body's levels in its layout frame (floor at y = 0),
    its head length (``head_l``: the crown above the nape) [cm], half its shoulder width
    [cm] and its arm pose [deg below the horizontal]."""

    nape_cm: float
    head_cm: float
    waist_cm: float
    hips_cm: float
    crotch_cm: float
    shoulder_half_cm: float
    arm_pose_deg: float

    @classmethod
    def from_body(cls, body: dict) -> GarmentCodeLevels:
        """From a GarmentCode body mapping (cm), as GarmentCode computes them:
        waist = height - head_l - waist_line, hips = waist - hips_line."""
        nape = body["height"] - body["head_l"]
        waist = nape - body["waist_line"]
        hips = waist - body["hips_line"]
        return cls(nape_cm=nape, head_cm=body["head_l"], waist_cm=waist, hips_cm=hips,
                   crotch_cm=hips - body.get("crotch_hip_diff", 8.8),
                   shoulder_half_cm=body["shoulder_w"] / 2,
                   arm_pose_deg=body.get("arm_pose_angle", 45.0))  # fmt: skip


#: GarmentCode's default body (``mean_all.yaml``), for designs imported without one
MEAN_ALL = GarmentCodeLevels.from_body({
    "height": 171.99, "head_l": 26.3262, "waist_line": 36.8913, "hips_line": 23.4837,
    "crotch_hip_diff": 8.81363, "shoulder_w": 36.4568, "arm_pose_angle": 45.483,
})  # fmt: skip


def arm_angle_from_pose(arm_pose_deg: float) -> float:
    """The mannequin's arm angle from the vertical [deg] for GarmentCode's arm pose (below
    the horizontal), moved into the mannequin's range
    (:data:`sandbox.mannequin.model.ARM_ANGLE_RANGE_DEG`)."""
    from sandbox.mannequin.model import ARM_ANGLE_RANGE_DEG

    lo, hi = ARM_ANGLE_RANGE_DEG
    return round(min(max(90.0 - float(arm_pose_deg), lo), hi), 6)


def head_length_from(head_l_cm: float) -> float:
    """The mannequin's head length [cm] (crown above the nape) for GarmentCode's ``head_l``,
    moved into the mannequin's range (:data:`sandbox.mannequin.head.HEAD_LENGTH_RANGE_CM`)."""
    from sandbox.mannequin.head import HEAD_LENGTH_RANGE_CM

    lo, hi = HEAD_LENGTH_RANGE_CM
    return round(min(max(float(head_l_cm), lo), hi), 6)


#: a torso panel whose top is this close to the nape [cm] is a bodice, hung from the shoulders
BODICE_TOP_CM = 12.0
_SIDES = ("front", "left", "back", "right")  # n's horizontal angle from +z, by quadrant


def body_placements(panels: dict, levels: GarmentCodeLevels = MEAN_ALL) -> dict:
    """The landmark placement of each imported panel (name -> placement, or None where
    GarmentCode's own placement is kept: legs, or a panel seen edge-on). ``panels``: our
    pattern format's panels (cm) with GarmentCode's explicit ``placement``. A sleeve's
    ``vertices``, curve controls and ``grain`` are turned in place (module docstring)."""
    laid = {name: _layout(panel) for name, panel in panels.items()}
    parts = {name: _part(x3, levels) for name, (x3, _, _) in laid.items()}
    named = {"nape": levels.nape_cm, "waist": levels.waist_cm, "hip": levels.hips_cm}
    level = {name: min(named, key=lambda k: abs(named[k] - laid[name][0][:, 1].max()))
             for name, part in parts.items() if part == "torso"}  # fmt: skip
    # the bodices hang from the shoulders: their tops go to the side neck point (a hood or
    # a collar, laid out higher, keeps its height above them)
    tops = [
        top
        for n, lv in level.items()
        if lv == "nape" and abs((top := laid[n][0][:, 1].max()) - levels.nape_cm) <= BODICE_TOP_CM
    ]
    heights = dict(named, nape=max(tops) if tops else levels.nape_cm)
    out = {}
    for name, panel in panels.items():
        x3, rot, t = laid[name]
        if parts[name] is None:
            out[name] = None
        elif parts[name] != "torso":
            out[name] = _arm_placement(panel, rot, parts[name], levels)
        else:
            out[name] = _torso_placement(rot, t, level[name], heights[level[name]])
    return out


def _layout(panel: dict):
    """GarmentCode's 3D outline (n, 3) [cm] of a panel, its rotation and translation."""
    pl = panel["placement"]
    rot = rotation_matrix_xyz_deg(pl.get("rotation_deg", (0.0, 0.0, 0.0)))
    t = np.asarray(pl["translation"], float)
    v = np.asarray(panel["vertices"], float)
    return np.column_stack([v, np.zeros(len(v))]) @ rot.T + t, rot, t


def _part(x3: np.ndarray, levels: GarmentCodeLevels) -> str | None:
    """``"arm_left"``, ``"arm_right"``, ``"torso"``, or None for a trouser leg."""
    c = x3.mean(axis=0)
    if abs(c[0]) > levels.shoulder_half_cm and c[1] > levels.hips_cm:
        return "arm_left" if c[0] > 0 else "arm_right"
    if c[1] < levels.crotch_cm and abs(c[0]) > 5.0 and min(-x3[:, 0].min(), x3[:, 0].max()) < 3.0:
        return None  # a trouser leg: both bodies' legs stand alike
    return "torso"


def _torso_placement(rot, t, level: str, height_cm: float) -> dict | None:
    """The panel point GarmentCode put at ``height_cm`` on the body's centre line (x = 0
    for a front or back panel, z = 0 sideways), at the landmark of that level."""
    n = rot[:, 2]
    side = _SIDES[int(np.floor((math.degrees(math.atan2(n[0], n[2])) + 45.0) % 360 / 90.0))]
    across = 0 if side in ("front", "back") else 2
    a = np.array([[rot[across, 0], rot[across, 1]], [rot[1, 0], rot[1, 1]]])
    if abs(np.linalg.det(a)) < 1e-6:
        return None
    anchor = np.linalg.solve(a, [-t[across], height_cm - t[1]])
    back = "back" if side == "back" else "front"
    landmark = "side_neck_point_left" if level == "nape" else f"{level}_{back}"
    return {"body": "torso", "side": side, "anchor": [_r(anchor[0]), _r(anchor[1])],
            "landmark": landmark, "wrap": True}  # fmt: skip


def _arm_placement(panel: dict, rot, body: str, levels: GarmentCodeLevels) -> dict:
    """A sleeve panel turned so that the arm runs along +y, anchored at the shoulder."""
    arm = body.rpartition("_")[2]
    n = rot[:, 2]
    a = math.radians(levels.arm_pose_deg)
    sx = 1.0 if arm == "left" else -1.0
    up = np.array([-sx * math.cos(a), math.sin(a), 0.0])  # along the arm, to the shoulder
    u = (rot.T @ up)[:2]
    if np.linalg.norm(u) < 1e-6:
        u = np.array([0.0, 1.0])
    phi = math.atan2(u[0], u[1])  # turn u onto +y: rotate by +phi
    cs, sn = math.cos(phi), math.sin(phi)
    turn = np.array([[cs, -sn], [sn, cs]])
    v = np.asarray(panel["vertices"], float) @ turn.T
    panel["vertices"] = [[_r(p[0]), _r(p[1])] for p in v]
    # the same 3D layout with the turned outline: R [v, 0] = R Rz(-phi) [turn v, 0]
    from sandbox.pattern.garmentcode import _euler_xyz_deg

    turn3 = np.eye(3)
    turn3[:2, :2] = turn
    euler = _euler_xyz_deg(rot @ turn3.T)
    panel["placement"] = dict(panel["placement"], rotation_deg=[_r(q) for q in euler])
    g = turn @ np.asarray(panel.get("grain", (0.0, 1.0)), float)
    panel["grain"] = [_r(g[0]), _r(g[1])]
    for e in panel["edges"]:
        curve = e.get("curve") or {}
        pts = [curve["control"]] if "control" in curve else curve.get("controls", [])
        for p in pts:
            p[0], p[1] = (_r(q) for q in turn @ np.asarray(p, float))
    side = "front" if n[2] >= 0 else "back"
    anchor = [_r(0.5 * (v[:, 0].min() + v[:, 0].max())), _r(v[:, 1].max())]
    return {"body": f"arm_{arm}", "side": side, "anchor": anchor,
            "landmark": f"shoulder_point_{arm}", "wrap": True, "clearance": 1.5}  # fmt: skip


def _r(x: float) -> float:
    return round(float(x), 6) + 0.0
