"""The fabric's look: a woven check that follows the grain, drawn onto the garment.

Flat colour hides what a garment does: where it stretches, shears or folds. A check woven
into the cloth shows all three, as it does on a real fitting: its squares grow where the
cloth stretches, turn into rhombi where it shears, and bend with every fold.

The texture is one square of fabric :data:`TILE_M` on a side, repeated; texture x runs
along the warp (u), texture y along the weft (v). Light bands run along the warp and dark
bands along the weft, so the grain can be read off a picture. Its coordinates are the
rest coordinates along warp and weft in metres (``Model.material_uv_np``), so a texture
coordinate is ``material_uv / TILE_M``.

Pictures sample it per vertex on a finer copy of the mesh (:func:`textured_mesh`), so both
render backends draw it with their usual per-vertex colours.
"""

from __future__ import annotations

import numpy as np

TILE_M = 1.0
"""Side of the texture's square of fabric [m]: texture coordinates in metres of the pattern
map onto it one to one, so the same file serves the OBJ (pattern coordinates) and the glTF
(warp and weft coordinates)."""
CHECK_M = 0.025
"""Period of the check [m] (a 2.5 cm gingham): four to five squares across a bust dart,
several on a 1 cm mesh's sleeve."""
TEXTURE_PX = 2048
"""Pixels along a side of the texture file: 51 to a check, 0.5 mm each."""


def fabric_texture(color, px: int = TEXTURE_PX) -> np.ndarray:
    """The woven check in ``color`` (RGB 0..1): (px, px, 3) uint8, row 0 at v = 0.

    Warp bands (along u, light) and weft bands (along v, dark), each a quarter of
    :data:`CHECK_M` wide.
    """
    base = np.clip(np.asarray(color, float), 0.0, 1.0)
    s = (np.arange(px) + 0.5) / px * TILE_M  # texel centres [m]
    phase = (s / CHECK_M) % 1.0
    band = np.abs(phase - 0.5) < 0.125  # a quarter of the period
    warp_band = band[:, None]  # rows: constant v, a band running along the warp
    weft_band = band[None, :]  # columns: constant u, a band running along the weft
    light = 0.42 * warp_band
    dark = 0.30 * weft_band
    rgb = base[None, None, :] * (1.0 - light - dark)[..., None]
    rgb += light[..., None]  # towards white
    return np.round(np.clip(rgb, 0.0, 1.0) * 255).astype(np.uint8)


def sample_texture(texture: np.ndarray, uv_m: np.ndarray) -> np.ndarray:
    """Bilinear, repeating lookup: colours (n, 3) in 0..1 at (n, 2) coordinates [m]."""
    px = texture.shape[0]
    f = np.asarray(uv_m, float) / TILE_M * px - 0.5
    i0 = np.floor(f).astype(np.int64)
    w = f - i0
    tex = texture.astype(np.float64) / 255.0
    out = np.zeros((len(f), 3))
    for du in (0, 1):
        for dv in (0, 1):
            wu = w[:, 0] if du else 1.0 - w[:, 0]
            wv = w[:, 1] if dv else 1.0 - w[:, 1]
            out += (wu * wv)[:, None] * tex[(i0[:, 1] + dv) % px, (i0[:, 0] + du) % px]
    return out


def _grid(level: int):
    """The points (i, j) of a triangle split ``level`` times along each edge, and their
    barycentric weights (k, 3) on its corners."""
    pts = [(i, j) for i in range(level + 1) for j in range(level + 1 - i)]
    return pts, np.array([[1.0 - (i + j) / level, i / level, j / level] for i, j in pts])


def subdivide(v: np.ndarray, t: np.ndarray, uv: np.ndarray, level: int):
    """Split every triangle into ``level²`` (linear, on its plane): the finer mesh's
    vertices (k, 3), triangles (level² m, 3) and coordinates (k, 2). Vertices on shared
    edges are not merged (shading across them uses each triangle's own normal sums)."""
    if level <= 1:
        return v, t, uv
    pts, bary = _grid(level)
    index = {p: k for k, p in enumerate(pts)}
    sub = []
    for i in range(level):
        for j in range(level - i):
            sub.append((index[(i, j)], index[(i + 1, j)], index[(i, j + 1)]))
            if i + j < level - 1:
                sub.append((index[(i + 1, j)], index[(i + 1, j + 1)], index[(i, j + 1)]))
    sub = np.array(sub)
    corners_v = v[t]  # (m, 3, 3)
    corners_uv = uv[t]  # (m, 3, 2)
    fine_v = np.einsum("pk,mkc->mpc", bary, corners_v).reshape(-1, 3)
    fine_uv = np.einsum("pk,mkc->mpc", bary, corners_uv).reshape(-1, 2)
    base = (np.arange(len(t)) * len(pts))[:, None, None]
    fine_t = (base + sub[None, :, :]).reshape(-1, 3)
    return fine_v, fine_t, fine_uv


def textured_mesh(vertices, triangles, uv_m, color, *, pixel_m: float,
                  texture: np.ndarray | None = None) -> dict:  # fmt: skip
    """A drawable mesh (``render_png``'s dict, with ``vertex_colors``) of a garment wearing
    the check: each triangle split so that its pieces are about two pixels of ``pixel_m``
    [m] across (at most 6 x 6), coloured from the texture at their corners."""
    v = np.asarray(vertices, float)
    t = np.asarray(triangles, np.int64)
    uv = np.asarray(uv_m, float)
    tex = fabric_texture(color) if texture is None else texture
    edge = float(np.mean(np.linalg.norm(v[t[:, 1]] - v[t[:, 0]], axis=1))) if len(t) else 0.0
    level = int(np.clip(np.ceil(edge / (2.0 * max(pixel_m, 1e-9))), 1, 6))
    fv, ft, fuv = subdivide(v, t, uv, level)
    normals_from = _smooth_normals(v, t, level)
    return {"vertices": fv, "triangles": ft, "color": color,
            "vertex_colors": sample_texture(tex, fuv), "normals": normals_from}  # fmt: skip


def _smooth_normals(v: np.ndarray, t: np.ndarray, level: int) -> np.ndarray:
    """The coarse mesh's vertex normals interpolated onto :func:`subdivide`'s vertices, so
    the finer copy shades as smoothly as the mesh it came from."""
    from sandbox.render.view import vertex_normals

    n = vertex_normals(v, t)
    if level <= 1:
        return n
    _, bary = _grid(level)
    out = np.einsum("pk,mkc->mpc", bary, n[t]).reshape(-1, 3)
    length = np.linalg.norm(out, axis=1, keepdims=True)
    return np.divide(out, length, out=np.zeros_like(out), where=length > 0)
