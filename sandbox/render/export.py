"""Export for other tools: the garment with its fabric texture, as glTF and as OBJ + MTL.

* ``garment.glb`` (binary glTF 2.0, written by trimesh): two meshes, ``garment`` and
  ``body``. The garment has positions, vertex normals, texture coordinates and the woven
  check of :mod:`sandbox.render.fabric` as its base-colour texture (PNG inside the file,
  repeating). Its texture coordinates are the rest coordinates along warp and weft in
  metres (``Model.material_uv_np``; one texture tile is :data:`~sandbox.render.fabric.TILE_M`
  of fabric), so the check follows the grain, and ``render --strain`` reads the rest shape
  back from them. The body has positions, normals and a skin-coloured material. Vertices
  keep the simulation's order and count. Web viewers (three.js, model-viewer, Blender)
  load it as it is.
* ``garment.obj`` names ``garment.mtl``, whose material ``fabric`` maps
  ``garment_texture.png`` (the same check). The OBJ's ``vt`` are the pattern coordinates in
  metres (docs/outputs.md), so there the check follows the pattern's axes.

Every file is written to a temporary name and renamed (:mod:`sandbox.atomic`).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from sandbox.errors import SandboxError
from sandbox.render.fabric import fabric_texture
from sandbox.render.meshio import OBJ_MATERIAL, write_bytes, write_mesh

GLB_GARMENT = "garment"
GLB_BODY = "body"


def _png_bytes(img: np.ndarray) -> bytes:
    import imageio.v3 as iio

    return iio.imwrite("<bytes>", img, extension=".png")


def write_textured_obj(path: str | os.PathLike, vertices, triangles, pattern_uv, color) -> dict:
    """``path`` (OBJ with pattern coordinates as ``vt``), its ``.mtl`` and its texture PNG
    (``<stem>_texture.png``) in ``color`` (RGB 0..1). Returns {"obj", "mtl", "texture"}."""
    path = Path(path)
    texture = path.with_name(f"{path.stem}_texture.png")
    mtl = path.with_suffix(".mtl")
    obj = write_mesh(path, vertices, triangles, uvs=pattern_uv, mtllib=mtl.name)
    write_bytes(texture, _png_bytes(fabric_texture(color)))
    text = (f"# garment-sandbox fabric: a {color} check, one texture tile per metre of "
            f"pattern\nnewmtl {OBJ_MATERIAL}\nKa 0 0 0\nKd 1 1 1\nKs 0 0 0\nd 1\nillum 1\n"
            f"map_Kd {texture.name}\n")  # fmt: skip
    write_bytes(mtl, text.encode("ascii"))
    return {"obj": obj, "mtl": mtl, "texture": texture}


def glb_bytes(vertices, triangles, material_uv, color, body=None,
              body_color=(0.82, 0.76, 0.68)) -> bytes:  # fmt: skip
    """The binary glTF of a garment (``vertices`` (n, 3) [m], ``triangles`` (m, 3),
    ``material_uv`` (n, 2) [m] along warp and weft, ``color`` RGB 0..1) and, optionally,
    a body ``(vertices, triangles)``."""
    import trimesh
    from PIL import Image

    v = np.asarray(vertices, np.float64)
    t = np.asarray(triangles, np.int64)
    uv = np.asarray(material_uv, np.float64)
    if v.ndim != 2 or v.shape[1] != 3 or uv.shape != (len(v), 2) or not np.isfinite(v).all():
        raise SandboxError("glTF export: vertices must be finite (n, 3) with (n, 2) coordinates")
    garment = trimesh.Trimesh(vertices=v, faces=t, process=False, validate=False)
    image = Image.fromarray(fabric_texture(color))
    material = trimesh.visual.material.PBRMaterial(
        name="fabric", baseColorTexture=image, metallicFactor=0.0, roughnessFactor=0.9,
        doubleSided=True)  # fmt: skip
    garment.visual = trimesh.visual.TextureVisuals(uv=uv, material=material)
    scene = trimesh.Scene()
    scene.add_geometry(garment, node_name=GLB_GARMENT, geom_name=GLB_GARMENT)
    if body is not None:
        b = trimesh.Trimesh(vertices=np.asarray(body[0], float), faces=np.asarray(body[1]),
                            process=False, validate=False)  # fmt: skip
        skin = trimesh.visual.material.PBRMaterial(
            name="skin", baseColorFactor=[*(int(255 * c) for c in body_color), 255],
            metallicFactor=0.0, roughnessFactor=0.8)  # fmt: skip
        b.visual = trimesh.visual.TextureVisuals(material=skin)
        scene.add_geometry(b, node_name=GLB_BODY, geom_name=GLB_BODY)
    return scene.export(file_type="glb", include_normals=True)


def write_glb(path: str | os.PathLike, vertices, triangles, material_uv, color,
              body=None) -> Path:  # fmt: skip
    """Write :func:`glb_bytes` to ``path`` atomically; return the path."""
    return write_bytes(Path(path), glb_bytes(vertices, triangles, material_uv, color, body))


def read_glb_garment(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The garment of a ``garment.glb``: vertices (n, 3) [m], triangles (m, 3) and its rest
    coordinates along warp and weft (n, 2) [m]."""
    import trimesh

    path = Path(path)
    if not path.is_file():
        raise SandboxError(f"{path}: glTF file not found")
    try:
        scene = trimesh.load(str(path), process=False, maintain_order=True)
    except Exception as exc:  # trimesh raises many types for malformed files
        raise SandboxError(f"{path}: could not read glTF: {exc}") from None
    geoms = getattr(scene, "geometry", {})
    mesh = geoms.get(GLB_GARMENT)
    uv = getattr(getattr(mesh, "visual", None), "uv", None)
    if mesh is None or uv is None:
        raise SandboxError(f"{path}: no textured mesh named {GLB_GARMENT!r} (not written by "
                           "drape?)")  # fmt: skip
    return (np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64),
            np.asarray(uv, float))  # fmt: skip
