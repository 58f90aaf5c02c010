"""Writing a drape: garment and body meshes, front and back renders, metrics.json.

The garment is drawn and exported wearing a woven check that follows the grain
(:mod:`sandbox.render.fabric`), so stretch, shear and folds show in every picture.

Every file is written to a temporary name and renamed (:mod:`sandbox.atomic`), so an
interrupted write leaves nothing half-written.
"""

from __future__ import annotations

import numpy as np

GARMENT_COLOR = (0.32, 0.45, 0.75)
"""RGB of the garment in renders."""
BODY_COLOR = (0.82, 0.76, 0.68)
"""RGB of the mannequin in renders."""


def write_drape(scene, result, metrics: dict, out_dir, *, render: bool = True,
                meshes: bool = True) -> dict:  # fmt: skip
    """Write the garment and body meshes (unless ``meshes=False``: ``garment.obj`` with its
    ``garment.mtl`` and ``garment_texture.png``, ``garment.ply``, both with the pattern
    coordinates [m] as UVs, ``body.obj``, and ``garment.glb``: garment and body with the
    texture on the warp and weft coordinates, :mod:`sandbox.render.export`), the front and
    back renders (unless ``render=False``: ``render.png``, ``render_back.png``) and
    ``metrics.json`` (with ``strain_percent``, :func:`strain_summary`) into ``out_dir``.
    Returns {kind: path}."""
    from sandbox.atomic import make_dir, write_json
    from sandbox.render.export import write_glb, write_textured_obj
    from sandbox.render.meshio import write_mesh
    from sandbox.scene.output import _jsonable

    out = make_dir(out_dir)
    model, mannequin = scene.model, scene.garment.mannequin
    x = result.positions
    tris = model.tri_indices_np
    muv = model.material_uv_np
    paths = {}
    if meshes:
        obj = write_textured_obj(out / "garment.obj", x, tris, model.rest_uv_np, GARMENT_COLOR)
        paths.update(garment_obj=obj["obj"], garment_mtl=obj["mtl"],
                     garment_texture=obj["texture"])  # fmt: skip
        paths["garment_ply"] = write_mesh(out / "garment.ply", x, tris, uvs=model.rest_uv_np)
        paths["body_obj"] = write_mesh(out / "body.obj", mannequin.vertices, mannequin.triangles)
        body = (mannequin.vertices, mannequin.triangles)
        paths["garment_glb"] = write_glb(
            out / "garment.glb", x, tris, muv, GARMENT_COLOR, body=body
        )
    if render:
        for key, name, view in (("render_front", "render.png", "front"),
                                ("render_back", "render_back.png", "back")):  # fmt: skip
            paths[key] = render_drape(out / name, x, tris, mannequin, view, material_uv=muv)
    metrics = dict(metrics)
    metrics["strain_percent"] = strain_summary(x, tris, muv)
    metrics["outputs"] = {k: p.name for k, p in paths.items()}
    metrics["bounding_box_m"] = [x.min(axis=0).tolist(), x.max(axis=0).tolist()]
    paths["metrics"] = write_json(out / "metrics.json", _jsonable(metrics))
    return paths


def strain_summary(x, tris, material_uv) -> dict:
    """Eq. 6 strains of the final shape in % (:mod:`sandbox.render.strain`): per strain
    (warp S_u − 1, weft S_v − 1, shear 2θ_s) the 1st, 50th and 99th percentile over the
    triangles (not area-weighted) and the extremes."""
    from sandbox.render.strain import STRAIN_NAMES, triangle_strain

    values = 100.0 * triangle_strain(x, tris, material_uv)
    out = {}
    for k, name in enumerate(STRAIN_NAMES):
        v = values[:, k]
        p1, p50, p99 = np.percentile(v, [1, 50, 99])
        out[name] = {"min": float(v.min()), "p1": float(p1), "median": float(p50),
                     "p99": float(p99), "max": float(v.max())}  # fmt: skip
    return out


def _scene_meshes(x, tris, mannequin, material_uv=None, size: int = 640) -> list[dict]:
    """The garment (wearing the check where ``material_uv`` is given) and the body."""
    garment = {"vertices": x, "triangles": tris, "color": GARMENT_COLOR}
    if material_uv is not None:
        from sandbox.render.fabric import textured_mesh

        extent = float(np.ptp(np.vstack([x, mannequin.vertices]), axis=0).max())
        garment = textured_mesh(x, tris, material_uv, GARMENT_COLOR, pixel_m=extent / size)
    return [
        garment,
        {"vertices": mannequin.vertices, "triangles": mannequin.triangles, "color": BODY_COLOR},
    ]


def render_drape(path, x, tris, mannequin, view: str = "front", *, size: int = 640,
                 material_uv=None):  # fmt: skip
    """Off-screen PNG of the garment on the body from one view ("front", "back", "side");
    with ``material_uv`` (n, 2) [m] the garment wears the woven check."""
    from sandbox.render.offscreen import render_png

    return render_png(path, _scene_meshes(x, tris, mannequin, material_uv, size),
                      views=(view,), width=size, height=size)  # fmt: skip


def drape_image(x, tris, mannequin, view: str = "front", *, size: int = 320,
                material_uv=None) -> np.ndarray:  # fmt: skip
    """RGB uint8 image (size, size, 3) of the garment on the body (for contact sheets);
    with ``material_uv`` the garment wears the woven check."""
    from sandbox.render.offscreen import render_image

    return render_image(_scene_meshes(x, tris, mannequin, material_uv, size), views=(view,),
                        width=size, height=size)  # fmt: skip
