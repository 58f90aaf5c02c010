"""Parametric mannequin after Leong, Kuo and Fang (2011), §2.1.

A structured smooth dress form (torso, neck stub, arms in an A-pose, legs) whose rows and
columns are the tailor's feature lines, resized by the paper's seven measurements
(§2.1.4) from a size database built from Aldrich's size table, with a tape measure that
checks every resize. Metres inside, centimetres for measurements.
"""

from sandbox.mannequin.io import load_body_mesh, write_mannequin
from sandbox.mannequin.measurements import (
    KEYS,
    SUPPORTED_RANGE_CM,
    Measurements,
    SizeEntry,
    closest_size,
    load_size_table,
    validate,
)
from sandbox.mannequin.model import DEFAULT_RESOLUTION, Mannequin, build_mannequin, measure

__all__ = [
    "DEFAULT_RESOLUTION",
    "KEYS",
    "SUPPORTED_RANGE_CM",
    "Mannequin",
    "Measurements",
    "SizeEntry",
    "build_mannequin",
    "closest_size",
    "load_body_mesh",
    "load_size_table",
    "measure",
    "validate",
    "write_mannequin",
]
