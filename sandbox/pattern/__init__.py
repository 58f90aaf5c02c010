"""Sewing patterns: the pattern file format, curved edges, panel meshes, seams, GarmentCode import.

The main entry points (see docs/pattern_format.md)::

    from sandbox.pattern import load_pattern, mesh_pattern, pattern_seam_sides

    pattern = load_pattern("garments/skirt.json")      # validated, lengths in metres
    meshes = mesh_pattern(pattern)                      # {panel name: PanelMesh}
"""

from sandbox.pattern.panel_mesh import PanelMesh, mesh_panel, mesh_pattern, pattern_seam_sides
from sandbox.pattern.spec import (
    Edge,
    Panel,
    Pattern,
    SeamSpec,
    load_pattern,
    rotation_matrix_xyz_deg,
    save_pattern,
)

__all__ = [
    "Edge",
    "Panel",
    "PanelMesh",
    "Pattern",
    "SeamSpec",
    "load_garmentcode",
    "load_pattern",
    "mesh_panel",
    "mesh_pattern",
    "pattern_seam_sides",
    "rotation_matrix_xyz_deg",
    "save_pattern",
]


def __getattr__(name):  # lazy, so `python -m sandbox.pattern.garmentcode` runs cleanly
    if name == "load_garmentcode":
        from sandbox.pattern.garmentcode import load_garmentcode

        return load_garmentcode
    raise AttributeError(f"module 'sandbox.pattern' has no attribute {name!r}")
