"""Triangle-mesh files: write OBJ/PLY with per-vertex UVs, read OBJ/PLY/GLB/GLTF/STL.

Writers (checked by reading the files back, Open3D 0.20 and trimesh 5.2):

* ``.obj`` is written by this module: ``v x y z [r g b]``, one ``vt u v`` per vertex and
  ``f a/a b/b c/c``, nine significant digits, vertices in the caller's order, no ``.mtl``
  sidecar. Open3D was tried first and rejected: its tensor writer (Assimp) reorders
  vertices by first use in the faces, drops unreferenced ones and always writes a
  ``.mtl`` next to the (temporary) file; its legacy writer keeps the order but prints six
  significant digits and one ``vt`` per triangle corner. trimesh cannot put vertex
  colours and UVs into the same OBJ.
* ``.ply`` is written by trimesh, binary little-endian: ``float x y z``, optional
  ``uchar red green blue alpha``, optional ``double s t``. Neither Open3D writer stores
  UVs in PLY (the tensor writer's documentation says so; verified).

Positions in PLY are float32 (trimesh); in OBJ they keep nine significant digits. Both
are exact for the float32 state of the simulator.

Reading uses trimesh (``process=False, maintain_order=True``) so OBJ and PLY files come
back in their vertex order. Open3D's legacy reader was rejected: in 0.20 it reorders the
vertices of OBJ files.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from sandbox.atomic import atomic_path
from sandbox.errors import SandboxError

WRITE_SUFFIXES = (".obj", ".ply")
READ_SUFFIXES = (".obj", ".ply", ".glb", ".gltf", ".stl")
OBJ_MATERIAL = "fabric"
"""The material an OBJ with a ``mtllib`` uses."""


def _check_array(path: Path, name: str, value, columns: int, rows: int | None) -> np.ndarray:
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError) as exc:
        raise SandboxError(f"{path}: {name} is not an array: {exc}") from None
    if arr.ndim != 2 or arr.shape[1] != columns:
        raise SandboxError(f"{path}: {name} must have shape (n, {columns}), got {arr.shape}")
    if rows is not None and arr.shape[0] != rows:
        raise SandboxError(
            f"{path}: {name} must have one row per vertex ({rows}), got {arr.shape[0]}"
        )
    if arr.dtype.kind not in "biuf":
        raise SandboxError(f"{path}: {name} must be numeric, got dtype {arr.dtype}")
    return arr


def _check_finite(path: Path, name: str, arr: np.ndarray) -> np.ndarray:
    arr = arr.astype(np.float64)
    bad = ~np.isfinite(arr).all(axis=1)
    if bad.any():
        rows = np.flatnonzero(bad)
        raise SandboxError(
            f"{path}: {name} has {rows.size} row(s) with NaN or infinity (first: row {rows[0]})"
        )
    return arr


def _validate(path: Path, vertices, triangles, uvs, vertex_colors):
    v = _check_finite(path, "vertices", _check_array(path, "vertices", vertices, 3, None))
    if v.shape[0] == 0:
        raise SandboxError(f"{path}: vertices is empty")
    t = _check_array(path, "triangles", triangles, 3, None)
    if t.shape[0] == 0:
        raise SandboxError(f"{path}: triangles is empty")
    if t.dtype.kind not in "iu":
        raise SandboxError(f"{path}: triangles must be integers, got dtype {t.dtype}")
    t = t.astype(np.int64)
    out = (t < 0) | (t >= v.shape[0])
    if out.any():
        row = int(np.flatnonzero(out.any(axis=1))[0])
        raise SandboxError(
            f"{path}: triangles[{row}] = {t[row].tolist()} has a vertex index out of range "
            f"0..{v.shape[0] - 1}"
        )
    uv = None
    if uvs is not None:
        uv = _check_finite(path, "uvs", _check_array(path, "uvs", uvs, 2, v.shape[0]))
    col = None
    if vertex_colors is not None:
        col = _check_array(path, "vertex_colors", vertex_colors, 3, v.shape[0])
        col = _check_finite(path, "vertex_colors", col)
        if (col < 0).any() or (col > 1).any():
            raise SandboxError(f"{path}: vertex_colors must lie in 0..1")
    return v, t, uv, col


def _obj_text(v, t, uv, col, mtllib: str | None = None) -> str:
    buf = io.StringIO()
    buf.write(f"# garment-sandbox mesh: {len(v)} vertices, {len(t)} triangles\n")
    if mtllib is not None:
        buf.write(f"mtllib {mtllib}\nusemtl {OBJ_MATERIAL}\n")
    if col is None:
        np.savetxt(buf, v, fmt="v %.9g %.9g %.9g")
    else:
        np.savetxt(buf, np.hstack([v, col]), fmt="v %.9g %.9g %.9g %.6g %.6g %.6g")
    f = t + 1
    if uv is None:
        np.savetxt(buf, f, fmt="f %d %d %d")
    else:
        np.savetxt(buf, uv, fmt="vt %.9g %.9g")
        np.savetxt(buf, np.repeat(f, 2, axis=1), fmt="f %d/%d %d/%d %d/%d")
    return buf.getvalue()


def _ply_bytes(v, t, uv, col) -> bytes:
    import trimesh
    from trimesh.exchange.ply import export_ply

    mesh = trimesh.Trimesh(vertices=v, faces=t, process=False, validate=False)
    if col is not None:
        rgba = np.empty((len(v), 4), dtype=np.uint8)
        rgba[:, :3] = np.round(col * 255.0)
        rgba[:, 3] = 255
        mesh.visual = trimesh.visual.ColorVisuals(mesh, vertex_colors=rgba)
    if uv is not None:
        mesh.vertex_attributes["s"] = uv[:, 0].copy()
        mesh.vertex_attributes["t"] = uv[:, 1].copy()
    return export_ply(mesh, encoding="binary_little_endian", vertex_normal=False)


def write_mesh(
    path: str | os.PathLike,
    vertices,
    triangles,
    *,
    uvs=None,
    vertex_colors=None,
    mtllib: str | None = None,
) -> Path:
    """Write a triangle mesh to ``.obj`` or ``.ply`` atomically; return the path.

    ``vertices`` (n, 3) in metres, ``triangles`` (m, 3) integer indices, ``uvs`` optional
    per-vertex (n, 2) pattern-plane coordinates in metres, ``vertex_colors`` optional
    (n, 3) floats in 0..1. ``mtllib``: an OBJ names this material file (beside it) and uses
    its material :data:`OBJ_MATERIAL` (:func:`sandbox.render.export.write_textured_obj`
    writes both). Bad input raises :class:`SandboxError` before anything is
    written; a failed write leaves no file behind.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in WRITE_SUFFIXES:
        raise SandboxError(
            f"{path}: cannot write mesh format {path.suffix or '(none)'!r}; "
            f"use one of {', '.join(WRITE_SUFFIXES)}"
        )
    v, t, uv, col = _validate(path, vertices, triangles, uvs, vertex_colors)
    if suffix == ".obj":
        data = _obj_text(v, t, uv, col, mtllib).encode("ascii")
    else:
        data = _ply_bytes(v, t, uv, col)
    return write_bytes(path, data, "mesh")


def write_bytes(path: Path, data: bytes, what: str = "file") -> Path:
    """Write ``data`` to ``path`` atomically (temporary file, then rename); an OSError
    becomes a :class:`SandboxError` naming the file and ``what`` it is."""
    try:
        with atomic_path(path) as tmp:
            tmp.write_bytes(data)
    except OSError as exc:
        raise SandboxError(f"{path}: could not write {what}: {exc}") from None
    return path


def read_mesh(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """Read a triangle mesh; return ``(vertices (n, 3) float64, triangles (m, 3) int64)``.

    Reads OBJ, PLY, GLB, GLTF and STL. OBJ and PLY keep the file's vertex order (also
    unreferenced vertices); polygons are triangulated; the meshes of a glTF scene are
    merged with their node transforms applied; STL facets get coincident corners merged.
    Raises :class:`SandboxError` when the file is missing, unreadable, or holds no
    triangles.
    """
    import trimesh

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in READ_SUFFIXES:
        raise SandboxError(
            f"{path}: cannot read mesh format {path.suffix or '(none)'!r}; "
            f"use one of {', '.join(READ_SUFFIXES)}"
        )
    if not path.is_file():
        raise SandboxError(f"{path}: mesh file not found")
    if path.stat().st_size == 0:
        raise SandboxError(f"{path}: mesh file is empty")
    try:
        mesh = trimesh.load(str(path), force="mesh", process=False, maintain_order=True)
    except Exception as exc:  # trimesh raises many types for malformed files
        raise SandboxError(f"{path}: could not read mesh: {exc}") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise SandboxError(f"{path}: no triangles could be read (unreadable or empty mesh)")
    if suffix == ".stl":
        mesh.merge_vertices()
    v = np.array(mesh.vertices, dtype=np.float64).reshape(-1, 3)
    t = np.array(mesh.faces, dtype=np.int64).reshape(-1, 3)
    if not np.isfinite(v).all():
        raise SandboxError(f"{path}: vertices contain NaN or infinity")
    if t.min() < 0 or t.max() >= len(v):
        raise SandboxError(f"{path}: triangle indices out of range 0..{len(v) - 1}")
    return v, t
