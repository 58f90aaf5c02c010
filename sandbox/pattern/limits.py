"""What a pattern file may hold and how large its mesh may get: one frozen settings object.

``load_pattern(path, limits=PatternLimits(...))`` and ``mesh_pattern(pattern,
limits=...)`` take it; the defaults suit garments on a human body (the library's panels are
3.5 cm to 1.1 m across) and a machine with a few GB of memory.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class PatternLimits:
    """Limits and plausibility thresholds of pattern files (lengths in metres).

    Refused (a SandboxError): a file over ``max_file_bytes``; a panel with more than
    ``max_panel_vertices`` corners or edges; a coordinate farther than ``max_coordinate_m``
    from the origin; a panel wider or taller than ``max_panel_extent_m`` (60 m panels come
    from centimetres read as metres); a mesh estimated at more than ``max_mesh_vertices``
    vertices over all panels.

    Warned (``logging``, logger ``sandbox.pattern``): a pattern whose largest panel is
    under ``min_pattern_extent_m`` across (millimetres read as centimetres, centimetres as
    millimetres); a panel under ``min_panel_extent_m``; a seam whose two sides differ by
    more than ``seam_mismatch_m`` and by more than ``seam_mismatch_ratio`` of the longer
    side (ease and gathers aside, a drafting or units mistake).
    """

    max_file_bytes: int = 20_000_000
    max_panel_vertices: int = 20_000
    max_coordinate_m: float = 100.0
    max_panel_extent_m: float = 4.0
    min_pattern_extent_m: float = 0.10
    min_panel_extent_m: float = 0.01
    seam_mismatch_m: float = 0.06
    seam_mismatch_ratio: float = 0.10
    max_mesh_vertices: int = 1_000_000

    def __post_init__(self):
        for name, value in self.__dict__.items():
            if not (isinstance(value, (int, float)) and value > 0):
                raise ValueError(f"PatternLimits.{name} must be a positive number, got {value!r}")


DEFAULT_LIMITS = PatternLimits()
