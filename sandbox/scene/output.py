"""Write what a run produced: the final mesh (OBJ and PLY with UVs), a PNG and metrics.

Every file goes through :mod:`sandbox.atomic`, so an interrupted or failed run leaves no
half-written file. A diverged run writes nothing (the caller never gets here).
"""

from __future__ import annotations

import logging

import numpy as np

from sandbox.atomic import make_dir, write_json
from sandbox.scene.build import Scene
from sandbox.scene.run import RunResult

log = logging.getLogger(__name__)

CLOTH_COLOR = (0.32, 0.45, 0.75)
BODY_COLOR = (0.82, 0.76, 0.68)


def write_outputs(scene: Scene, result: RunResult, out_dir, *, render: bool = True) -> dict:
    """Write ``mesh.obj``, ``mesh.ply``, ``render.png`` and ``metrics.json`` into ``out_dir``.

    Returns a dict of the written paths by kind. UVs are the pattern-plane coordinates [m].
    """
    from sandbox.render.meshio import write_mesh

    out = make_dir(out_dir)
    model = scene.model
    x = result.positions
    tris = model.tri_indices_np
    paths = {
        "mesh_obj": write_mesh(out / "mesh.obj", x, tris, uvs=model.rest_uv_np),
        "mesh_ply": write_mesh(out / "mesh.ply", x, tris, uvs=model.rest_uv_np),
    }
    if render:
        bodies = [(c.body_x.to_numpy().astype(np.float64), c.triangles_np)
                  for c in model.colliders if c.closed]  # fmt: skip
        paths["image"] = render_state(out / "render.png", x, tris, bodies=bodies)
    metrics = dict(result.metrics)
    metrics["outputs"] = {k: p.name for k, p in paths.items()}
    metrics["bounding_box_m"] = [x.min(axis=0).tolist(), x.max(axis=0).tolist()]
    paths["metrics"] = write_json(out / "metrics.json", _jsonable(metrics))
    return paths


def render_state(path, x: np.ndarray, tris: np.ndarray, *, bodies=(), views=("front", "side")):
    """Off-screen PNG of the cloth and any closed colliders (front and side views)."""
    from sandbox.render.offscreen import render_png

    meshes = [{"vertices": x, "triangles": tris, "color": CLOTH_COLOR}]
    meshes += [{"vertices": v, "triangles": f, "color": BODY_COLOR} for v, f in bodies]
    return render_png(path, meshes, views=views, width=480, height=480)


def _jsonable(obj):
    if isinstance(obj, dict):
        return {k: _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, float) and not np.isfinite(obj):
        return None
    return obj
