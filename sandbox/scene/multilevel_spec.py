"""A scene's ``[multilevel]`` table: run it coarse to fine (:mod:`sandbox.scene.multilevel`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from sandbox.errors import SandboxError


@dataclass(frozen=True)
class MultilevelSpec:
    """A scene's ``[multilevel]`` table: the coarse levels and how the finer ones settle."""

    coarse_edge_length_m: tuple[float, ...] = (0.06,)
    """Every cloth's mesh edge on each coarse level [m], coarsest first; each must be
    longer than the cloths' own edges."""
    coarse_damping_per_s: float | None = None
    """γ [1/s] of the coarsest level (None: the scene's ``[simulation] damping_per_s``)."""
    settle_damping_per_s: float = 60.0
    """γ [1/s] of every finer level: above critical for a cloth's slow swinging."""
    settle_inertia_scale: float = 4.0
    """Inertia of every finer level, in multiples of its mass (explicit scenes only)."""


def multilevel_from_table(t: dict, source: str) -> MultilevelSpec:
    """Check a ``[multilevel]`` table (as read from TOML; its keys are checked by the
    caller)."""
    where = "[multilevel]"
    spec = MultilevelSpec()

    def number(key, value, minimum, strict=True):
        ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
        if not ok or value < minimum or (strict and value == minimum):
            sign = ">" if strict else ">="
            raise SandboxError(f"{source}: {where} {key} must be a number {sign} {minimum}, "
                               f"got {value!r}")  # fmt: skip
        return float(value)

    edges = t.get("coarse_edge_length_m", list(spec.coarse_edge_length_m))
    edges = [edges] if isinstance(edges, int | float) else edges
    if not isinstance(edges, list) or not edges:
        raise SandboxError(f"{source}: {where} coarse_edge_length_m must be a number or a "
                           f"non-empty list of numbers")  # fmt: skip
    edges = tuple(number("coarse_edge_length_m", e, 0.0) for e in edges)
    if any(b >= a for a, b in zip(edges, edges[1:], strict=False)):
        raise SandboxError(f"{source}: {where} coarse_edge_length_m must be listed coarsest "
                           f"first, each shorter than the one before: {list(edges)}")  # fmt: skip
    damping = t.get("coarse_damping_per_s")
    return MultilevelSpec(
        coarse_edge_length_m=edges,
        coarse_damping_per_s=None if damping is None else number(
            "coarse_damping_per_s", damping, 0.0, strict=False),
        settle_damping_per_s=number("settle_damping_per_s",
                                    t.get("settle_damping_per_s", spec.settle_damping_per_s), 0.0),
        settle_inertia_scale=number("settle_inertia_scale",
                                    t.get("settle_inertia_scale", spec.settle_inertia_scale), 1.0,
                                    strict=False),
    )  # fmt: skip


def check_levels(spec) -> None:
    """Every coarse level must be coarser than every cloth of the scene ``spec``."""
    finest = max(c.edge_length_m for c in spec.cloths)
    coarse = spec.multilevel.coarse_edge_length_m
    if coarse[-1] <= finest:
        raise SandboxError(f"{spec.source}: [multilevel] coarse_edge_length_m {list(coarse)} "
                           f"must all be longer than the cloths' edge ({finest} m)")  # fmt: skip
