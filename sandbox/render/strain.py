"""Strain maps: each triangle coloured by the paper's Eq. 6 strains, with legends in %.

What a fitting shows first is where the cloth pulls: a garment that stretches 5 % across
the bust is too tight there, whatever its ease. For every triangle this module evaluates
Eq. 6 (:func:`sandbox.sim.forces.eq6_strain`, the solver's own function) on the final
positions against the rest shape along warp and weft, and draws three pictures side by
side:

* **warp**: S_u − 1, the stretch along the warp [%];
* **weft**: S_v − 1, the stretch along the weft [%];
* **shear**: 2θ_s, the change of the angle between warp and weft [% of a radian, the
  engineering shear strain].

Blue is compression (or negative shear), white none, red stretch. Every picture has its
own symmetric scale: the 99th percentile of its values over the garment, rounded up to a
step of 0.5 %, at least 1 %.
"""

import numpy as np
import taichi as ti

from sandbox.sim.forces import eq6_strain

STRAIN_NAMES = ("warp", "weft", "shear")
BODY_MARGIN_M = 0.08
"""Strain pictures show the body only this far [m] around the garment's bounding box."""
LEGEND_PX = 56
"""Height of the legend strip under each picture [px]."""


@ti.kernel
def _eq6_kernel(x: ti.types.ndarray(), tris: ti.types.ndarray(), uv: ti.types.ndarray(),
                out: ti.types.ndarray()):  # fmt: skip
    for k in range(tris.shape[0]):
        a, b, c = tris[k, 0], tris[k, 1], tris[k, 2]
        q0 = ti.Vector([x[a, 0], x[a, 1], x[a, 2]], ti.f64)
        d1 = ti.Vector([x[b, 0], x[b, 1], x[b, 2]], ti.f64) - q0
        d2 = ti.Vector([x[c, 0], x[c, 1], x[c, 2]], ti.f64) - q0
        s_u, s_v, theta_s = eq6_strain(d1, d2, uv[b, 0] - uv[a, 0], uv[b, 1] - uv[a, 1],
                                       uv[c, 0] - uv[a, 0], uv[c, 1] - uv[a, 1])  # fmt: skip
        out[k, 0] = s_u - 1.0
        out[k, 1] = s_v - 1.0
        out[k, 2] = 2.0 * theta_s


def triangle_strain(x: np.ndarray, triangles: np.ndarray, material_uv: np.ndarray) -> np.ndarray:
    """Eq. 6 per triangle: (m, 3) of S_u − 1, S_v − 1 and 2θ_s [1].

    Args: ``x`` (n, 3) positions [m]; ``triangles`` (m, 3), counter-clockwise in the
    pattern plane; ``material_uv`` (n, 2) rest coordinates along warp and weft [m]
    (``Model.material_uv_np``, or the UVs of a drape's ``garment.glb``).
    """
    from sandbox import runtime

    runtime.ensure_init()
    t = np.ascontiguousarray(triangles, np.int32)
    out = np.zeros((len(t), 3), np.float64)
    if len(t):
        _eq6_kernel(np.ascontiguousarray(x, np.float64), t,
                    np.ascontiguousarray(material_uv, np.float64), out)  # fmt: skip
    return out


def strain_scale(values: np.ndarray) -> float:
    """The symmetric colour scale [1] of one strain: its 99th percentile of |values|,
    rounded up to 0.5 %, at least 1 %."""
    p = float(np.percentile(np.abs(values), 99)) if len(values) else 0.0
    return max(0.01, np.ceil(p / 0.005) * 0.005)


def diverging(values: np.ndarray, scale: float) -> np.ndarray:
    """Blue (−scale) to white (0) to red (+scale): colours (k, 3) in 0..1."""
    s = np.clip(np.asarray(values, float) / scale, -1.0, 1.0)[:, None]
    blue = np.array([0.19, 0.35, 0.80])
    red = np.array([0.80, 0.15, 0.12])
    white = np.ones(3)
    return np.where(s < 0, white + (-s) * (blue - white), white + s * (red - white))


def strain_meshes(x, triangles, values: np.ndarray, scale: float, body=None) -> list[dict]:
    """Drawable meshes (``render_png``'s dicts): the garment with each triangle in the colour
    of its strain ``values`` (m,) on the scale ``scale``, and the body in grey."""
    from sandbox.render.view import vertex_normals

    x = np.asarray(x, float)
    t = np.asarray(triangles, np.int64)
    normals = vertex_normals(x, t)[t].reshape(-1, 3)  # smooth shading, flat colours
    colors = np.repeat(diverging(values, scale), 3, axis=0)
    out = [{"vertices": x[t].reshape(-1, 3), "triangles": np.arange(3 * len(t)).reshape(-1, 3),
            "vertex_colors": colors, "normals": normals}]  # fmt: skip
    if body is not None:
        out.append({"vertices": body[0], "triangles": body[1], "color": (0.72, 0.72, 0.72)})
    return out


def _legend(width: int, name: str, scale: float) -> np.ndarray:
    """A colour bar with its ticks in % and the strain's name: (LEGEND_PX, width, 3) uint8."""
    from PIL import Image, ImageDraw

    img = Image.new("RGB", (width, LEGEND_PX), (255, 255, 255))
    draw = ImageDraw.Draw(img)
    left, right = int(0.1 * width), int(0.9 * width)
    bar = diverging(np.linspace(-scale, scale, right - left), scale)
    for i, c in enumerate(bar):
        draw.line([(left + i, 4), (left + i, 20)], fill=tuple(int(255 * v) for v in c))
    draw.rectangle([left, 4, right, 20], outline=(0, 0, 0))
    pct = 100.0 * scale
    for frac, value in ((0.0, -pct), (0.5, 0.0), (1.0, pct)):
        px = left + frac * (right - left)
        label = f"{value:+.1f} %" if value else "0"
        draw.line([(px, 20), (px, 25)], fill=(0, 0, 0))
        draw.text((px - 3 * len(label), 27), label, fill=(0, 0, 0))
    title = {"warp": "stretch along the warp (S_u - 1)", "weft": "stretch along the weft (S_v - 1)",
             "shear": "shear (2 theta_s)"}[name]  # fmt: skip
    draw.text((left, 41), title, fill=(0, 0, 0))
    return np.asarray(img)


def _body_near(body, x: np.ndarray, margin_m: float):
    """The body's triangles within ``margin_m`` [m] of the garment's bounding box, so that
    the pictures frame the garment."""
    v, t = np.asarray(body[0], float), np.asarray(body[1], np.int64)
    lo, hi = x.min(axis=0) - margin_m, x.max(axis=0) + margin_m
    inside = np.all((v >= lo) & (v <= hi), axis=1)
    return v, t[inside[t].all(axis=1)]


def strain_figure(x, triangles, material_uv, *, body=None, view: str = "front",
                  size: int = 480, backend: str = "auto") -> tuple[np.ndarray, dict]:  # fmt: skip
    """The three strain pictures side by side with their legends (framing the garment and the
    body around it, :data:`BODY_MARGIN_M`): an RGB uint8 image
    (size + LEGEND_PX, 3 size, 3) and a summary {name: {"scale_percent", "p99_percent",
    "min_percent", "max_percent"}}."""
    from sandbox.render.offscreen import render_image

    x = np.asarray(x, float)
    values = triangle_strain(x, triangles, material_uv)
    body = None if body is None else _body_near(body, x, BODY_MARGIN_M)
    tiles, summary = [], {}
    for k, name in enumerate(STRAIN_NAMES):
        scale = strain_scale(values[:, k])
        meshes = strain_meshes(x, triangles, values[:, k], scale, body)
        img = render_image(meshes, views=(view,), width=size, height=size, backend=backend)
        tiles.append(np.vstack([img, _legend(size, name, scale)]))
        v = 100.0 * values[:, k]
        summary[name] = {"scale_percent": 100.0 * scale,
                         "p99_percent": float(np.percentile(np.abs(v), 99)),
                         "min_percent": float(v.min()), "max_percent": float(v.max())}  # fmt: skip
    return np.hstack(tiles), summary
