"""§2.1.4 Customized mannequin: closest size, ratios, control points moved, corrections.

The paper finds the closest mannequin in its database, computes the ratios between the
requested and the stored dimensions, moves the NURBS control points by their position on
the body and those ratios, and exports a triangle mesh. We do the same on our control
net, then correct with the tape measure so every request is met within 0.05 cm:

* girth rings are scaled to their exact convex-hull perimeter (the tape reads the ring);
* the back length is met by a secant search on the vertical scale above the waist;
* shoulder width, shoulder length and back width are met by a few fixed-point steps that
  move the shoulder points, the neck width and the armhole creases.
"""

from __future__ import annotations

import math

import numpy as np

from sandbox.errors import SandboxError
from sandbox.mannequin import tape
from sandbox.mannequin.measurements import Measurements, SizeEntry
from sandbox.mannequin.shape import SHOULDER_SLOPE_RAD, BodyShape, shape_from_size
from sandbox.mannequin.surface import BodyTemplate

TOLERANCE_M = 0.0004  # corrective iterations stop below 0.04 cm


def size_ratios(target: Measurements, entry: SizeEntry) -> dict[str, float]:
    """§2.1.4 step 2: ratio requested / closest-size value for each of the seven keys."""
    ref = entry.measurements.to_dict()
    return {k: v / ref[k] for k, v in target.to_dict().items()}


def move_control_points(base: BodyShape, r: dict[str, float]) -> BodyShape:
    """§2.1.4 step 3: move the control net by position on the body and ratio.

    Each key row is scaled by the ratio of the feature line it lies on, rows between two
    feature lines by the ratios blended by height (so neighbouring rows move alike and the
    surface stays smooth); limbs follow the nearest girth.
    """
    s = base
    w_ub = (s.y_bust - s.y_underbust) / (s.y_bust - s.y_waist)
    r_ub = (1 - w_ub) * r["bust_girth"] + w_ub * r["waist_girth"]
    r_hip = r["hip_girth"]
    new = s.copy(
        bust_girth=s.bust_girth * r["bust_girth"],
        underbust_girth=s.underbust_girth * r_ub,
        waist_girth=s.waist_girth * r["waist_girth"],
        hip_girth=s.hip_girth * r_hip,
        bust_prominence=s.bust_prominence * r["bust_girth"],
        top_arm_girth=s.top_arm_girth * r["bust_girth"],
        wrist_girth=s.wrist_girth * math.sqrt(r["bust_girth"]),
        thigh_girth=s.thigh_girth * r_hip,
        knee_girth=s.knee_girth * math.sqrt(r_hip),
        calf_girth=s.calf_girth * math.sqrt(r_hip),
        ankle_girth=s.ankle_girth * math.sqrt(r_hip),
        vertical_scale=r["back_length"],
        shoulder_x=s.shoulder_x * r["shoulder_width"],
        back_crease_x=s.back_crease_x * r["back_width"],
        front_crease_x=s.front_crease_x * r["back_width"],
        shoulder_length=s.shoulder_length * r["shoulder_length"],
    )
    # keep the underbust between waist and bust after unequal ratios
    lo, hi = sorted((new.waist_girth, new.bust_girth))
    new.underbust_girth = min(max(new.underbust_girth, lo), hi)
    run = new.shoulder_length * math.cos(SHOULDER_SLOPE_RAD)
    new.neck_half_width = new.shoulder_x - run
    return new


class Corrector:
    """Tape-measure corrections on one template (the cheap partial evaluations)."""

    def __init__(self, template: BodyTemplate, landmarks: dict[str, int]):
        self.t = template
        self.lm = landmarks
        f = template.faces
        self.yoke_faces = f[np.isin(f, template.yoke_grid).all(axis=1)]

    def back_length(self, s: BodyShape) -> float:
        """Nape-to-waist tape [m] on the centre-back column only."""
        prof = self.t.centre_back_profile(s)
        return tape.hull_chain_length(prof[:, [2, 1]], np.array([-1.0, 0.0]))

    def fit_back_length(self, s: BodyShape, target: float) -> BodyShape:
        """Secant search on the vertical scale above the waist."""
        x0 = s.vertical_scale
        f0 = self.back_length(s) - target
        if abs(f0) < TOLERANCE_M:
            return s
        x1 = x0 * target / (target + f0)
        for _ in range(8):
            f1 = self.back_length(s.copy(vertical_scale=x1)) - target
            if abs(f1) < TOLERANCE_M:
                break
            x0, x1 = x1, x1 - f1 * (x1 - x0) / (f1 - f0)
            f0 = f1
        return s.copy(vertical_scale=x1)

    def upper(self, s: BodyShape) -> dict[str, float]:
        v = self.t.evaluate_upper(s)
        lm = {k: v[i] for k, i in self.lm.items()}
        return tape.upper_body_measures(v, self.yoke_faces, lm)

    def fit_shoulders(
        self, s: BodyShape, target: Measurements | None, *, keep_neck: bool = False
    ) -> tuple[BodyShape, dict[str, float]]:
        """Fixed-point steps on shoulder point, neck width and creases.

        With ``keep_neck`` (database build) the neck width stays and the shoulder width is
        whatever results; otherwise all three widths/lengths are met.
        """
        cm = 0.01
        cos_slope = math.cos(SHOULDER_SLOPE_RAD)
        got = self.upper(s)
        for _ in range(12):
            e_sl = target.shoulder_length * cm - got["shoulder_length"]
            e_bw = target.back_width * cm - got["back_width"]
            e_sw = 0.0 if keep_neck else target.shoulder_width * cm - got["shoulder_width"]
            if max(abs(e_sl), abs(e_bw), abs(e_sw)) < TOLERANCE_M:
                break
            dx_sp = 0.5 * e_sw if not keep_neck else e_sl * cos_slope
            s = s.copy(
                shoulder_x=s.shoulder_x + dx_sp,
                neck_half_width=s.neck_half_width + dx_sp - e_sl * cos_slope,
                back_crease_x=s.back_crease_x + 0.5 * e_bw,
                front_crease_x=s.front_crease_x + 0.5 * e_bw,
            )
            check_shape(s)
            got = self.upper(s)
        else:
            raise SandboxError(
                "measurements: shoulder width "
                f"{'' if target is None else target.shoulder_width}, shoulder length and back "
                "width are contradictory (the corrections do not converge)"
            )
        return s, got


def check_shape(s: BodyShape) -> None:
    """Raise :class:`SandboxError` when the corrections leave a body we cannot build."""
    if not 0.035 <= s.neck_half_width <= 0.1:
        raise SandboxError(
            "measurements: shoulder width and shoulder length are contradictory "
            f"(they need a neck {200 * s.neck_half_width:.1f} cm wide; 7-20 cm is possible)"
        )
    if s.back_crease_x > s.shoulder_x + 0.005 or s.back_crease_x < s.neck_half_width + 0.04:
        raise SandboxError(
            "measurements: back width and shoulder width are contradictory (the armhole "
            "creases would fall outside the shoulder points or onto the neck)"
        )


def fit_shape(
    template: BodyTemplate,
    corrector: Corrector,
    target: Measurements,
    entry: SizeEntry,
    *,
    keep_neck: bool = False,
) -> BodyShape:
    """§2.1.4 from a database entry to a corrected :class:`BodyShape` for ``target``."""
    s = move_control_points(shape_from_size(entry), size_ratios(target, entry))
    if keep_neck:
        base = shape_from_size(entry)
        s = s.copy(neck_half_width=base.neck_half_width)
    check_shape(s)
    s = corrector.fit_back_length(s, target.back_length * 0.01)
    s, _ = corrector.fit_shoulders(s, target, keep_neck=keep_neck)
    return s
