"""Smooth away cloth triangles that cross each other (placement start and sewn garments).

Continuous collision keeps cloth that does not intersect from starting to, but it never
undoes a crossing it is handed: once a triangle is through another, proximity and impact
tests only hold it there. Crossings come from outside the solver's guarantees: a placed
start pushed out of a crease (:func:`sandbox.pattern.placement.repair.untangle`), or a seam
zone, where the self-collider leaves a sewn vertex free against its partner's triangles so
the seam can close (:mod:`sandbox.collision.self_contact`), and a panel beside it can slip
through.

:func:`untangle_positions` is a local, geometric repair, in the spirit of the intersection
handling of Baraff, Witkin and Kass 2003 ("Untangling cloth") but far simpler: each round
takes the vertices of the crossing triangles and a few rings of neighbours (through mesh
edges and, if given, seam springs, so a junction moves as one), moves them half-way to the
mean of their neighbours a few times (Laplacian smoothing unfolds a fold), gives the edges
back their rest lengths, and pushes them out of the body again. The fewest crossings seen
win. Only positions are changed; the caller decides what happens to velocities.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

ROUNDS = 20
"""At most this many rounds ..."""
RINGS = 2
"""... each over the vertices of the crossing triangles and this many rings around them ..."""
SMOOTHING = 10
"""... smoothed this many times (each step half-way to the neighbours' mean) ..."""
RESTORE = 3
"""... then given back their edge lengths by this many Jacobi passes, in the first half of
the rounds (smoothing alone shrinks triangles: the T-shirt's sleeve caps kept some at 1 % of
their width); where that folds the cloth again, the second half goes on from the fewest
crossings without it."""


def edge_lengths_setup(triangles: np.ndarray, rest_xy: np.ndarray, n: int):
    """Unique edges (i, j) of a mesh, their rest lengths from the pattern coordinates
    ``rest_xy`` (n, 2) [m] and each vertex's edge count (n, 1), at least 1."""
    tri = np.asarray(triangles, np.int64)
    e = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    e = np.unique(e, axis=0)
    i, j = e[:, 0], e[:, 1]
    rest = np.linalg.norm(rest_xy[j] - rest_xy[i], axis=1)
    count = np.bincount(np.concatenate([i, j]), minlength=n).astype(float)[:, None]
    return i, j, rest, np.maximum(count, 1.0)


def edge_length_pass(x, i, j, rest, count) -> np.ndarray:
    """One Jacobi pass: the move (n, 3) [m] that takes both ends of every edge half-way to
    its rest length, averaged per vertex."""
    d = x[j] - x[i]
    length = np.maximum(np.linalg.norm(d, axis=1), 1e-12)
    c = (0.5 * (length - rest) / length)[:, None] * d  # move i by +c, j by -c
    dx = np.zeros_like(x)
    for k in range(3):
        dx[:, k] = np.bincount(i, c[:, k], len(x)) - np.bincount(j, c[:, k], len(x))
    return dx / count


def untangle_positions(
    x: np.ndarray,
    triangles: np.ndarray,
    rest_xy: np.ndarray,
    push_out: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
    *,
    seam_pairs: np.ndarray | None = None,
    rounds: int = ROUNDS,
    rings: int = RINGS,
) -> tuple[np.ndarray, int, int, np.ndarray]:
    """Cloth positions with their crossing triangle pairs smoothed away (the fewest found).

    Args:
        x: (n, 3) positions [m]. triangles: (m, 3) vertex indices.
        rest_xy: (n, 2) pattern coordinates [m]: each edge's rest length.
        push_out: ``push_out(x, mask) -> x``: moves the masked vertices out of the body
            (None: no body).
        seam_pairs: (s, 2) sewn vertex pairs: smoothed together like mesh edges; triangles
            joined through them (:func:`~sandbox.collision.metrics.seam_joined_pairs`) are
            not crossings, as in the metrics.
        rounds, rings: see :data:`ROUNDS`, :data:`RINGS`.
    Returns ``(x_new (n, 3), pairs_before, pairs_after, moved (n,) bool)``.
    """
    import scipy.sparse as sp

    from sandbox.collision.metrics import intersecting_pairs, seam_joined_pairs

    x = np.array(x, float)
    tri = np.asarray(triangles, np.int64)
    n = len(x)
    seams = np.zeros((0, 2), np.int64) if seam_pairs is None else np.asarray(seam_pairs, np.int64)
    seams = seams[seams[:, 0] != seams[:, 1]] if len(seams) else seams
    i, j, rest, count = edge_lengths_setup(tri, np.asarray(rest_xy, float), n)
    gi, gj = np.r_[i, seams[:, 0]], np.r_[j, seams[:, 1]]
    adj = sp.coo_matrix((np.ones(2 * len(gi)), (np.r_[gi, gj], np.r_[gj, gi])), shape=(n, n))
    adj = adj.tocsr()
    adj.data[:] = 1.0  # a seam along a mesh edge counts once
    degree = np.maximum(np.asarray(adj.sum(1)), 1.0)

    joined = seam_joined_pairs(seams, n) if len(seams) else None

    def crossing():
        return intersecting_pairs(x, tri, exclude_vertex_pairs=joined)

    pairs = crossing()
    before = len(pairs)
    best, fewest = x.copy(), before
    moved = np.zeros(n, bool)
    best_moved = moved.copy()
    for k in range(rounds):
        if len(pairs) == 0:
            break
        if k == rounds // 2 and fewest:  # the restoring refolds here: go on from the best
            x, moved = best.copy(), best_moved.copy()
            pairs = crossing()
        mask = np.zeros(n, bool)
        mask[tri[np.asarray(pairs).ravel()].ravel()] = True
        for _ in range(rings):
            mask |= adj @ mask.astype(float) > 0
        for _ in range(SMOOTHING):
            x[mask] = 0.5 * x[mask] + 0.5 * (adj @ x)[mask] / degree[mask]
        for _ in range(RESTORE if k < rounds // 2 else 0):  # triangle shapes back
            x[mask] += edge_length_pass(x, i, j, rest, count)[mask]
        if push_out is not None:
            x = push_out(x, mask)
        moved |= mask
        pairs = crossing()
        if len(pairs) < fewest:
            best, fewest, best_moved = x.copy(), len(pairs), moved.copy()
    return best, before, fewest, best_moved
