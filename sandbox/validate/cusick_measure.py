"""What the Cusick drape test measures on a draped mesh: shadow area, drape coefficient, nodes.

All lengths in metres, areas in m², angles in radians. "Horizontal" is the world X-Z plane
(gravity along -Y), so a point's shadow from above is its (x, z).

- :func:`shadow_mask` / :func:`shadow_area_m2`: the vertical projection of the triangles,
  rasterised on a square grid (a pixel counts when its centre lies in a projected triangle),
  so overlapping folds are counted once: the area of the union.
- :func:`drape_coefficient_pct`: DC = (A_shadow − A_disc) / (A_specimen − A_disc) × 100 %.
- :func:`hem_profile`: the hem's radial distance r [m] of its projection against the hem
  vertices' angle around the centre in the flat specimen (single-valued even where a fold
  turns over).
- :func:`count_nodes`: the folds (nodes) around the hem: local maxima of the smoothed r(θ)
  whose prominence is at least a threshold.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.signal import find_peaks


def shadow_mask(xz: np.ndarray, tris: np.ndarray, extent_m: float, pixel_m: float) -> np.ndarray:
    """Boolean image (n, n) of the projected triangles' union, n = round(extent / pixel).

    The grid covers [-extent/2, extent/2]² around the origin (the specimen's centre); pixel
    (i, j) has its centre at x = -extent/2 + (j + ½)·pixel, z = -extent/2 + (i + ½)·pixel and
    is set when that centre lies inside (or on) a triangle of ``xz`` (k, 2) [m] with vertex
    indices ``tris`` (m, 3). Parts outside the grid are cut off.
    """
    n = int(round(extent_m / pixel_m))
    half = 0.5 * n * pixel_m
    mask = np.zeros((n, n), bool)
    p = (np.asarray(xz, np.float64) + half) / pixel_m - 0.5  # pixel-centre coordinates
    a, b, c = p[tris[:, 0]], p[tris[:, 1]], p[tris[:, 2]]
    lo = np.clip(np.ceil(np.minimum(np.minimum(a, b), c)).astype(int), 0, n)
    hi = np.clip(np.floor(np.maximum(np.maximum(a, b), c)).astype(int) + 1, 0, n)
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    eps = 1e-9
    for t in np.nonzero((np.abs(det) > 1e-14) & np.all(hi > lo, axis=1))[0]:
        jj, ii = np.meshgrid(np.arange(lo[t, 0], hi[t, 0]), np.arange(lo[t, 1], hi[t, 1]))
        px, pz = jj - a[t, 0], ii - a[t, 1]
        e1, e2 = b[t] - a[t], c[t] - a[t]
        u = (px * e2[1] - pz * e2[0]) / det[t]
        v = (e1[0] * pz - e1[1] * px) / det[t]
        inside = (u >= -eps) & (v >= -eps) & (u + v <= 1 + eps)
        mask[ii[inside], jj[inside]] = True
    return mask


def shadow_area_m2(xz: np.ndarray, tris: np.ndarray, extent_m: float, pixel_m: float) -> float:
    """Area [m²] of the union of the projected triangles: set pixels × pixel² (see
    :func:`shadow_mask`)."""
    return float(shadow_mask(xz, tris, extent_m, pixel_m).sum()) * pixel_m**2


def drape_coefficient_pct(
    shadow_m2: float, specimen_diameter_m: float, disc_diameter_m: float
) -> float:
    """DC [%] = (A_shadow − A_disc) / (A_specimen − A_disc) × 100, A = π D²/4 (BS 5058).

    100 % for a specimen that stays flat, 0 % for one hanging straight down from the rim.
    """
    a_spec = math.pi * specimen_diameter_m**2 / 4.0
    a_disc = math.pi * disc_diameter_m**2 / 4.0
    return 100.0 * (shadow_m2 - a_disc) / (a_spec - a_disc)


def hem_profile(
    rest_uv: np.ndarray, tris: np.ndarray, x: np.ndarray, centre_uv, centre_xz=(0.0, 0.0)
) -> tuple[np.ndarray, np.ndarray]:
    """The hem's projected radius against its angle: ``(theta [rad], r [m])``, sorted by θ.

    Hem vertices are those on a boundary edge (an edge of one triangle). θ is each one's angle
    about ``centre_uv`` in the flat pattern (so r(θ) stays single-valued where a fold turns
    over); r = |(x, z) − centre_xz| of its draped position ``x`` (k, 3) [m].
    """
    e = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    edges, counts = np.unique(e, axis=0, return_counts=True)
    hem = np.unique(edges[counts == 1])
    d = rest_uv[hem] - np.asarray(centre_uv, np.float64)
    theta = np.mod(np.arctan2(d[:, 1], d[:, 0]), 2.0 * math.pi)
    r = np.hypot(x[hem, 0] - centre_xz[0], x[hem, 2] - centre_xz[1])
    order = np.argsort(theta)
    return theta[order], r[order]


def count_nodes(
    theta: np.ndarray,
    r: np.ndarray,
    prominence_m: float = 0.005,
    smooth_rad: float = math.radians(3.0),
    samples: int = 720,
) -> int:
    """Number of nodes (folds) of a hem r(θ): peaks of the periodic, smoothed profile.

    r [m] at angles θ [rad] (any order, in [0, 2π)) is interpolated periodically onto
    ``samples`` equal steps, smoothed by a circular Gaussian of standard deviation
    ``smooth_rad`` [rad], and the local maxima whose topographic prominence is at least
    ``prominence_m`` [m] are counted (``scipy.signal.find_peaks``; the profile is tiled three
    times and the peaks of the middle copy counted, so the wrap at 2π is seamless). A circle
    has none; r = R + a·cos(kθ) with a ≳ prominence/2 has k.
    """
    theta = np.mod(np.asarray(theta, np.float64), 2.0 * math.pi)
    order = np.argsort(theta)
    t, rr = theta[order], np.asarray(r, np.float64)[order]
    grid = np.arange(samples) * (2.0 * math.pi / samples)
    prof = np.interp(grid, t, rr, period=2.0 * math.pi)
    sigma = smooth_rad / (2.0 * math.pi / samples)
    if sigma > 0:
        prof = gaussian_filter1d(prof, sigma, mode="wrap")
    if np.ptp(prof) < prominence_m:
        return 0
    tiled = np.concatenate([prof, prof, prof])
    peaks, _ = find_peaks(tiled, prominence=prominence_m)
    return int(np.count_nonzero((peaks >= samples) & (peaks < 2 * samples)))


def shadow_picture(mask: np.ndarray, pixel_m: float, circles_m=(), scale: int = 1) -> np.ndarray:
    """Greyscale image (uint8) of the shadow: black on white, +z at the bottom.

    ``circles_m``: radii [m] of circles about the centre drawn as grey lines (the support disc
    and the flat specimen's outline). ``scale`` repeats each pixel that many times.
    """
    img = np.where(mask, 0, 255).astype(np.uint8)
    n = mask.shape[0]
    c = 0.5 * n
    ii, jj = np.mgrid[0:n, 0:n]
    rad = np.hypot(jj + 0.5 - c, ii + 0.5 - c) * pixel_m
    for r in circles_m:
        ring = np.abs(rad - r) < 0.8 * pixel_m
        img[ring] = np.where(mask[ring], 150, 110)
    if scale > 1:
        img = np.repeat(np.repeat(img, scale, axis=0), scale, axis=1)
    return img


def contact_sheet(images: list[np.ndarray], labels: list[str], columns: int = 5) -> np.ndarray:
    """The images (same size, uint8 greyscale) in a grid, each with its label above it."""
    from PIL import Image, ImageDraw

    h, w = images[0].shape
    columns = max(1, min(columns, len(images)))
    pad, label_h = 8, 18
    rows = math.ceil(len(images) / columns)
    sheet = Image.new("L", (columns * (w + pad) + pad, rows * (h + label_h + pad) + pad), 255)
    draw = ImageDraw.Draw(sheet)
    for k, (im, text) in enumerate(zip(images, labels, strict=True)):
        x0 = pad + (k % columns) * (w + pad)
        y0 = pad + (k // columns) * (h + label_h + pad)
        draw.text((x0, y0 + 2), text, fill=0)
        sheet.paste(Image.fromarray(im), (x0, y0 + label_h))
    return np.asarray(sheet)
