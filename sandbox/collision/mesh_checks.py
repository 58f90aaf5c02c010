"""Checks of the mesh and point arrays handed to the contact measures, and a mesh's edge
report (what keeps it from being closed). Bad input raises a one-line :class:`SandboxError`
naming the mesh and the problem."""

from __future__ import annotations

import numpy as np

from sandbox.errors import SandboxError


def mesh_arrays(vertices, triangles, what: str) -> tuple[np.ndarray, np.ndarray]:
    """(n, 3) float64 vertices and (m, 3) int64 triangles, checked."""
    try:
        v = np.asarray(vertices, dtype=np.float64)
        t = np.asarray(triangles)
    except (TypeError, ValueError) as exc:
        raise SandboxError(f"{what}: vertices/triangles are not numeric arrays ({exc})") from exc
    if v.ndim != 2 or v.shape[1] != 3:
        raise SandboxError(f"{what}: vertices must have shape (n, 3), got {v.shape}")
    if t.ndim != 2 or t.shape[1] != 3:
        raise SandboxError(f"{what}: triangles must have shape (m, 3), got {t.shape}")
    if t.size and not np.issubdtype(t.dtype, np.integer):
        if not np.array_equal(t, np.round(t)):
            raise SandboxError(f"{what}: triangle indices must be integers")
    t = t.astype(np.int64)
    if t.size and (t.min() < 0 or t.max() >= len(v)):
        raise SandboxError(
            f"{what}: a triangle refers to a missing vertex (indices {t.min()}..{t.max()}, "
            f"{len(v)} vertices)"
        )
    if not np.isfinite(v).all():
        raise SandboxError(f"{what}: vertices contain NaN or infinity")
    return v, t


def points_array(points, what: str) -> np.ndarray:
    p = np.asarray(points, dtype=np.float64)
    if p.ndim == 1 and p.shape == (3,):
        p = p[None]
    if p.ndim != 2 or p.shape[1] != 3:
        raise SandboxError(f"{what}: points must have shape (n, 3), got {p.shape}")
    if not np.isfinite(p).all():
        raise SandboxError(f"{what}: points contain NaN or infinity")
    return p


def pair_array(pairs, what: str, limit: int) -> np.ndarray:
    p = np.asarray(pairs)
    if p.size == 0:
        return np.zeros((0, 2), np.int64)
    if p.ndim != 2 or p.shape[1] != 2 or not np.issubdtype(p.dtype, np.integer):
        raise SandboxError(f"{what}: must be integer pairs of shape (k, 2), got {p.shape}")
    p = p.astype(np.int64)
    if p.min() < 0 or p.max() >= limit:
        raise SandboxError(f"{what}: an index is out of range 0..{limit - 1}")
    return p


def edge_report(triangles: np.ndarray, vertex_count: int) -> dict[str, int]:
    """Counts of what keeps a triangle mesh from being closed and consistently oriented.

    ``boundary_edges`` (used by one triangle), ``nonmanifold_edges`` (more than two),
    ``misoriented_edges`` (two triangles walking the edge in the same direction) and
    ``degenerate_triangles`` (a repeated vertex index). All zero for a closed mesh.
    """
    t = np.asarray(triangles, np.int64)
    degenerate = (t[:, 0] == t[:, 1]) | (t[:, 1] == t[:, 2]) | (t[:, 2] == t[:, 0])
    t = t[~degenerate]
    e = t[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    lo, hi = e.min(1), e.max(1)
    key = lo * np.int64(vertex_count) + hi
    _, inv, counts = np.unique(key, return_inverse=True, return_counts=True)
    forward = np.bincount(inv, weights=(e[:, 0] < e[:, 1]), minlength=len(counts))
    return {
        "boundary_edges": int(np.sum(counts == 1)),
        "nonmanifold_edges": int(np.sum(counts > 2)),
        "misoriented_edges": int(np.sum((counts == 2) & (forward != 1))),
        "degenerate_triangles": int(degenerate.sum()),
    }
