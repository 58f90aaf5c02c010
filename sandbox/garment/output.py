"""Writing a drape: garment and body meshes, front and back renders, metrics.json.

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
    """Write the garment and body meshes (unless ``meshes=False``: ``garment.obj``,
    ``garment.ply`` with the pattern coordinates [m] as UVs, ``body.obj``), the front and
    back renders (unless ``render=False``: ``render.png``, ``render_back.png``) and
    ``metrics.json`` into ``out_dir``. Returns {kind: path}."""
    from sandbox.atomic import make_dir, write_json
    from sandbox.render.meshio import write_mesh
    from sandbox.scene.output import _jsonable

    out = make_dir(out_dir)
    model, mannequin = scene.model, scene.garment.mannequin
    x = result.positions
    tris = model.tri_indices_np
    paths = {}
    if meshes:
        paths["garment_obj"] = write_mesh(out / "garment.obj", x, tris, uvs=model.rest_uv_np)
        paths["garment_ply"] = write_mesh(out / "garment.ply", x, tris, uvs=model.rest_uv_np)
        paths["body_obj"] = write_mesh(out / "body.obj", mannequin.vertices, mannequin.triangles)
    if render:
        paths["render_front"] = render_drape(out / "render.png", x, tris, mannequin, "front")
        paths["render_back"] = render_drape(out / "render_back.png", x, tris, mannequin, "back")
    metrics = dict(metrics)
    metrics["outputs"] = {k: p.name for k, p in paths.items()}
    metrics["bounding_box_m"] = [x.min(axis=0).tolist(), x.max(axis=0).tolist()]
    paths["metrics"] = write_json(out / "metrics.json", _jsonable(metrics))
    return paths


def _scene_meshes(x, tris, mannequin) -> list[dict]:
    return [
        {"vertices": x, "triangles": tris, "color": GARMENT_COLOR},
        {"vertices": mannequin.vertices, "triangles": mannequin.triangles, "color": BODY_COLOR},
    ]


def render_drape(path, x, tris, mannequin, view: str = "front", *, size: int = 640):
    """Off-screen PNG of the garment on the body from one view ("front", "back", "side")."""
    from sandbox.render.offscreen import render_png

    return render_png(path, _scene_meshes(x, tris, mannequin), views=(view,), width=size,
                      height=size)  # fmt: skip


def drape_image(x, tris, mannequin, view: str = "front", *, size: int = 320) -> np.ndarray:
    """RGB uint8 image (size, size, 3) of the garment on the body (for contact sheets)."""
    from sandbox.render.offscreen import render_image

    return render_image(_scene_meshes(x, tris, mannequin), views=(view,), width=size,
                        height=size)  # fmt: skip
