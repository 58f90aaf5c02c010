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


def hermite_weights(t_keys: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Weights (len(tau), K + 2) of the spline of :func:`hermite_matrix` at parameters ``tau``.

    ``tau`` are parameters in ``[t_0, t_K-1]``; a parameter equal to a key's gives exactly
    that key row (weight 1, all others 0).
    """
    t = np.asarray(t_keys, float)
    tau = np.asarray(tau, float)
    k_count = len(t)
    dt = np.diff(t)
    te = np.concatenate([[t[0] - dt[0]], t, [t[-1] + dt[-1]]])
    de = np.diff(te)
    n_ext = k_count + 2
    tang = np.zeros((n_ext, n_ext))
    for i in range(1, k_count + 1):
        a, b = de[i - 1], de[i]
        tang[i, i + 1] += a / b / (a + b)
        tang[i, i] += (-a / b + b / a) / (a + b)
        tang[i, i - 1] += -b / a / (a + b)
    seg = np.clip(np.searchsorted(t, tau, side="right") - 1, 0, k_count - 2)
    s = (tau - t[seg]) / dt[seg]
    h00 = 2 * s**3 - 3 * s**2 + 1
    h10 = s**3 - 2 * s**2 + s
    h01 = -2 * s**3 + 3 * s**2
    h11 = s**3 - s**2
    w = np.zeros((len(tau), n_ext))
    rows = np.arange(len(tau))
    w[rows, seg + 1] += h00
    w[rows, seg + 2] += h01
    w += (h10 * dt[seg])[:, None] * tang[seg + 1]
    w += (h11 * dt[seg])[:, None] * tang[seg + 2]
    exact = np.isclose(tau[:, None], t[None, :], rtol=0.0, atol=1e-12)
    hit = exact.any(axis=1)
    w[hit] = 0.0
    w[hit, 1 + np.argmax(exact[hit], axis=1)] = 1.0
    return w


def graded_column_matrix(
    t_keys: np.ndarray,
    keys: np.ndarray,
    bounds: tuple[int, ...],
    stretch: float,
    *,
    smooth: int = 2,
    samples: int = 96,
) -> tuple[np.ndarray, np.ndarray]:
    """Per-column weights ``H`` (M, R, K + 2) with rows graded by the local column spacing.

    ``keys`` (K + 2, M, 3) are the base size's key rows with ghosts, ``bounds`` the key
    indices that stay exact mesh rows (segment ends, e.g. ``(0, K-1)``). In each segment,
    every column places its rows so that the row spacing is proportional to the local
    column spacing (``stretch`` times it on average; a conformal grading, so that a part
    whose circumference shrinks or whose end is tilted gets near-square quads in every
    column). The row count of a segment is the same for all columns; the parameters are
    smoothed across columns to keep neighbouring rows aligned. Returns ``H`` and the mesh
    row index of each bound; rows are ``einsum("mrk,kmx->rmx", H, keys)``
    (:func:`loft_columns`), a fixed linear map like :func:`hermite_matrix`.
    """
    t = np.asarray(t_keys, float)
    m = keys.shape[1]
    taus = []
    rows_at = [0]
    for ka, kb in zip(bounds[:-1], bounds[1:], strict=True):
        tau = np.linspace(t[ka], t[kb], samples * (kb - ka) + 1)
        pts = loft(hermite_weights(t, tau), keys)  # (J, M, 3)
        gap = np.linalg.norm(pts - np.roll(pts, -1, axis=1), axis=2)
        g = 0.5 * (gap + np.roll(gap, 1, axis=1))
        ds = np.linalg.norm(np.diff(pts, axis=0), axis=2)
        mu = np.concatenate([np.zeros((1, m)), np.cumsum(ds / (0.5 * (g[1:] + g[:-1])), 0)])
        n = max(1, int(round(float(mu[-1].mean()) / stretch)))
        frac = np.arange(n + 1) / n
        col_tau = np.stack([np.interp(frac * mu[-1, c], mu[:, c], tau) for c in range(m)])
        for _ in range(smooth):
            col_tau = 0.25 * (np.roll(col_tau, 1, 0) + 2 * col_tau + np.roll(col_tau, -1, 0))
        col_tau[:, 0], col_tau[:, -1] = t[ka], t[kb]
        taus.append(col_tau if not taus else col_tau[:, 1:])
        rows_at.append(rows_at[-1] + n)
    col_tau = np.concatenate(taus, axis=1)  # (M, R)
    h = np.stack([hermite_weights(t, col_tau[c]) for c in range(m)])
    return h, np.array(rows_at)


def loft_columns(h: np.ndarray, keys: np.ndarray) -> np.ndarray:
    """Rows (R, M, 3) from per-column weights ``h`` (M, R, K+2) and ``keys`` (K+2, M, 3)."""
    return np.einsum("mrk,kmx->rmx", h, keys, optimize=True)
