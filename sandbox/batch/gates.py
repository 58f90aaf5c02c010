"""Quality gates of a batch drape: which checks a finished drape fails, and why.

Each gate reads numbers the drape already measured (its metrics.json,
:func:`sandbox.garment.metrics.drape_metrics`) against a threshold of
:class:`GateThresholds`; the defaults are :class:`~sandbox.garment.config.AcceptanceConfig`'s,
so with them a drape passes every gate exactly when ``meets_acceptance`` is true (the
``time_limit`` gate aside, which such a drape fails as ``not_at_rest`` would).

=======================  =====================================================================
gate                     rejected when
=======================  =====================================================================
not_at_rest              the stop rule did not hold (``converged`` false) before the simulated
                         time limit
seams_open               ``seam_gap_max_m`` > ``seam_gap_m``
cloth_inside_body        ``penetration_max_m`` > ``penetration_m`` (or not measured)
body_through_cloth       ``body_through_cloth_max_m`` > ``body_through_m``
intersecting_triangles   ``intersecting_triangle_pairs`` > ``max_intersecting_pairs``
slid_off                 ``top_below_anchor_m`` > ``slide_tolerance_m`` (the top ended that
                         far below the landmark the garment hangs from)
rolled_up                ``folded_area_pct`` > ``fold_tolerance_pct`` (or NaN)
nan_positions            any vertex position is NaN
time_limit               the drape was stopped by the task's wall-clock limit, or its worker
                         was killed past ``kill_after_s``
=======================  =====================================================================
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, fields

from sandbox.errors import SandboxError
from sandbox.garment.config import AcceptanceConfig

GATES = (
    "not_at_rest",
    "seams_open",
    "cloth_inside_body",
    "body_through_cloth",
    "intersecting_triangles",
    "slid_off",
    "rolled_up",
    "nan_positions",
    "time_limit",
)
"""Every gate, in the order reports list them."""

WALL_CLOCK_REASON = "wall-clock limit"
"""``stop_reason`` of a drape stopped by its wall-clock limit (:func:`sandbox.scene.run`)."""

_DEFAULT = AcceptanceConfig()


@dataclass(frozen=True)
class GateThresholds:
    """Thresholds of the quality gates (``[gates]`` in a batch spec); defaults from
    :class:`~sandbox.garment.config.AcceptanceConfig`. A drape is accepted when it passes
    every gate."""

    seam_gap_m: float = _DEFAULT.seam_gap_m
    """``seams_open``: largest distance between a seam's two sides [m]."""
    penetration_m: float = _DEFAULT.penetration_m
    """``cloth_inside_body``: deepest cloth vertex inside the body [m]."""
    body_through_m: float = _DEFAULT.body_through_m
    """``body_through_cloth``: deepest body vertex through the cloth [m]."""
    max_intersecting_pairs: int = 0
    """``intersecting_triangles``: most crossing cloth triangle pairs allowed."""
    slide_tolerance_m: float = _DEFAULT.slide_tolerance_m
    """``slid_off``: the garment's top may end this far [m] below its anchor landmark."""
    fold_tolerance_pct: float = _DEFAULT.fold_tolerance_pct
    """``rolled_up``: largest share of the area [%] that may end turned over."""

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "max_intersecting_pairs":
                if isinstance(v, bool) or not isinstance(v, int) or v < 0:
                    raise SandboxError(f"{f.name} must be a whole number >= 0, got {v!r}")
            elif (
                isinstance(v, bool)
                or not isinstance(v, int | float)
                or not (v > 0 and math.isfinite(v))
            ):
                raise SandboxError(f"{f.name} must be a positive number, got {v!r}")

    def acceptance(self) -> AcceptanceConfig:
        """The drape's :class:`AcceptanceConfig` with these thresholds (so metrics.json's
        ``slid_off``, ``rolled_up`` and ``meets_acceptance`` use them too)."""
        return AcceptanceConfig(seam_gap_m=self.seam_gap_m, penetration_m=self.penetration_m,
                                body_through_m=self.body_through_m,
                                slide_tolerance_m=self.slide_tolerance_m,
                                fold_tolerance_pct=self.fold_tolerance_pct)  # fmt: skip


def gates_from_table(table, where: str) -> GateThresholds:
    """:class:`GateThresholds` from a spec's ``[gates]`` table; a SandboxError naming
    ``where`` and the key for an unknown key or a bad value."""
    if not isinstance(table, dict):
        raise SandboxError(f"{where}: must be a table of thresholds, got {table!r}")
    names = [f.name for f in fields(GateThresholds)]
    unknown = sorted(set(table) - set(names))
    if unknown:
        raise SandboxError(f"{where}.{unknown[0]}: unknown threshold; known: {', '.join(names)}")
    for key, value in table.items():
        try:
            dataclasses.replace(GateThresholds(), **{key: value})
        except SandboxError as exc:
            raise SandboxError(f"{where}.{key}: {str(exc).split(' ', 1)[1]}") from None
    return GateThresholds(**table)


def _above(value, limit: float) -> bool:
    """True when ``value`` is above ``limit`` or not a finite number."""
    return not (isinstance(value, int | float) and math.isfinite(value) and value <= limit)


def failed_gates(m: dict, gates: GateThresholds, *, killed: bool = False) -> list[str]:
    """The gates (names from :data:`GATES`, in that order) a drape's metrics ``m`` fail;
    ``killed``: its worker was killed at the hard limit (only ``time_limit`` then)."""
    if killed:
        return ["time_limit"]
    out = []
    stopped_by_wall = m.get("stop_reason") == WALL_CLOCK_REASON
    if not m.get("converged") and not stopped_by_wall:
        out.append("not_at_rest")
    gap = m.get("seam_gap_max_m")
    if gap is not None and _above(gap, gates.seam_gap_m):
        out.append("seams_open")
    if _above(m.get("penetration_max_m"), gates.penetration_m):
        out.append("cloth_inside_body")
    through = m.get("body_through_cloth_max_m")
    if through is not None and _above(through, gates.body_through_m):
        out.append("body_through_cloth")
    if _above(m.get("intersecting_triangle_pairs"), gates.max_intersecting_pairs):
        out.append("intersecting_triangles")
    if _above(m.get("top_below_anchor_m"), gates.slide_tolerance_m):
        out.append("slid_off")
    if _above(m.get("folded_area_pct"), gates.fold_tolerance_pct):
        out.append("rolled_up")
    if m.get("nan_positions", 0):
        out.append("nan_positions")
    if stopped_by_wall:
        out.append("time_limit")
    return out
