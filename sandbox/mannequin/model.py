"""The public mannequin object: build by size or measurements, resize, measure.

>>> m = build_mannequin(size=12)                      # doctest: +SKIP
>>> m2 = m.resize(m.measurements_requested.replace(bust_girth=95.0))  # same triangles
"""

from __future__ import annotations

import dataclasses
import math
from functools import lru_cache

import numpy as np

from sandbox.errors import SandboxError
from sandbox.mannequin import tape
from sandbox.mannequin.measurements import (
    Measurements,
    SizeEntry,
    closest_size,
    load_size_table,
    size_entry,
    validate,
)
from sandbox.mannequin.resize import Corrector, fit_shape
from sandbox.mannequin.shape import BodyShape, shape_from_size
from sandbox.mannequin.surface import BodyTemplate

DEFAULT_RESOLUTION = 48  # torso columns; 48 -> ~17k triangles, 64 -> ~29k
#: the arm pose a mannequin can be built in: the arms' angle from the vertical [deg]
ARM_ANGLE_RANGE_DEG = (16.0, 55.0)
BASE_SIZE = 14  # the template's topology is fixed on this database size


@dataclasses.dataclass
class _Structure:
    template: BodyTemplate
    corrector: Corrector
    landmarks: dict[str, int]
    feature_lines: dict[str, np.ndarray]


@lru_cache(maxsize=4)
def _structure(resolution: int) -> _Structure:
    table = load_size_table()
    base_entry = min(table, key=lambda e: abs(e.size - BASE_SIZE))
    extremes = (shape_from_size(table[0]), shape_from_size(table[-1]))
    template = BodyTemplate(shape_from_size(base_entry), resolution, samples=extremes)
    lm = template.landmark_indices()
    return _Structure(template, Corrector(template, lm), lm, template.feature_line_indices())


@dataclasses.dataclass
class Mannequin:
    """A mannequin mesh with its landmarks and feature lines.

    ``vertices`` (n, 3) float64 [m], ``triangles`` (m, 3) int64 (watertight, outward),
    ``landmarks`` name -> (3,) [m], ``feature_lines`` name -> (k, 3) polyline [m] (closed
    lines repeat their first point), ``measurements_requested`` the seven targets [cm],
    ``size`` the closest database size the resize started from.
    """

    vertices: np.ndarray
    triangles: np.ndarray
    landmarks: dict[str, np.ndarray]
    feature_lines: dict[str, np.ndarray]
    measurements_requested: Measurements
    size: int | None
    resolution: int
    shape: BodyShape | None
    head_length_cm: float | None = None
    """The head's crown above the nape [cm] (:mod:`sandbox.mannequin.head`); None: no head,
    the neck ends in a cap."""

    @property
    def arm_angle_deg(self) -> float | None:
        """The smallest angle of the arms from the vertical it was built with [deg] (the arms
        open further where they would come closer to the torso than their clearance)."""
        return None if self.shape is None else math.degrees(self.shape.arm_angle)

    def resize(self, measurements: Measurements) -> Mannequin:
        """§2.1.4 on the same structure: new vertex positions, same triangles, same pose."""
        return build_mannequin(measurements, resolution=self.resolution or DEFAULT_RESOLUTION,
                               arm_angle_deg=self.arm_angle_deg,
                               head_length_cm=self.head_length_cm)  # fmt: skip

    def measure(self) -> dict[str, float]:
        """The tape measure on this mesh, with its own landmarks [cm]."""
        return measure(self.vertices, self.triangles, self.landmarks)


def measure(vertices, triangles, landmarks: dict | None = None) -> dict[str, float]:
    """The tape measure (see :mod:`sandbox.mannequin.tape`): seven values [cm]."""
    return tape.measure(vertices, triangles, landmarks)


def build_mannequin(
    measurements: Measurements | None = None,
    *,
    size: int | None = None,
    resolution: int = DEFAULT_RESOLUTION,
    flag_names: dict[str, str] | None = None,
    arm_angle_deg: float | None = None,
    head_length_cm: float | None = None,
) -> Mannequin:
    """Build a mannequin from measurements [cm] and/or a database size.

    With only ``size``, the stored size; with ``measurements``, §2.1.4 from the closest
    size (or from ``size`` if given). ``arm_angle_deg``: the arms' angle from the vertical
    (within :data:`ARM_ANGLE_RANGE_DEG`; default the A-pose's 16°, opened further until
    the arms clear the torso). ``head_length_cm``: a head on the neck, its crown this far
    above the nape (within :data:`~sandbox.mannequin.head.HEAD_LENGTH_RANGE_CM`; default
    none). Raises :class:`SandboxError` for out-of-range or contradictory measurements, or
    an arm angle or head length out of range.
    """
    from sandbox.mannequin.head import HEAD_LENGTH_RANGE_CM

    if head_length_cm is not None:
        lo, hi = HEAD_LENGTH_RANGE_CM
        if not (lo <= float(head_length_cm) <= hi):
            raise SandboxError(f"head length {head_length_cm!r} cm: the mannequin's head "
                               f"can be {lo:g}-{hi:g} cm from nape to crown")  # fmt: skip
    if arm_angle_deg is not None:
        lo, hi = ARM_ANGLE_RANGE_DEG
        if not (lo <= float(arm_angle_deg) <= hi):
            raise SandboxError(f"arm angle {arm_angle_deg!r} deg: the mannequin's arms can be "
                               f"posed at {lo:g}-{hi:g} deg from the vertical")  # fmt: skip
    table = load_size_table()
    if measurements is None:
        entry = size_entry(size if size is not None else 12, table)
        measurements = entry.measurements
    else:
        validate(measurements, flag_names=flag_names)
        entry = closest_size(measurements, table) if size is None else size_entry(size, table)
    return _build(measurements, entry, resolution, arm_angle_deg, head_length_cm)


def _build(target: Measurements, entry: SizeEntry, resolution: int,
           arm_angle_deg: float | None = None,
           head_length_cm: float | None = None) -> Mannequin:  # fmt: skip
    st = _structure(resolution)
    s = fit_shape(st.template, st.corrector, target, entry)
    if arm_angle_deg is not None:  # the arms only: the torso's measurements stay
        s = s.copy(arm_angle=math.radians(float(arm_angle_deg)))
    v = st.template.evaluate(s)
    faces = st.template.faces
    if head_length_cm is not None:  # a closed surface of its own, after the body's
        from sandbox.mannequin.head import head_mesh

        hv, hf = head_mesh(s, float(head_length_cm) / 100.0)
        faces = np.concatenate([faces, hf + len(v)])
        v = np.concatenate([v, hv])
    return Mannequin(
        vertices=v,
        triangles=faces,
        landmarks={k: v[i].copy() for k, i in st.landmarks.items()},
        feature_lines={k: v[i] for k, i in st.feature_lines.items()},
        measurements_requested=target,
        size=entry.size,
        resolution=resolution,
        shape=s,
        head_length_cm=None if head_length_cm is None else float(head_length_cm),
    )
