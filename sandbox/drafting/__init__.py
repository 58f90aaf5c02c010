"""Garment drafting (Aldrich-style blocks) for the paper's Fig. 7 library of 14 garments.

``draft(name, measurements)`` returns a ``sandbox-pattern/1`` dict (cm) fitted to the body;
the garment definitions are data in ``garments/<name>.json``.
"""

from sandbox.drafting.body import BodyDims, body_dims
from sandbox.drafting.garments import (
    GarmentDef,
    draft,
    garment_from_dict,
    garment_names,
    load_garment,
)

__all__ = [
    "BodyDims",
    "GarmentDef",
    "body_dims",
    "draft",
    "garment_from_dict",
    "garment_names",
    "load_garment",
]
