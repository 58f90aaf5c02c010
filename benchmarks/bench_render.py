"""Time per image of ``python -m sandbox render`` (sandbox.render.studio.Studio).

Usage: python benchmarks/bench_render.py [--size 400] [--frames 12] [--backend open3d]

The scene is a capsule as the body and an open, subdivided tube as the garment
(4,618 vertices together). Prints seconds per view and per
turntable frame.
"""

import argparse
import time

import numpy as np
import trimesh

from sandbox.render.studio import Studio


def scene():
    body = trimesh.creation.capsule(height=1.2, radius=0.15, count=[48, 48])
    body.apply_translation([0, 0.9, 0])
    tube = trimesh.creation.cylinder(radius=0.2, height=0.5, sections=96)
    keep = np.abs(tube.face_normals[:, 1]) < 0.5
    tube = trimesh.Trimesh(tube.vertices, tube.faces[keep], process=False)
    tube = tube.subdivide().subdivide()
    tube.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    tube.apply_translation([0, 0.8, 0])
    return (tube.vertices, tube.faces), (body.vertices, body.faces)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--size", type=int, default=400)
    p.add_argument("--frames", type=int, default=12)
    p.add_argument("--backend", choices=("open3d", "numpy"), default="open3d")
    a = p.parse_args()
    garment, body = scene()
    studio = Studio(garment, body, size=(a.size, a.size), backend=a.backend)
    studio.view("front")  # warm-up (context creation)
    t0 = time.perf_counter()
    for v in ("front", "back", "side"):
        studio.view(v)
    t1 = time.perf_counter()
    studio.turntable(a.frames)
    t2 = time.perf_counter()
    nv = len(garment[0]) + len(body[0])
    print(f"{nv} vertices, {a.size} x {a.size}, backend {studio.backend}")
    print(f"views: {(t1 - t0) / 3:.3f} s each; turntable: {(t2 - t1) / a.frames:.3f} s/frame")


if __name__ == "__main__":
    main()
