"""The public mannequin object: build by size or measurements, resize, measure.

>>> m = build_mannequin(size=12)                      # doctest: +SKIP
>>> m2 = m.resize(m.measurements_requested.replace(bust_girth=95.0))  # same triangles
"""

from __future__ import annotations

import dataclasses
from functools import lru_cache

import numpy as np

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

    def resize(self, measurements: Measurements) -> Mannequin:
        """§2.1.4 on the same structure: new vertex positions, same triangles."""
        return build_mannequin(measurements, resolution=self.resolution or DEFAULT_RESOLUTION)

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
) -> Mannequin:
    """Build a mannequin from measurements [cm] and/or a database size.

    With only ``size``, the stored size; with ``measurements``, §2.1.4 from the closest
    size (or from ``size`` if given). Raises :class:`SandboxError` for out-of-range or
    contradictory measurements.
    """
    table = load_size_table()
    if measurements is None:
        entry = size_entry(size if size is not None else 12, table)
        measurements = entry.measurements
    else:
        validate(measurements, flag_names=flag_names)
        entry = closest_size(measurements, table) if size is None else size_entry(size, table)
    return _build(measurements, entry, resolution)


def _build(target: Measurements, entry: SizeEntry, resolution: int) -> Mannequin:
    st = _structure(resolution)
    s = fit_shape(st.template, st.corrector, target, entry)
    v = st.template.evaluate(s)
    return Mannequin(
        vertices=v,
        triangles=st.template.faces,
        landmarks={k: v[i].copy() for k, i in st.landmarks.items()},
        feature_lines={k: v[i] for k, i in st.feature_lines.items()},
        measurements_requested=target,
        size=entry.size,
        resolution=resolution,
        shape=s,
    )
