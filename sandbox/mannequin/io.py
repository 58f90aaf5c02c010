"""Mannequin files: external body meshes in, mesh + landmarks + measurements + PNG out."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from sandbox.atomic import atomic_path, write_json
from sandbox.errors import SandboxError
from sandbox.mannequin.measurements import KEYS

log = logging.getLogger(__name__)

MESH_SUFFIXES = (".obj", ".ply", ".glb", ".gltf", ".stl", ".off")
BODY_COLOR = (0.85, 0.78, 0.70)
LINE_COLORS = {
    "girth": (0.85, 0.1, 0.1),
    "vertical": (0.1, 0.3, 0.85),
    "neck_shoulder": (0.1, 0.6, 0.2),
}


def load_body_mesh(path: str | Path):
    """Read an external body mesh and return it as a :class:`Mannequin` [m].

    Reads OBJ, PLY, GLB/GLTF, STL and OFF with trimesh (scenes are merged). Units are
    guessed from the height (1-2.5 -> metres, 100-250 -> cm, 1000-2500 -> mm); the body
    must stand with Y up and face +Z. It is moved so that its feet are at y = 0 and its
    mid-torso is on the Y axis. Landmarks are detected and the seven measurements taken;
    they become ``measurements_requested``.
    """
    import trimesh

    from sandbox.mannequin.landmarks import detect_landmarks
    from sandbox.mannequin.measurements import Measurements
    from sandbox.mannequin.model import Mannequin, measure

    p = Path(path)
    if not p.is_file():
        raise SandboxError(f"{p}: body mesh file not found")
    if p.suffix.lower() not in MESH_SUFFIXES:
        raise SandboxError(f"{p}: unsupported mesh format (use {', '.join(MESH_SUFFIXES)})")
    try:
        loaded = trimesh.load(p, force="mesh", process=True)
    except Exception as exc:  # trimesh raises many types for bad files
        raise SandboxError(f"{p}: cannot read the mesh: {exc}") from exc
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise SandboxError(f"{p}: the file holds no triangles")
    v = np.asarray(loaded.vertices, float)
    f = np.asarray(loaded.faces, np.int64)
    height = float(np.ptp(v[:, 1]))
    for lo, hi, scale in ((1.0, 2.5, 1.0), (100.0, 250.0, 0.01), (1000.0, 2500.0, 0.001)):
        if lo <= height <= hi:
            v = v * scale
            break
    else:
        raise SandboxError(
            f"{p}: body height {height:g} is not 1-2.5 m, 100-250 cm or 1000-2500 mm (is Y up?)"
        )
    if not loaded.is_watertight:
        log.warning("%s: mesh is not watertight; sections may be open", p)
    v[:, 1] -= v[:, 1].min()
    y = v[:, 1]
    band = v[(y > 0.5 * y.max()) & (y < 0.6 * y.max())]
    v[:, 0] -= np.median(band[:, 0])
    v[:, 2] -= np.median(band[:, 2])
    try:
        lm = detect_landmarks(v, f)
        got = measure(v, f, lm)
    except SandboxError as exc:
        raise SandboxError(f"{p}: {exc}") from exc
    return Mannequin(
        vertices=v,
        triangles=f,
        landmarks=lm,
        feature_lines={},
        measurements_requested=Measurements(**{k: round(got[k], 2) for k in KEYS}),
        size=None,
        resolution=0,
        shape=None,
    )


def _line_color(name: str):
    if name.endswith("girth") or name.startswith("neck"):
        return LINE_COLORS["girth"]
    if name.startswith(("shoulder", "armhole")):
        return LINE_COLORS["neck_shoulder"]
    return LINE_COLORS["vertical"]


def render_mannequin_png(path: Path, meshes: list, lines: list, **kw) -> Path:
    """Off-screen PNG through :func:`sandbox.render.offscreen.render_png`."""
    try:
        from sandbox.render.offscreen import render_png
    except ImportError as exc:
        raise SandboxError(
            f"{path}: the off-screen renderer sandbox.render.offscreen is not available ({exc})"
        ) from exc
    return render_png(path, meshes, lines=lines, **kw)


def mannequin_png(mannequin, path: Path, *, views=("front", "side", "back")) -> Path:
    """PNG of the body with its feature lines (girths red, verticals blue, shoulder green)."""
    mesh = {
        "vertices": mannequin.vertices,
        "triangles": mannequin.triangles,
        "color": BODY_COLOR,
    }
    lines = [
        {"points": pts, "color": _line_color(name)} for name, pts in mannequin.feature_lines.items()
    ]
    return render_mannequin_png(Path(path), [mesh], lines, views=views, width=480, height=640)


def write_mannequin(mannequin, out_dir: str | Path, *, png: bool = True, mesh_name="mannequin.obj"):
    """Write mesh, ``landmarks.json``, ``measurements.json`` (and a PNG) into ``out_dir``.

    The tape measure is run on the written mesh's vertices; each of the seven keys gets
    ``{"requested": cm, "measured": cm}``. Every file is written atomically and the PNG
    (the step most likely to fail) first, so a failure leaves no half-written mesh.
    """
    import trimesh

    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise SandboxError(f"{out}: --out exists and is not a directory")
    measured = mannequin.measure()
    req = mannequin.measurements_requested.to_dict()
    meas = {k: {"requested": round(req[k], 3), "measured": round(measured[k], 3)} for k in KEYS}
    written = []
    if png:
        written.append(mannequin_png(mannequin, out / "mannequin.png"))
    mesh_path = out / mesh_name
    with atomic_path(mesh_path) as tmp:
        trimesh.Trimesh(mannequin.vertices, mannequin.triangles, process=False).export(tmp)
    written.append(mesh_path)
    landmarks = {
        "units": "m",
        "axes": "Y up, front +Z, body left +X, floor y = 0",
        "landmarks": {k: np.round(p, 6).tolist() for k, p in mannequin.landmarks.items()},
        "feature_lines": {k: np.round(p, 6).tolist() for k, p in mannequin.feature_lines.items()},
    }
    written.append(write_json(out / "landmarks.json", landmarks))
    doc = {"units": "cm", "size": mannequin.size, **meas}
    written.append(write_json(out / "measurements.json", doc))
    return written
