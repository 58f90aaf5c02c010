"""Gathered seams: a seam side much longer than the other is drawn in to its length.

A bodice 28.7 cm wide sewn to a skirt waist of 22 cm (GarmentCode's pencil dress) is
gathered: the dressmaker runs a thread along the longer edge and pulls it to the shorter
one, and the fabric beside the seam packs into small folds. The paper's seams match their
sides by parameter (Fig. 5b), so the springs pull the longer side onto the shorter one,
but the cloth resists being compressed along the seam as much as being stretched (Eq. 7),
and the seam stays millimetres open. Folds a few millimetres wide cannot be drawn on a
1-3 cm mesh; what they do can: the gathered side's *rest shape* is drawn in along the
seam, as the thread does, over a band beside it, so the cloth there is at rest when the
seam is closed. The band's mass and its texture coordinates stay the cut's (the fabric is
all there, packed), only Eq. 6's rest shape changes.

A side counts as gathered when it is more than :attr:`GatherSettings.min_ratio` times the
other's length and longer by more than :attr:`GatherSettings.min_excess_m` (sleeve-cap
ease is 2-5 %); the library's garments have none.
"""

import math
from dataclasses import dataclass, fields

import numpy as np

from sandbox.errors import SandboxError


@dataclass(frozen=True)
class GatherSettings:
    """When a seam side is gathered, and over how wide a band (:mod:`sandbox.pattern.gather`)."""

    min_ratio: float = 1.10
    """A side longer than the other by this factor or more is gathered."""
    min_excess_m: float = 0.02
    """... and by at least this much [m] (short edges differ by a mesh edge's rounding)."""
    band_per_shift: float = 4.0
    """The band beside the seam over which the rest shape is drawn in is this many times the
    largest distance a point of the edge moves (at most 25 % shear in the band) ..."""
    min_band_edges: float = 3.0
    """... and at least this many mesh edges wide."""

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            low = 1.0 if f.name == "min_ratio" else 0.0
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) \
                    or v <= low:  # fmt: skip
                raise SandboxError(f"GatherSettings.{f.name} must be a number > {low:g}, got {v!r}")


@dataclass(frozen=True)
class Gather:
    """One gathered seam side: ``seam`` (index), ``side`` ("a" or "b"), ``edges`` [(panel,
    edge index)], its length and the other side's [m]."""

    seam: int
    side: str
    edges: tuple
    length_m: float
    to_m: float

    @property
    def ratio(self) -> float:
        """The other side's length over this one's (< 1)."""
        return self.to_m / self.length_m

    def describe(self, pattern) -> str:
        """One line for the log and the metrics."""
        names = ", ".join(f"{p}.{pattern.panels[p].edges[k].name}" for p, k in self.edges)
        return (f"seam #{self.seam} side {self.side} ({names}) gathered from "
                f"{self.length_m * 100:.1f} to {self.to_m * 100:.1f} cm")  # fmt: skip


def _polyline(meshes, pname: str, k: int) -> np.ndarray:
    mesh = meshes[pname]
    return mesh.points[mesh.edge_vertices[k]]


def gathered_sides(pattern, settings: GatherSettings = GatherSettings()) -> list:
    """The pattern's gathered seam sides, :class:`Gather` each (lengths along the pattern's
    edges, curves included)."""
    out = []
    for i, (s, (la, lb)) in enumerate(zip(pattern.seams, pattern.seam_lengths_m(), strict=True)):
        for name, side, long, short in (("a", s.side_a, la, lb), ("b", s.side_b, lb, la)):
            if (short > 0.0 and long >= settings.min_ratio * short
                    and long - short >= settings.min_excess_m):  # fmt: skip
                out.append(Gather(i, name, tuple((p, int(k)) for p, k in side), long, short))
    return out


def gathered_rest(meshes, gathers, edge_length_m: float,
                  settings: GatherSettings = GatherSettings()) -> dict:  # fmt: skip
    """Rest coordinates (n, 2) [m] of every panel with a gathered edge, by panel name.

    Each gathered edge (a polyline of arc length L) is drawn in by the ratio r about its
    middle: a point at arc length s moves by (r − 1)(s − L/2) along the edge's tangent
    there. Points of the panel within the band w of the edge move by the same, weighted by
    a smoothstep of 1 − d/w (d: distance to the edge), so the rest shape stays a smooth,
    unfolded map of the cut. w = max(``band_per_shift`` × the largest move,
    ``min_band_edges`` × the mesh edge).
    """
    out: dict[str, np.ndarray] = {}
    for g in gathers:
        for pname, k in g.edges:
            p0 = meshes[pname].points
            rest = out.setdefault(pname, p0.copy())
            line = _polyline(meshes, pname, k)
            seg = np.diff(line, axis=0)
            seg_len = np.linalg.norm(seg, axis=1)
            s0 = np.concatenate([[0.0], np.cumsum(seg_len)])
            total = s0[-1]
            if total <= 0.0:
                continue
            shift_max = (1.0 - g.ratio) * 0.5 * total
            band = max(settings.band_per_shift * shift_max, settings.min_band_edges * edge_length_m)
            # closest point of each panel point on each segment
            d = p0[:, None, :] - line[None, :-1, :]
            t = np.clip(np.einsum("nsk,sk->ns", d, seg) / np.maximum(seg_len**2, 1e-30), 0, 1)
            foot = line[None, :-1, :] + t[..., None] * seg[None]
            dist = np.linalg.norm(p0[:, None, :] - foot, axis=2)
            j = np.argmin(dist, axis=1)
            rows = np.arange(len(p0))
            dmin = dist[rows, j]
            s = s0[j] + t[rows, j] * seg_len[j]
            tangent = seg[j] / np.maximum(seg_len[j], 1e-30)[:, None]
            x = np.clip(1.0 - dmin / band, 0.0, 1.0)
            weight = x * x * (3.0 - 2.0 * x)
            rest += (weight * (g.ratio - 1.0) * (s - 0.5 * total))[:, None] * tangent
    return out
