"""Collider meshes for scenes: analytic shapes tessellated by trimesh, files, the mannequin.

All return ``(vertices (m, 3) float64 [m], triangles (k, 3) int64, closed: bool)`` with
faces oriented outwards.
"""

from __future__ import annotations

import numpy as np
import trimesh

from sandbox.errors import SandboxError


def sphere(center, radius: float, subdivisions: int = 4):
    m = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    return m.vertices + np.asarray(center, float), np.asarray(m.faces, np.int64), True


def box(center, size, rotation: np.ndarray | None = None, subdivisions: int = 3):
    m = trimesh.creation.box(extents=size)
    for _ in range(subdivisions):  # smaller triangles keep the grid cells balanced
        m = m.subdivide()
    v = np.asarray(m.vertices)
    if rotation is not None:
        v = v @ rotation.T
    return v + np.asarray(center, float), np.asarray(m.faces, np.int64), True


def cylinder(center, radius: float, height: float, rotation: np.ndarray | None = None,
             sections: int = 48):  # fmt: skip
    """A capped cylinder whose axis is Y before ``rotation``."""
    m = trimesh.creation.cylinder(radius=radius, height=height, sections=sections)
    v = np.asarray(m.vertices)[:, [0, 2, 1]] * np.array([1.0, 1.0, -1.0])  # axis z -> y
    f = np.asarray(m.faces, np.int64)
    mesh = trimesh.Trimesh(v, f, process=False)
    mesh.fix_normals()
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces, np.int64)
    if rotation is not None:
        v = v @ rotation.T
    return v + np.asarray(center, float), f, True


def plane(point, normal, size: float = 10.0, divisions: int = 8):
    """A square of side ``size`` through ``point`` facing ``normal`` (an open surface)."""
    n = np.asarray(normal, float)
    if np.linalg.norm(n) == 0:
        raise SandboxError("plane collider: the normal must not be zero")
    n = n / np.linalg.norm(n)
    a = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(n, a)
    g = np.linspace(-0.5 * size, 0.5 * size, divisions + 1)
    gu, gv = np.meshgrid(g, g, indexing="ij")
    v = np.asarray(point, float) + gu.reshape(-1, 1) * a + gv.reshape(-1, 1) * b
    tris = []
    for i in range(divisions):
        for j in range(divisions):
            p = i * (divisions + 1) + j
            tris += [(p, p + divisions + 1, p + 1), (p + 1, p + divisions + 1, p + divisions + 2)]
    f = np.asarray(tris, np.int64)
    # orient so that the face normals point along n
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    if np.dot(fn.sum(axis=0), n) < 0:
        f = f[:, [0, 2, 1]]
    return v, f, False


def mesh_file(path, *, where: str):
    from sandbox.render.meshio import read_mesh

    v, f = read_mesh(path)
    m = trimesh.Trimesh(v, f, process=False)
    closed = bool(m.is_watertight and m.is_winding_consistent)
    if closed and m.volume < 0:
        f = f[:, [0, 2, 1]]
    return np.asarray(v, float), np.asarray(f, np.int64), closed


def mannequin(size: int | None = None, measurements: dict | None = None):
    from sandbox.mannequin import build_mannequin

    kwargs = {}
    if size is not None:
        kwargs["size"] = size
    if measurements:
        from sandbox.mannequin import Measurements

        kwargs["measurements"] = Measurements.from_dict(measurements)
    body = build_mannequin(**kwargs)
    return np.asarray(body.vertices, float), np.asarray(body.triangles, np.int64), True
