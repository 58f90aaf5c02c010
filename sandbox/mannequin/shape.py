"""Body shape parameters: the scalars that drive the control net, all in metres.

:func:`shape_from_size` turns one row of the size database (centimetres) into a
:class:`BodyShape` with proportion rules for what the table does not give (thigh, knee,
bust prominence, neck placement). The control net (key rows of every part) is generated
from a :class:`BodyShape` by :mod:`sandbox.mannequin.body`.
"""

from __future__ import annotations

import dataclasses
import math

from sandbox.mannequin.measurements import SizeEntry

SHOULDER_SLOPE_RAD = math.radians(20.0)  # shoulder line below horizontal
ARM_ANGLE_MIN_RAD = math.radians(16.0)  # A-pose: smallest arm angle from vertical
# A-pose: the arm opens until its elbow, forearm and wrist clear the torso by this much [m].
# 3 cm leaves room in the crease between arm and
# torso for a sleeve's underarm seam, a bodice's side seam and their contact thickness.
ARM_CLEARANCE_M = 0.03


@dataclasses.dataclass
class BodyShape:
    """Scalars of one body [m]. Girths are convex-hull perimeters of the key rings."""

    # heights (y, floor at 0)
    y_waist: float
    back_length: float  # nape (back neck point) to waist along the centre back (target)
    armscye_depth: float  # nape to underarm level
    waist_to_hip: float
    body_rise: float  # waist to crotch
    waist_to_knee: float
    y_ankle: float
    vertical_scale: float  # stretch of the torso above the waist (back-length fit)
    # torso girths
    bust_girth: float
    underbust_girth: float
    waist_girth: float
    hip_girth: float
    bust_prominence: float  # forward bulge of each breast [m]
    # neck and shoulders
    neck_half_width: float
    neck_half_depth: float
    neck_z: float
    shoulder_x: float  # lateral position of the shoulder point
    shoulder_length: float  # target side-neck-point to shoulder-point length
    back_crease_x: float  # lateral position of the back armhole crease at back-width level
    front_crease_x: float
    # limbs
    top_arm_girth: float
    wrist_girth: float
    sleeve_length: float
    thigh_girth: float
    knee_girth: float
    calf_girth: float
    ankle_girth: float
    # pose
    arm_angle: float = ARM_ANGLE_MIN_RAD  # smallest angle of the arms from vertical [rad]

    def copy(self, **changes) -> BodyShape:
        return dataclasses.replace(self, **changes)

    # derived heights -------------------------------------------------------------------
    @property
    def y_nape(self) -> float:
        return self.y_waist + self.back_length * self.vertical_scale

    def _above_waist(self, drop_from_nape: float) -> float:
        """Height of a level given as a drop below the nape of the *unscaled* back."""
        return self.y_waist + (self.back_length - drop_from_nape) * self.vertical_scale

    @property
    def y_armpit(self) -> float:
        return self._above_waist(self.armscye_depth)

    @property
    def y_back_width(self) -> float:
        """Level of the back-width line: half the armscye depth below the nape (Aldrich)."""
        return self._above_waist(0.5 * self.armscye_depth)

    @property
    def y_bust(self) -> float:
        return self._above_waist(self.armscye_depth + 0.035)

    @property
    def y_underbust(self) -> float:
        return self._above_waist(self.armscye_depth + 0.035 + 0.075)

    @property
    def y_hip(self) -> float:
        return self.y_waist - self.waist_to_hip

    @property
    def y_crotch(self) -> float:
        return self.y_waist - self.body_rise

    @property
    def y_knee(self) -> float:
        return self.y_waist - self.waist_to_knee

    @property
    def y_side_neck(self) -> float:
        return self.y_nape + 0.015

    @property
    def y_front_neck(self) -> float:
        return self.y_nape - 0.06

    @property
    def y_shoulder(self) -> float:
        run = self.shoulder_x - self.neck_half_width
        return self.y_side_neck - run * math.tan(SHOULDER_SLOPE_RAD)


def shape_from_size(entry: SizeEntry) -> BodyShape:
    """Proportion rules from one database row (cm) to a :class:`BodyShape` (m)."""
    m = entry.measurements
    e = entry.extra
    cm = 0.01
    bust, waist, hip = m.bust_girth * cm, m.waist_girth * cm, m.hip_girth * cm
    dart = e["dart"] * cm
    neck = e["neck_size"] * cm
    # Neck base as an ellipse, width/depth 1.12 (Ramanujan-free estimate pi*(a+b)).
    a_plus_b = neck / math.pi
    neck_half_depth = a_plus_b / 2.12
    neck_half_width = a_plus_b - neck_half_depth
    slope_run = m.shoulder_length * cm * math.cos(SHOULDER_SLOPE_RAD)
    return BodyShape(
        y_waist=e["waist_to_floor"] * cm,
        back_length=m.back_length * cm,
        armscye_depth=e["armscye_depth"] * cm,
        waist_to_hip=e["waist_to_hip"] * cm,
        body_rise=e["body_rise"] * cm,
        waist_to_knee=e["waist_to_knee"] * cm,
        y_ankle=0.075 * e["waist_to_floor"] / 105.0,
        vertical_scale=1.0,
        bust_girth=bust,
        underbust_girth=max(bust - 1.6 * dart, waist + 0.3 * (bust - waist)),
        waist_girth=waist,
        hip_girth=hip,
        bust_prominence=0.0045 * e["dart"],
        neck_half_width=neck_half_width,
        neck_half_depth=neck_half_depth,
        neck_z=-0.025,
        shoulder_x=neck_half_width + slope_run,
        shoulder_length=m.shoulder_length * cm,
        back_crease_x=0.5 * m.back_width * cm / 1.05,
        front_crease_x=0.5 * e["chest"] * cm / 1.05,
        top_arm_girth=e["top_arm"] * cm,
        wrist_girth=e["wrist"] * cm,
        sleeve_length=e["sleeve_length"] * cm,
        thigh_girth=0.58 * hip,
        knee_girth=0.37 * hip,
        calf_girth=0.35 * hip,
        ankle_girth=0.21 * hip + 0.01,
    )
