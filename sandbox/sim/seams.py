"""Seams as springs (paper §2.4, Fig. 5).

Two seam lines, each made of one or more pattern edges merged into one continuous line,
are joined by springs:

* **Direction (Fig. 5a).** With P1, P2 the ends of line A and P3, P4 the ends of line B,
  placed in the world: if L1 + L2 < L3 + L4 (L1 = |P1P3|, L2 = |P2P4|, L3 = |P1P4|,
  L4 = |P2P3|) then P1 is sewn to P3 and P2 to P4; otherwise B is reversed.
* **Parametric matching (Fig. 5b).** Both lines are parametrised by arc length on [0, 1].
  Each point t_i of the line with fewer points is joined to the point s_j of the other
  line with s_j = t_i by a zero-length spring, or, when s_j < t_i < s_j+1, to s_j and
  s_j+1 with rest lengths L (t_i − s_j) and L (s_j+1 − t_i), L = min(L1, L2) the length
  the seam has once sewn (a longer side is gathered to the shorter): the two rest lengths
  then add up to the gathered segment, and the point stays on the other line.

Everything here is numpy; the builder turns the springs into Taichi fields.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sandbox.errors import SandboxError

PARAM_TOL = 1e-6


@dataclass
class SeamLine:
    """Particle indices along a seam line (in order) and their arc-length parameters."""

    particles: np.ndarray  # (k,) int, global particle indices
    rest_xy: np.ndarray  # (k, 2) pattern coordinates [m]

    @property
    def length(self) -> float:
        return float(np.linalg.norm(np.diff(self.rest_xy, axis=0), axis=1).sum())

    @property
    def params(self) -> np.ndarray:
        seg = np.linalg.norm(np.diff(self.rest_xy, axis=0), axis=1)
        s = np.concatenate([[0.0], np.cumsum(seg)])
        return s / max(s[-1], 1e-30)

    def reversed(self) -> SeamLine:
        return SeamLine(self.particles[::-1].copy(), self.rest_xy[::-1].copy())


def edge_vertices(uv: np.ndarray, a, b, *, where: str) -> np.ndarray:
    """Indices of the mesh vertices on the pattern segment a -> b, ordered from a to b."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    d = b - a
    length = float(np.linalg.norm(d))
    if length == 0:
        raise SandboxError(f"{where}: the edge has zero length")
    rel = uv - a
    t = rel @ d / length**2
    off = np.abs(rel[:, 0] * d[1] - rel[:, 1] * d[0]) / length
    tol = 1e-7 * max(length, 1.0)
    on = np.nonzero((off <= tol) & (t >= -1e-9) & (t <= 1 + 1e-9))[0]
    if len(on) < 2:
        raise SandboxError(f"{where}: fewer than 2 mesh vertices lie on the edge")
    return on[np.argsort(t[on], kind="stable")]


def merge_lines(parts: list[tuple[np.ndarray, np.ndarray]]) -> SeamLine:
    """Join several (particles, rest_xy) edge lines into one continuous line (§2.4).

    Consecutive edges that share an end particle are joined at it; otherwise they are
    simply concatenated in the given order (the parameter then jumps by the gap, which the
    paper's method also implies).
    """
    particles, xy = [], []
    for p, q in parts:
        if particles and particles[-1][-1] == p[0]:
            p, q = p[1:], q[1:]
        particles.append(p)
        xy.append(q)
    return SeamLine(np.concatenate(particles), np.concatenate(xy))


def seam_direction_same(world_a: np.ndarray, world_b: np.ndarray) -> bool:
    """Fig. 5(a): True to sew P1-P3 and P2-P4, False to sew P1-P4 and P2-P3.

    ``world_a`` = (P1, P2) and ``world_b`` = (P3, P4), the world positions of the ends.
    """
    p1, p2 = world_a
    p3, p4 = world_b
    l1, l2 = np.linalg.norm(p1 - p3), np.linalg.norm(p2 - p4)
    l3, l4 = np.linalg.norm(p1 - p4), np.linalg.norm(p2 - p3)
    return bool(l1 + l2 < l3 + l4)


def match_springs(a: SeamLine, b: SeamLine) -> tuple[np.ndarray, np.ndarray]:
    """Fig. 5(b): springs between two seam lines already running the same way.

    Returns ``(pairs (s, 2) int, rest_lengths (s,) [m])``.
    """
    short, long_ = (a, b) if len(a.particles) <= len(b.particles) else (b, a)
    t, s = short.params, long_.params
    # a point between two of the other line's is held at the distances the seam has once
    # sewn: the shorter line's length, to which a longer side is gathered (with the mean,
    # a gathered side's points, closer than their rest lengths, push the point off the line)
    sewn_len = min(a.length, b.length)
    pairs, rest = [], []
    for i, ti in enumerate(t):
        j = int(np.searchsorted(s, ti))
        if j < len(s) and abs(s[j] - ti) <= PARAM_TOL:
            pair = (short.particles[i], long_.particles[j])
            if not pairs or pairs[-1] != pair:  # a collapsed edge repeats its one vertex
                pairs.append(pair)
                rest.append(0.0)
        elif j > 0 and j - 1 < len(s) and abs(s[j - 1] - ti) <= PARAM_TOL:
            pair = (short.particles[i], long_.particles[j - 1])
            if not pairs or pairs[-1] != pair:
                pairs.append(pair)
                rest.append(0.0)
        else:
            j = min(max(j, 1), len(s) - 1)
            pairs.append((short.particles[i], long_.particles[j - 1]))
            rest.append(sewn_len * (ti - s[j - 1]))
            pairs.append((short.particles[i], long_.particles[j]))
            rest.append(sewn_len * (s[j] - ti))
    return np.asarray(pairs, np.int64), np.asarray(rest, np.float64)


def sew(a: SeamLine, b: SeamLine, world: np.ndarray, direction: str = "auto"):
    """Springs for one seam: direction by Fig. 5(a) (or forced), matching by Fig. 5(b).

    ``world`` (n, 3) are the particles' initial (placed) positions. Returns
    ``(pairs, rest_lengths, reversed_b)``.
    """
    if direction == "auto":
        same = seam_direction_same(
            world[[a.particles[0], a.particles[-1]]], world[[b.particles[0], b.particles[-1]]]
        )
    else:
        same = direction == "same"
    bb = b if same else b.reversed()
    pairs, rest = match_springs(a, bb)
    return pairs, rest, not same


def partner_points(pairs: np.ndarray, rest: np.ndarray):
    """Each spring's partner point on the other line, as :func:`match_springs` emits them:
    a point between s_j and s_j+1 has two springs, one after the other (same first
    particle, both rest lengths > 0); its partner is (1 − w) x_j + w x_j+1 with
    w = r_1 / (r_1 + r_2). Returns ``(first, second, b2, w)``, each (k,): whether a spring
    is the first or the second of such a twin, and for a first, the other line's second
    particle and w (b2 = the spring's own partner and w = 0 otherwise)."""
    p = np.asarray(pairs, np.int64).reshape(-1, 2)
    r = np.asarray(rest, float).reshape(-1)
    first = np.zeros(len(p), bool)
    if len(p) > 1:
        first[:-1] = (r[:-1] > 0.0) & (r[1:] > 0.0) & (p[:-1, 0] == p[1:, 0])
    second = np.zeros(len(p), bool)
    second[1:] = first[:-1]
    b2 = np.where(first, np.roll(p[:, 1], -1), p[:, 1])
    w = np.where(first, r / np.maximum(r + np.roll(r, -1), 1e-300), 0.0)
    return first, second, b2, w


def seam_openings(pairs: np.ndarray, rest: np.ndarray, x: np.ndarray) -> np.ndarray:
    """How far apart a seam's two sides are at each spring [m], (k,) for ``pairs`` (k, 2),
    ``rest`` (k,) [m] and positions ``x`` (n, 3) [m].

    The gap of Fig. 5(b)'s matching: at each point t_i of the shorter line, its distance to
    the point of equal parameter on the other line. A zero-length spring's gap is its
    length. A point between s_j and s_j+1 has two springs, emitted one after the other by
    :func:`match_springs` (same first particle, both rest lengths > 0); its partner point
    is s_j + w (s_j+1 − s_j) with w = r_1 / (r_1 + r_2), and both springs get that gap.
    Their stretch beyond the rest lengths is not the gap: it counts the other line's own
    strain along the seam as an opening (a 3 cm edge stretched 9 % "opens" 2.7 mm with the
    point on it) and hardly sees the point leaving the line sideways (d²/2r). A spring
    without a twin (not from :func:`match_springs`) keeps its stretch.
    """
    p = np.asarray(pairs, np.int64).reshape(-1, 2)
    r = np.asarray(rest, float).reshape(-1)
    length = np.linalg.norm(x[p[:, 0]] - x[p[:, 1]], axis=1)
    gap = np.where(r > 0.0, length - r, length)
    first, _, b2, w = partner_points(p, r)
    twin = np.flatnonzero(first)
    q = (1.0 - w[twin, None]) * x[p[twin, 1]] + w[twin, None] * x[b2[twin]]
    gap[twin] = gap[twin + 1] = np.linalg.norm(x[p[twin, 0]] - q, axis=1)
    return gap


def set_seam_springs(model, pairs, rest, stiffness) -> None:
    """Replace a running model's seam springs (click-to-sew, undo, clear).

    Args:
        model: a :class:`~sandbox.sim.model.Model` finalised with enough ``seam_capacity``.
        pairs: (k, 2) int particle indices; rest: (k,) rest lengths [m];
        stiffness: (k,) spring stiffnesses [N/m].
    The solvers' kernels read the live count, so nothing recompiles; the self-collider (if
    any) stops treating the newly sewn pairs as contacts. Raises SandboxError on indices
    out of range, a pair sewn to itself, negative or non-finite values, or too many springs.
    """
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    rest = np.asarray(rest, dtype=float).reshape(-1)
    stiffness = np.asarray(stiffness, dtype=float).reshape(-1)
    k = len(pairs)
    if len(rest) != k or len(stiffness) != k:
        raise SandboxError(f"seam springs: {k} pairs but {len(rest)} rest lengths and "
                           f"{len(stiffness)} stiffnesses")  # fmt: skip
    if not model.has_seams or k > model.seam_capacity:
        raise SandboxError(f"seam springs: {k} springs do not fit the model's capacity of "
                           f"{model.seam_capacity} (finalize(seam_capacity=...))")  # fmt: skip
    n = model.particle_count
    if k and (pairs.min() < 0 or pairs.max() >= n):
        raise SandboxError(f"seam springs: particle index out of range 0..{n - 1}")
    if np.any(pairs[:, 0] == pairs[:, 1]):
        raise SandboxError("seam springs: a particle is sewn to itself")
    bad = ~np.isfinite(rest) | (rest < 0) | ~np.isfinite(stiffness) | (stiffness < 0)
    if np.any(bad):
        raise SandboxError(f"seam springs: spring {int(np.argmax(bad))} has a negative or "
                           f"non-finite rest length or stiffness")  # fmt: skip
    model.set_seams(pairs, rest, stiffness)
    if model.self_collider is not None:
        model.self_collider.set_seam_partners(model.seam_pairs_np)
