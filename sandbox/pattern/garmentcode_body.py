"""GarmentCode body files (``body: {bust: 99.8, ...}`` YAML) as the paper's seven measurements.

GarmentCode designs are drafted for a body given by about 25 measurements in cm
(``assets/bodies/*.yaml`` in GarmentCode; ``mean_all.yaml`` is its default body). The
mannequin here is sized by seven (§2.1.4). Four have a direct counterpart:

=================  ==========================  ==============================================
ours               GarmentCode                 note
=================  ==========================  ==============================================
bust_girth         ``bust``                    girth at the bust points
waist_girth        ``waist``                   girth at the waist
hip_girth          ``hips``                    girth at the hips
back_length        ``waist_line``              nape of the neck to the waist, on the back
=================  ==========================  ==============================================

The other three are taken from the database size closest to the body's three girths
(the paper's first step, §2.1.4), because GarmentCode measures them differently:
``shoulder_w`` is the straight distance between the shoulder points (ours is the tape over
the back neck point, a few cm longer); ``back_width`` is measured around the back from
armpit to armpit at the bust level (45-48 cm on its bodies; ours is the across-back width
between the arm creases, 31-40 cm); a shoulder length is not measured. The arm pose
``arm_pose_angle`` (degrees below the horizontal) poses the mannequin's arms at 90 degrees
minus it from the vertical (``arm_angle_deg``). Everything else (height, arm length, neck
width, bust points, the levels of bust, waist and hips, inclinations, leg girth, ...) has no
counterpart in the mannequin: its proportions below the hips, its arm length and its
height come from the database (the levels place an imported design's panels:
:mod:`sandbox.pattern.garmentcode_place`). :func:`load_garmentcode_body` lists all of it in
its ``notes``.

A mapped value just outside the supported range (within ``CLAMP_TOLERANCE`` of it, such
as ``mean_all``'s 36.9 cm nape-to-waist against 37-46 cm) is moved onto the range's end
and noted; one further out is an error naming the file and the key.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from sandbox.errors import SandboxError

#: ours <- GarmentCode, for the measurements with a direct counterpart (cm both sides)
DIRECT = {
    "bust_girth": "bust",
    "waist_girth": "waist",
    "hip_girth": "hips",
    "back_length": "waist_line",
}
#: ours taken from the closest database size, and why
FROM_SIZE = {
    "shoulder_width": "GarmentCode's shoulder_w is straight between the shoulder points",
    "back_width": "GarmentCode's back_width runs armpit to armpit around the back",
    "shoulder_length": "GarmentCode has no shoulder length",
}
#: a mapped value at most this fraction outside the supported range is clamped onto it
CLAMP_TOLERANCE = 0.05
MAX_FILE_BYTES = 1_000_000


@dataclass(frozen=True)
class GarmentCodeBody:
    """A GarmentCode body mapped onto the seven measurements.

    ``measurements``: the seven [cm] (keys of :data:`sandbox.mannequin.measurements.KEYS`);
    ``size``: the database size the three girths are closest to; ``notes``: one line per
    measurement taken from the size, clamped, or without a counterpart.
    """

    source: str
    measurements: dict
    size: int
    notes: tuple[str, ...] = field(default=())
    arm_angle_deg: float | None = None
    """The arms' angle from the vertical [deg]: 90 - ``arm_pose_angle`` (GarmentCode's is
    below the horizontal), moved into the mannequin's range; None without one."""
    head_length_cm: float | None = None
    """The head's crown above the nape [cm]: ``head_l`` moved into the mannequin's range
    (:data:`~sandbox.mannequin.head.HEAD_LENGTH_RANGE_CM`); None without one."""


def load_garmentcode_body(path: str | Path) -> GarmentCodeBody:
    """Read a GarmentCode body YAML file and map it (see the module docstring).

    Raises SandboxError naming the file and the key for a missing file, bad YAML, a
    missing or non-numeric measurement, or one far outside the supported range.
    """
    from sandbox.mannequin.measurements import KEYS, SUPPORTED_RANGE_CM, load_size_table

    p = Path(path)
    body = _read_body(p)

    def number(key: str) -> float:
        return _number(p, body, key)

    notes = []
    ours = {}
    for key, theirs in DIRECT.items():
        v = number(theirs)
        lo, hi = SUPPORTED_RANGE_CM[key]
        if lo <= v <= hi:
            ours[key] = v
            continue
        end = lo if v < lo else hi
        if abs(v - end) > CLAMP_TOLERANCE * end:
            raise SandboxError(f"{p}: body.{theirs}: {v:g} cm is outside the mannequin's "
                               f"supported {key.replace('_', ' ')} of {lo:g}-{hi:g} cm: this "
                               "body cannot be built")  # fmt: skip
        ours[key] = end
        notes.append(f"{key} {end:g} cm: {theirs} {v:g} cm clamped onto the supported "
                     f"{lo:g}-{hi:g} cm")  # fmt: skip
    table = load_size_table()
    girths = ("bust_girth", "waist_girth", "hip_girth")

    def dist(entry) -> float:
        ref = entry.measurements.to_dict()
        return sum(((ours[k] - ref[k]) / ref[k]) ** 2 for k in girths)

    nearest = min(table, key=dist)
    ref = nearest.measurements.to_dict()
    for key, why in FROM_SIZE.items():
        ours[key] = float(ref[key])
        notes.append(f"{key} {ref[key]:g} cm: from size {nearest.size}, the closest by the "
                     f"three girths ({why})")  # fmt: skip
    arm = None
    if "arm_pose_angle" in body:
        from sandbox.mannequin.model import ARM_ANGLE_RANGE_DEG
        from sandbox.pattern.garmentcode_place import arm_angle_from_pose

        pose = number("arm_pose_angle")
        lo, hi = ARM_ANGLE_RANGE_DEG
        arm = arm_angle_from_pose(pose)
        moved = f", moved onto the supported {lo:g}-{hi:g} deg"
        moved = "" if abs(arm - (90.0 - pose)) < 1e-6 else moved
        notes.append(f"arms at {arm:g} deg from the vertical: arm_pose_angle {pose:g} deg "
                     f"below the horizontal{moved}")  # fmt: skip
    head = None
    if "head_l" in body:
        from sandbox.mannequin.head import HEAD_LENGTH_RANGE_CM

        lo, hi = HEAD_LENGTH_RANGE_CM
        head_l = number("head_l")
        head = min(max(head_l, lo), hi)
        moved = "" if head == head_l else f", moved onto the supported {lo:g}-{hi:g} cm"
        notes.append(f"a head, its crown {head:g} cm above the nape: head_l {head_l:g} cm"
                     f"{moved}")  # fmt: skip
    used = set(DIRECT.values()) | {"shoulder_w", "back_width", "arm_pose_angle", "head_l"}
    rest = sorted(k for k in body if k not in used)
    if rest:
        notes.append("no counterpart (the database size's proportions stand in): "
                     + ", ".join(rest))  # fmt: skip
    return GarmentCodeBody(str(p), {k: ours[k] for k in KEYS}, nearest.size, tuple(notes), arm,
                           head)  # fmt: skip


def load_garmentcode_levels(path: str | Path):
    """The levels of a GarmentCode body file that place an imported design's panels
    (:class:`sandbox.pattern.garmentcode_place.GarmentCodeLevels`); errors as
    :func:`load_garmentcode_body`'s."""
    from sandbox.pattern.garmentcode_place import GarmentCodeLevels

    p = Path(path)
    body = _read_body(p)
    keys = ("height", "head_l", "waist_line", "hips_line", "shoulder_w")
    values = {k: _number(p, body, k, "needed to place the panels") for k in keys}
    for k in ("crotch_hip_diff", "arm_pose_angle"):
        if k in body:
            values[k] = _number(p, body, k)
    return GarmentCodeLevels.from_body(values)


def _read_body(p: Path) -> dict:
    """The ``body:`` mapping of a GarmentCode body YAML file."""
    import yaml

    try:
        if p.stat().st_size > MAX_FILE_BYTES:
            raise SandboxError(f"{p}: larger than {MAX_FILE_BYTES} bytes; not a body file")
        data = yaml.safe_load(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise SandboxError(f"{p}: no such body file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SandboxError(f"{p}: cannot read the body file ({exc})") from None
    except yaml.YAMLError as exc:
        raise SandboxError(f"{p}: not valid YAML ({str(exc).splitlines()[0]})") from None
    body = data.get("body") if isinstance(data, dict) else None
    if not isinstance(body, dict):
        raise SandboxError(f"{p}: a GarmentCode body file has a 'body:' mapping of "
                           "measurements in cm")  # fmt: skip
    return body


def _number(p: Path, body: dict, key: str, why: str = "needed for the mannequin") -> float:
    if key not in body:
        raise SandboxError(f"{p}: body.{key}: missing ({why})")
    v = body[key]
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise SandboxError(f"{p}: body.{key}: must be a finite number of cm, got {v!r}")
    return float(v)
