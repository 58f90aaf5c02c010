"""Sewing patterns: the pattern file format, curved edges, panel meshes, seams, GarmentCode import.

The main entry points (see docs/pattern_format.md)::

    from sandbox.pattern import load_pattern, mesh_pattern, pattern_seam_sides

    pattern = load_pattern("tests/data/pattern_skirt.json")  # validated, lengths in metres
    meshes = mesh_pattern(pattern)  # {panel name: PanelMesh}

Names are imported lazily, so ``python -m sandbox.pattern.<module>`` runs cleanly.
"""

import importlib

_EXPORTS = {
    "Edge": "spec",
    "Panel": "spec",
    "Pattern": "spec",
    "SeamSpec": "spec",
    "load_pattern": "spec",
    "save_pattern": "spec",
    "rotation_matrix_xyz_deg": "spec",
    "PanelMesh": "panel_mesh",
    "mesh_panel": "panel_mesh",
    "mesh_pattern": "panel_mesh",
    "pattern_seam_sides": "panel_mesh",
    "load_garmentcode": "garmentcode",
    "PatternLimits": "limits",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name):
    if name in _EXPORTS:
        return getattr(importlib.import_module(f"sandbox.pattern.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module 'sandbox.pattern' has no attribute {name!r}")
