"""Lofting: a cubic Hermite (Bessel-tangent) spline through key rows, as a fixed linear map.

A body part is a stack of key rows (closed cross-sections sampled at the same columns);
the surface between them is a C1 cubic Hermite spline along every column. Key rows are
reproduced exactly (interpolating, not approximating), so a girth feature line that is a
key row is a mesh row and the tape measure reads exactly its control points.
"""

from __future__ import annotations

import numpy as np


def hermite_matrix(t_keys: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Weights ``H`` (rows, K + 2) so that ``rows = H @ [ghost_lo, key_0..key_K-1, ghost_hi]``.

    ``t_keys`` (K,) are nominal parameters of the key rows [m, arc length of the base size];
    ``counts`` (K-1,) the number of mesh row intervals between consecutive keys. The ghost
    rows sit at ``t_0 - (t_1 - t_0)`` and ``t_K-1 + (t_K-1 - t_K-2)``: pass a neighbouring
    part's row there for tangent continuity across a junction, or the reflection
    :func:`reflect_ghost` for a one-sided end tangent. Key rows map to themselves exactly.
    """
    t = np.asarray(t_keys, float)
    k_count = len(t)
    dt = np.diff(t)
    te = np.concatenate([[t[0] - dt[0]], t, [t[-1] + dt[-1]]])
    de = np.diff(te)  # (K+1,)
    n_ext = k_count + 2
    # Bessel tangent at extended index i (1..K): linear in p[i-1], p[i], p[i+1].
    tang = np.zeros((n_ext, n_ext))
    for i in range(1, k_count + 1):
        a, b = de[i - 1], de[i]
        tang[i, i + 1] += a / b / (a + b)
        tang[i, i] += (-a / b + b / a) / (a + b)
        tang[i, i - 1] += -b / a / (a + b)
    rows = []
    for seg in range(k_count - 1):
        i = seg + 1
        n = int(counts[seg])
        s = np.arange(n) / n
        h00 = 2 * s**3 - 3 * s**2 + 1
        h10 = s**3 - 2 * s**2 + s
        h01 = -2 * s**3 + 3 * s**2
        h11 = s**3 - s**2
        w = np.zeros((n, n_ext))
        w[:, i] += h00
        w[:, i + 1] += h01
        w += (h10 * dt[seg])[:, None] * tang[i][None, :]
        w += (h11 * dt[seg])[:, None] * tang[i + 1][None, :]
        w[0] = 0.0
        w[0, i] = 1.0  # exact key row
        rows.append(w)
    last = np.zeros((1, n_ext))
    last[0, k_count] = 1.0
    rows.append(last)
    return np.concatenate(rows, axis=0)


def reflect_ghost(p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
    """Ghost row beyond ``p0`` (mirror of ``p1``): gives the one-sided tangent ``p1 - p0``."""
    return 2.0 * p0 - p1


def loft(h: np.ndarray, keys: np.ndarray) -> np.ndarray:
    """Evaluate rows (R, M, 3) from ``h`` (R, K+2) and ``keys`` (K+2, M, 3) incl. ghosts."""
    return np.tensordot(h, keys, axes=(1, 0))


def key_row_indices(counts: np.ndarray) -> np.ndarray:
    """Mesh row index of every key row, for ``counts`` intervals between keys."""
    return np.concatenate([[0], np.cumsum(counts)]).astype(int)
