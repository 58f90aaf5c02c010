"""The control net of the body: key rows of every part, generated from a :class:`BodyShape`.

Parts and their key rows (bottom to top, or from the junction outwards):

* torso (N columns, periodic): crotch-top, hip, high hip, waist, underbust, bust, armpit
  rings, all horizontal. Columns: centre front 0, left side seam N/4, centre back N/2,
  right side seam 3N/4, princess lines through the bust points and the shoulder blades.
* shoulder bridges (curves): front armhole point -> front crease -> shoulder point ->
  back crease -> back armhole point; with the torso underarm columns they close the
  armhole feature line.
* yoke (neck-shoulder tube): loop (torso front and back columns at the armpit ring plus
  both shoulder bridges) -> neck base -> neck top.
* arms: armhole loop -> upper arm -> biceps -> elbow -> forearm -> wrist.
* legs: crotch loop (half torso ring + the crotch bridge at x = 0) -> upper thigh ->
  mid thigh -> knee -> calf -> ankle.

All points are metres, Y up, front +Z, body left +X, floor at y = 0.
"""

from __future__ import annotations

import math

import numpy as np

from sandbox.mannequin.sections import breasts, hull_perimeter, torso_ring
from sandbox.mannequin.shape import ARM_CLEARANCE_M, BodyShape

# (front depth / width, back depth / width, exponent, -) of each torso key ring.
TORSO_RINGS = ("crotch_top", "hip", "high_hip", "waist", "underbust", "bust", "armpit")
PROPORTIONS = {
    "crotch_top": (0.60, 0.80, 2.3, 0.0),
    "hip": (0.60, 0.82, 2.3, 0.0),
    "high_hip": (0.64, 0.74, 2.2, 0.0),
    "waist": (0.70, 0.68, 2.1, 0.0),
    "underbust": (0.66, 0.64, 2.3, 0.0),
    "bust": (0.62, 0.62, 2.5, 0.0),
    "armpit": (0.56, 0.62, 2.6, 0.0),
}
Z_CENTRE = {
    "crotch_top": -0.005,
    "hip": -0.012,
    "high_hip": -0.006,
    "waist": 0.0,
    "underbust": 0.0,
    "bust": -0.005,
    "armpit": -0.012,
}
CROTCH_DIP = 0.035  # crotch point below the crotch-top ring [m]


class Columns:
    """Feature column indices of a torso with ``n`` columns (n a multiple of 16)."""

    def __init__(self, n: int):
        if n % 16 or n < 32:
            raise ValueError("torso column count must be a multiple of 16, at least 32")
        self.n = n
        self.side_left = n // 4
        self.back = n // 2
        self.side_right = 3 * n // 4
        self.armhole_half = max(2, round(n / 21))
        self.princess_front = round(0.075 * n)
        self.princess_back = round(0.085 * n)
        self.angles = 2.0 * math.pi * np.arange(n) / n

    def mirror(self, c):
        return (self.n - np.asarray(c)) % self.n


def torso_key_rings(s: BodyShape, cols: Columns) -> dict[str, np.ndarray]:
    """The seven horizontal torso rings (N, 3) each, girths exact where the shape sets one."""
    rings = dict(_girth_rings(s, cols))
    bust_half_width = float(rings["bust"][cols.side_left, 0])
    rings["armpit"] = torso_ring(
        cols.angles,
        girth=None,
        half_width=max(bust_half_width, s.back_crease_x - 0.004) + 0.004,
        y=s.y_armpit,
        proportions=PROPORTIONS["armpit"],
        z_centre=Z_CENTRE["armpit"],
    )
    return rings


_RING_CACHE: dict = {}


def _girth_rings(s: BodyShape, cols: Columns) -> dict[str, np.ndarray]:
    """The six girth-driven rings, memoised on the values they depend on."""
    key = (
        cols.n,
        s.y_crotch,
        s.y_hip,
        s.y_waist,
        s.y_underbust,
        s.y_bust,
        s.hip_girth,
        s.waist_girth,
        s.underbust_girth,
        s.bust_girth,
        s.bust_prominence,
    )
    hit = _RING_CACHE.get(key)
    if hit is None:
        if len(_RING_CACHE) > 64:
            _RING_CACHE.clear()
        hit = _RING_CACHE[key] = _compute_girth_rings(s, cols)
    return hit


def _compute_girth_rings(s: BodyShape, cols: Columns) -> dict[str, np.ndarray]:
    a = cols.angles
    apex = cols.angles[cols.princess_front]
    y = {
        "crotch_top": s.y_crotch + CROTCH_DIP,
        "hip": s.y_hip,
        "high_hip": 0.5 * (s.y_hip + s.y_waist),
        "waist": s.y_waist,
        "underbust": s.y_underbust,
        "bust": s.y_bust,
    }
    girth = {
        "crotch_top": 0.965 * s.hip_girth,
        "hip": s.hip_girth,
        "high_hip": 0.45 * s.waist_girth + 0.55 * s.hip_girth,
        "waist": s.waist_girth,
        "underbust": s.underbust_girth,
        "bust": s.bust_girth,
    }
    rings = {}
    for name in TORSO_RINGS[:-1]:
        bulge = None
        if name == "bust":
            bulge = breasts(a, s.bust_prominence, apex)
        elif name == "underbust":
            bulge = breasts(a, 0.35 * s.bust_prominence, apex)
        rings[name] = torso_ring(
            a,
            girth=girth[name],
            y=y[name],
            proportions=PROPORTIONS[name],
            z_centre=Z_CENTRE[name],
            bulge=bulge,
        )
    return rings


def ring_girth(ring: np.ndarray) -> float:
    """Convex-hull perimeter of a horizontal ring (k, 3) [m]."""
    return hull_perimeter(ring[:, [0, 2]])


def shoulder_bridge_points(s: BodyShape, armpit: np.ndarray, cols: Columns) -> np.ndarray:
    """Five control points (5, 3) of the left armhole's upper part.

    Front armhole point (torso armpit ring), front crease and back crease at the
    back-width level, shoulder point on top, back armhole point.
    """
    a_f = armpit[cols.side_left - cols.armhole_half]
    a_b = armpit[cols.side_left + cols.armhole_half]
    z_sp = s.neck_z + 0.012
    sp = np.array([s.shoulder_x, s.y_shoulder, z_sp])
    y_bw = s.y_back_width
    f_c = np.array([s.front_crease_x, y_bw, 0.5 * (a_f[2] + z_sp) + 0.028])
    b_c = np.array([s.back_crease_x, y_bw, 0.5 * (a_b[2] + z_sp) - 0.028])
    return np.stack([a_f, f_c, sp, b_c, a_b])


def crotch_bridge(cf: np.ndarray, cb: np.ndarray, count: int) -> np.ndarray:
    """Interior points (count, 3) of the crotch curve at x = 0 from centre back to front.

    A U in the sagittal plane dipping :data:`CROTCH_DIP` below the crotch-top ring; the
    middle point (count odd) is the crotch point.
    """
    u = np.arange(1, count + 1) / (count + 1)
    pts = np.zeros((count, 3))
    pts[:, 2] = cb[2] + (cf[2] - cb[2]) * u
    pts[:, 1] = cb[1] - CROTCH_DIP * np.sin(math.pi * u) ** 0.7
    return pts


def neck_ring(s: BodyShape, psi: np.ndarray, *, top: bool = False) -> np.ndarray:
    """Neck base (or neck top) ring at angles ``psi`` (0 front, pi/2 body left) [m]."""
    a, b = s.neck_half_width, s.neck_half_depth
    out = np.empty((len(psi), 3))
    if top:
        out[:, 0] = 0.93 * a * np.sin(psi)
        out[:, 2] = s.neck_z + 0.008 + 0.93 * b * np.cos(psi)
        out[:, 1] = s.y_nape + 0.075
        return out
    front, side, back = s.y_front_neck, s.y_side_neck, s.y_nape
    mid = 0.5 * (0.5 * (front + back) + side)
    c2 = 0.5 * (0.5 * (front + back) - side)
    out[:, 0] = a * np.sin(psi)
    out[:, 2] = s.neck_z + b * np.cos(psi)
    out[:, 1] = mid + 0.5 * (front - back) * np.cos(psi) + c2 * np.cos(2 * psi)
    return out


def arm_frames(s: BodyShape, loop: np.ndarray, torso_half_width) -> dict:
    """Centres, normals and in-plane axes of the left arm's key sections.

    The arm hangs in an A-pose at angle theta from vertical, at least ``s.arm_angle``
    (:data:`~sandbox.mannequin.shape.ARM_ANGLE_MIN_RAD` unless posed), opened further
    until the arm clears the torso by :data:`ARM_CLEARANCE_M` (``torso_half_width(y)``
    gives the torso's half width at height y).
    """
    c0 = loop.mean(axis=0)
    _, _, vt = np.linalg.svd(loop - c0)
    n0 = vt[2] if vt[2][0] > 0 else -vt[2]
    r_top = s.top_arm_girth / (2 * math.pi)
    joint = np.array([s.shoulder_x - 0.9 * r_top, s.y_shoulder - 1.0 * r_top, c0[2]])
    dist = np.array([0.10, 0.17, 0.30, 0.38, s.sleeve_length - 0.02])
    girths = np.array(
        [
            1.08 * s.top_arm_girth,
            s.top_arm_girth,
            0.86 * s.top_arm_girth,
            0.80 * s.top_arm_girth,
            s.wrist_girth,
        ]
    )
    theta = s.arm_angle
    for d, g in zip(dist[1:], girths[1:], strict=True):
        r = g / (2 * math.pi)
        for _ in range(3):
            y = joint[1] - d * math.cos(theta)
            need = torso_half_width(y) + ARM_CLEARANCE_M + r / math.cos(theta) - joint[0]
            theta = max(theta, math.atan2(need, d))
    axis = np.array([math.sin(theta), -math.cos(theta), 0.0])
    blend = np.array([0.6, 1.0, 1.0, 1.0, 1.0])
    frames = []
    for d, w in zip(dist, blend, strict=True):
        n = (1 - w) * n0 + w * axis
        n /= np.linalg.norm(n)
        u = np.array([0.0, 0.0, 1.0]) - n[2] * n
        u /= np.linalg.norm(u)
        v = np.cross(n, u)
        frames.append((joint + d * axis, n, u, v))
    u0 = np.array([0.0, 0.0, 1.0]) - n0[2] * n0
    u0 /= np.linalg.norm(u0)
    return {
        "c0": c0,
        "u0": u0,
        "v0": np.cross(n0, u0),
        "frames": frames,
        "girths": girths,
        "theta": theta,
    }


def limb_angles(loop: np.ndarray, centre: np.ndarray, u: np.ndarray, v: np.ndarray):
    """Unwrapped angles (M,) of loop points around ``centre`` in the (u, v) frame."""
    d = loop - centre
    ang = np.unwrap(np.arctan2(d @ v, d @ u))
    if ang[-1] < ang[0]:
        raise ValueError("limb loop runs clockwise in its frame")
    return ang


def blended_angles(loop_angles: np.ndarray, weight: float) -> np.ndarray:
    """Blend loop angles towards uniform spacing (weight 1 = uniform)."""
    m = len(loop_angles)
    uniform = loop_angles[0] + 2 * math.pi * np.arange(m) / m
    return (1 - weight) * loop_angles + weight * uniform


def leg_sections(s: BodyShape, hip_ring: np.ndarray, loop: np.ndarray):
    """Centres (5, 3), girths (5,) and aspects (5,) of the left leg's key sections."""
    hip_half = float(np.max(hip_ring[:, 0]))
    r = np.array([s.thigh_girth, 0.86 * s.thigh_girth, s.knee_girth, s.calf_girth])
    r = np.append(r, s.ankle_girth) / (2 * math.pi)
    x_thigh = max(r[0] + 0.004, 0.5 * hip_half + 0.01)
    x_knee = max(r[2] + 0.012, 0.62 * x_thigh)
    x_ankle = max(r[4] + 0.02, 0.9 * x_knee)
    ys = np.array(
        [
            s.y_crotch - 0.035,
            s.y_crotch - 0.16,
            s.y_knee,
            s.y_knee - 0.11,
            s.y_ankle,
        ]
    )
    xs = np.array([x_thigh, 0.5 * (x_thigh + x_knee) + 0.005, x_knee, x_knee, x_ankle])
    zs = np.array([-0.01, -0.01, 0.0, -0.012, -0.02])
    centres = np.stack([xs, ys, zs], axis=1)
    girths = 2 * math.pi * r
    aspects = np.array([1.02, 1.0, 0.95, 1.08, 0.85])
    return centres, girths, aspects
