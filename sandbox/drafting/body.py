"""The body dimensions a pattern drafter needs, from the seven measurements (cm).

The paper's seven measurements (bust, waist, hip girth, shoulder width, back width,
shoulder length, back length) do not give everything a block needs (neck size, armscye
depth, waist to hip, across chest, upper arm, wrist, sleeve length). Those come from the
size database (Aldrich's table, ``mannequins/sizes.json``) interpolated linearly in the
bust girth, or, when a mannequin is given, are read off its landmarks (heights,
neck width, shoulder slope) and its body shape (arm girths, sleeve length).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from sandbox.mannequin.measurements import Measurements, load_size_table

REFERENCE_BACK_LENGTH_CM = 41.0  # size 12: lengths given "for size 12" scale by BL / this


@dataclasses.dataclass(frozen=True)
class BodyDims:
    """Everything a block needs [cm, degrees].

    ``bust``, ``waist``, ``hip`` girths; ``shoulder_width`` (across the back over the nape),
    ``back_width``, ``shoulder_length``, ``back_length`` (nape to waist); ``armscye_depth``
    (nape to the underarm level), ``waist_to_hip``, ``waist_to_knee``, ``neck_size`` (neck
    base girth), ``neck_half_width`` (centre line to the side neck point, horizontal),
    ``neck_rise`` (side neck point above the nape), ``front_neck_depth`` (front neck point
    below the side neck point), ``shoulder_slope_deg`` (shoulder line below horizontal),
    ``chest`` (across front), ``top_arm``, ``wrist`` (girths), ``sleeve_length`` (shoulder
    point to wrist). ``source`` says where the derived values came from.
    """

    bust: float
    waist: float
    hip: float
    shoulder_width: float
    back_width: float
    shoulder_length: float
    back_length: float
    armscye_depth: float
    waist_to_hip: float
    waist_to_knee: float
    neck_size: float
    neck_half_width: float
    neck_rise: float
    front_neck_depth: float
    shoulder_slope_deg: float
    chest: float
    top_arm: float
    wrist: float
    sleeve_length: float
    source: str = "size table"

    @property
    def length_scale(self) -> float:
        """Back length / 41 cm: lengths given for size 12 scale by this."""
        return self.back_length / REFERENCE_BACK_LENGTH_CM

    def to_dict(self) -> dict:
        return {
            k: (round(v, 3) if isinstance(v, float) else v)
            for k, v in dataclasses.asdict(self).items()
        }


def _table_extras(bust: float) -> dict[str, float]:
    """Aldrich extras interpolated (and linearly extrapolated) in the bust girth [cm]."""
    table = load_size_table()
    b = np.array([e.measurements.bust_girth for e in table])
    out = {}
    for key in table[0].extra:
        v = np.array([e.extra[key] for e in table])
        if bust <= b[0]:
            out[key] = float(v[0] + (bust - b[0]) * (v[1] - v[0]) / (b[1] - b[0]))
        elif bust >= b[-1]:
            out[key] = float(v[-1] + (bust - b[-1]) * (v[-1] - v[-2]) / (b[-1] - b[-2]))
        else:
            out[key] = float(np.interp(bust, b, v))
    return out


def neck_half_width_from_size(neck_size: float) -> float:
    """Half width [cm] of the neck base: the mannequin's ellipse (width/depth 1.12)."""
    # perimeter of an ellipse with a = 1.12 b (Ramanujan) = 6.667 b
    return 1.12 * neck_size / 6.667


def body_dims(m: Measurements, mannequin=None) -> BodyDims:
    """Drafting dimensions of a body [cm] (see :class:`BodyDims`).

    ``mannequin``: a :class:`sandbox.mannequin.Mannequin`; its landmarks give the heights
    (armscye depth, waist to hip), the neck half width, the neck rise, the front neck depth
    and the shoulder slope, its shape the arm girths and the sleeve length.
    """
    ex = _table_extras(m.bust_girth)
    scale = m.back_length / REFERENCE_BACK_LENGTH_CM
    neck = ex["neck_size"]
    d = dict(
        bust=m.bust_girth,
        waist=m.waist_girth,
        hip=m.hip_girth,
        shoulder_width=m.shoulder_width,
        back_width=m.back_width,
        shoulder_length=m.shoulder_length,
        back_length=m.back_length,
        armscye_depth=ex["armscye_depth"],
        waist_to_hip=ex["waist_to_hip"],
        waist_to_knee=ex["waist_to_knee"] * scale / _table_scale(m.bust_girth),
        neck_size=neck,
        neck_half_width=neck_half_width_from_size(neck),
        neck_rise=1.5,
        front_neck_depth=0.2 * neck + 0.2,
        shoulder_slope_deg=20.0,
        chest=ex["chest"],
        top_arm=ex["top_arm"],
        wrist=ex["wrist"],
        sleeve_length=ex["sleeve_length"],
        source="size table",
    )
    if mannequin is not None:
        lm = {k: np.asarray(v, float) * 100.0 for k, v in mannequin.landmarks.items()}
        y_ua = 0.5 * (lm["underarm_point_left"][1] + lm["underarm_point_right"][1])
        y_w = 0.5 * (lm["waist_front"][1] + lm["waist_back"][1])
        y_h = 0.5 * (lm["hip_front"][1] + lm["hip_back"][1])
        snp = 0.5 * (lm["side_neck_point_left"] + lm["side_neck_point_right"] * [-1, 1, 1])
        sp = 0.5 * (lm["shoulder_point_left"] + lm["shoulder_point_right"] * [-1, 1, 1])
        d.update(
            armscye_depth=float(lm["back_neck_point"][1] - y_ua),
            waist_to_hip=float(y_w - y_h),
            neck_half_width=float(snp[0]),
            neck_rise=float(snp[1] - lm["back_neck_point"][1]),
            front_neck_depth=float(snp[1] - lm["front_neck_point"][1]),
            shoulder_slope_deg=math.degrees(
                math.atan2(snp[1] - sp[1], math.hypot(sp[0] - snp[0], sp[2] - snp[2]))
            ),
            source="mannequin landmarks",
        )
        shape = getattr(mannequin, "shape", None)
        if shape is not None:
            d.update(
                top_arm=float(shape.top_arm_girth) * 100.0,
                wrist=float(shape.wrist_girth) * 100.0,
                sleeve_length=float(shape.sleeve_length) * 100.0,
                waist_to_knee=float(shape.waist_to_knee) * 100.0,
            )
    return BodyDims(**d)


def _table_scale(bust: float) -> float:
    """The back-length scale the table itself has at this bust (so the table's own sizes
    get their table waist-to-knee back exactly)."""
    table = load_size_table()
    b = np.array([e.measurements.bust_girth for e in table])
    bl = np.array([e.measurements.back_length for e in table])
    if bust <= b[0]:
        v = bl[0] + (bust - b[0]) * (bl[1] - bl[0]) / (b[1] - b[0])
    elif bust >= b[-1]:
        v = bl[-1] + (bust - b[-1]) * (bl[-1] - bl[-2]) / (b[-1] - b[-2])
    else:
        v = float(np.interp(bust, b, bl))
    return v / REFERENCE_BACK_LENGTH_CM
