"""Mesh files and offscreen pictures.

``write_mesh`` / ``read_mesh`` move triangle meshes (with per-vertex pattern UVs) in and
out of OBJ/PLY/GLB/GLTF/STL files; ``render_png`` draws meshes and polylines from fixed
views into a PNG without a display or GPU. Heavy libraries (Open3D, trimesh, imageio)
are imported only when a function needs them.
"""

from sandbox.render.meshio import read_mesh, write_mesh
from sandbox.render.offscreen import (
    BACKENDS,
    ENV_BACKEND,
    image_is_blank,
    render_image,
    render_png,
    resolve_backend,
)
from sandbox.render.view import VIEWS

__all__ = [
    "BACKENDS",
    "ENV_BACKEND",
    "VIEWS",
    "image_is_blank",
    "read_mesh",
    "render_image",
    "render_png",
    "resolve_backend",
    "write_mesh",
]
