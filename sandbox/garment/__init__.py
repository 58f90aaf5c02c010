"""Garments on the mannequin: build, sew, repair, measure and write a drape.

Data flows one way: pattern + mannequin -> :func:`build_drape` (a Scene with its
:class:`GarmentContext`) -> :func:`run_drape` (sew, untangle, drape to the stop rule) ->
:func:`drape_metrics` -> :func:`write_drape`; :func:`drape` does all of it. Every setting is
in one :class:`DrapeConfig` (with its :class:`SewingConfig`, :class:`RepairConfig` and
:class:`AcceptanceConfig`).
"""

from sandbox.garment.build import GarmentContext, build_drape, seam_springs
from sandbox.garment.config import (
    AcceptanceConfig,
    DrapeConfig,
    RepairConfig,
    SewingConfig,
    default_edge_m,
)
from sandbox.garment.inputs import check_garment, garment_names, make_mannequin, resolve_pattern
from sandbox.garment.metrics import drape_metrics, meets_acceptance
from sandbox.garment.output import write_drape
from sandbox.garment.pipeline import DrapeResult, drape, run_drape

__all__ = [
    "AcceptanceConfig",
    "DrapeConfig",
    "DrapeResult",
    "GarmentContext",
    "RepairConfig",
    "SewingConfig",
    "build_drape",
    "check_garment",
    "default_edge_m",
    "drape",
    "drape_metrics",
    "garment_names",
    "make_mannequin",
    "meets_acceptance",
    "resolve_pattern",
    "run_drape",
    "seam_springs",
    "write_drape",
]
