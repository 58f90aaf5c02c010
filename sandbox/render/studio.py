"""Open3D renders of saved results: lit, smooth-shaded, front / back / side and a turntable.

``python -m sandbox render RESULT_DIR`` reads the garment and body a drape or run wrote
(``garment.glb``, else ``garment.obj`` or ``mesh.obj``; ``body.obj`` if present) and
renders them (see :class:`Studio`). Y is up and the body faces +Z. A garment read from
``garment.glb`` wears the woven check along its grain (:mod:`sandbox.render.fabric`);
``--strain`` draws the strain maps of :mod:`sandbox.render.strain` instead
(``strain_front.png``, ...), which need the rest shape the glTF carries.

Views: ``front`` (camera on +Z), ``back`` (-Z), ``side`` (+X); ``--turntable N`` renders N
frames around the Y axis and writes them as a GIF (and an MP4 with ``--mp4``, through
imageio's ffmpeg plugin). Every file is written to a temporary name and renamed.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

from sandbox.errors import SandboxError

GARMENT_COLOUR = (0.22, 0.42, 0.78, 1.0)
BODY_COLOUR = (0.80, 0.72, 0.64, 1.0)
BACKGROUND = (1.0, 1.0, 1.0, 1.0)
VIEW_DIRECTIONS = {"front": (0.0, 0.0, 1.0), "back": (0.0, 0.0, -1.0), "side": (1.0, 0.0, 0.0)}
GARMENT_NAMES = ("garment.glb", "garment.obj", "garment.ply", "mesh.obj", "mesh.ply")


class Studio:
    """A garment and (optionally) a body, rendered lit and smooth-shaded with Open3D.

    Args: garment, body: ``(vertices (n, 3) [m], triangles (m, 3))`` or None;
    size: (width, height) pixels; backend: "open3d" (the legacy Visualizer on headless
    EGL) or "numpy" (the software rasteriser of :mod:`sandbox.render.offscreen`: the same
    shading, for machines where Open3D cannot open a context).

    Shading (the same for both backends, :mod:`sandbox.render.offscreen`): area-weighted
    vertex normals, two-sided Lambert from a light above-left behind the camera plus
    ambient, interpolated over each triangle (Gouraud): the body matte skin-coloured, the
    garment in the fabric colour, both sides of the cloth lit.

    Open3D's Filament renderer (``OffscreenRenderer``, physically based) was tried first:
    it runs here on lavapipe, but a body and a garment together took 50-250 s per frame in
    software (one of them alone about a second), so it is not used.
    """

    def __init__(self, garment, body=None, *, size=(800, 800), backend: str = "open3d",
                 material_uv=None):  # fmt: skip
        self.size = (int(size[0]), int(size[1]))
        self.material_uv = None if material_uv is None else np.asarray(material_uv, float)
        self.backend = backend
        self.garment = (np.asarray(garment[0], float), np.asarray(garment[1], np.int64))
        self.body = None
        if body is not None:
            self.body = (np.asarray(body[0], float), np.asarray(body[1], np.int64))
        pts = [self.garment[0]] + ([self.body[0]] if self.body is not None else [])
        allp = np.vstack(pts)
        self.lo, self.hi = allp.min(axis=0), allp.max(axis=0)
        self.centre = 0.5 * (self.lo + self.hi)

    def _meshes(self, angle_rad: float = 0.0) -> list[dict]:
        c, s = math.cos(angle_rad), math.sin(angle_rad)
        rot = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])

        def turn(v):
            return (v - self.centre) @ rot.T + self.centre

        out = []
        if self.body is not None:
            out.append({"vertices": turn(self.body[0]), "triangles": self.body[1],
                        "color": BODY_COLOUR[:3]})  # fmt: skip
        garment = {"vertices": turn(self.garment[0]), "triangles": self.garment[1],
                   "color": GARMENT_COLOUR[:3]}  # fmt: skip
        if self.material_uv is not None:
            from sandbox.render.fabric import textured_mesh

            pixel_m = float((self.hi - self.lo).max()) / min(self.size)
            garment = textured_mesh(garment["vertices"], garment["triangles"], self.material_uv,
                                    GARMENT_COLOUR[:3], pixel_m=pixel_m)  # fmt: skip
        out.append(garment)
        return out

    def _render(self, meshes, view: str) -> np.ndarray:
        from sandbox.render.offscreen import render_image

        w, h = self.size
        try:
            return render_image(meshes, views=(view,), width=w, height=h,
                                background=BACKGROUND[:3], backend=self.backend)  # fmt: skip
        except SandboxError:
            if self.backend == "numpy":
                raise
            self.backend = "numpy"  # no OpenGL context here: the same picture in software
            return self._render(meshes, view)

    def view(self, name: str) -> np.ndarray:
        """An RGB uint8 image (height, width, 3) of one view: front, back or side."""
        if name not in VIEW_DIRECTIONS:
            raise SandboxError(f"unknown view {name!r}: choose from {', '.join(VIEW_DIRECTIONS)}")
        return self._render(self._meshes(), name)

    def turntable(self, frames: int = 36) -> list[np.ndarray]:
        """``frames`` front views of the scene turned about the vertical axis, from the front."""
        return [self._render(self._meshes(-2.0 * math.pi * k / frames), "front")
                for k in range(int(frames))]  # fmt: skip


def find_meshes(result: Path) -> tuple[Path, Path | None]:
    """The garment mesh and the body mesh (or None) in a result directory."""
    if not result.is_dir():
        raise SandboxError(f"{result}: no such result directory")
    for name in GARMENT_NAMES:
        if (result / name).is_file():
            body = result / "body.obj"
            return result / name, body if body.is_file() else None
    raise SandboxError(f"{result}: no garment mesh (looked for {', '.join(GARMENT_NAMES)})")


def write_image(path: Path, img: np.ndarray) -> Path:
    import imageio.v3 as iio

    from sandbox.atomic import atomic_path

    with atomic_path(path) as tmp:
        iio.imwrite(tmp, img, extension=path.suffix)
    return path


def write_video(path: Path, frames: list[np.ndarray], fps: float) -> Path:
    """A GIF (looping) or an MP4 (H.264 through imageio-ffmpeg), atomically."""
    import imageio.v3 as iio

    from sandbox.atomic import atomic_path

    with atomic_path(path) as tmp:
        if path.suffix == ".gif":
            iio.imwrite(tmp, frames, extension=".gif", duration=1000.0 / fps, loop=0)
        else:
            import imageio.v2 as iio2

            writer = iio2.get_writer(tmp, format="FFMPEG", fps=fps, codec="libx264",
                                     macro_block_size=1)  # fmt: skip
            for f in frames:
                writer.append_data(f)
            writer.close()
    return path


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m sandbox render",
        description="Lit, smooth-shaded Open3D renders of a saved result (garment and body): "
        "front, back, side and a turntable, to PNG, GIF and MP4.",
        epilog="Example: python -m sandbox drape t-shirt --out out/t && "
        "python -m sandbox render out/t --turntable 36 --mp4",
    )
    p.add_argument("result", nargs="?", type=Path, default=None,
                   help="a directory written by drape/run/demo (garment.obj or mesh.obj, "
                   "body.obj)")  # fmt: skip
    p.add_argument("--garment", type=Path, default=None, help="garment mesh file instead")
    p.add_argument("--body", type=Path, default=None, help="body mesh file")
    p.add_argument("--views", nargs="+", default=["front", "back", "side"],
                   help="views to render (front back side)")  # fmt: skip
    p.add_argument("--size", type=int, nargs=2, default=[800, 800], metavar=("W", "H"))
    p.add_argument("--turntable", type=int, default=0, metavar="N",
                   help="also N frames around the body (GIF)")  # fmt: skip
    p.add_argument("--fps", type=float, default=12.0, help="turntable frame rate")
    p.add_argument("--mp4", action="store_true", help="the turntable as MP4 too")
    p.add_argument("--out", type=Path, default=None, help="output directory (default: RESULT)")
    p.add_argument("--strain", action="store_true",
                   help="strain maps instead (stretch along warp and weft, shear; Eq. 6, in "
                   "%%): strain_VIEW.png; needs the garment.glb a drape writes")  # fmt: skip
    p.add_argument("--backend", choices=("open3d", "numpy"), default="open3d",
                   help="open3d (default; falls back to numpy without a GL context)")  # fmt: skip
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        from sandbox.atomic import make_dir
        from sandbox.preflight import check_render
        from sandbox.render import read_mesh

        check_render(args)
        if args.garment is None:
            if args.result is None:
                raise SandboxError("give a result directory or --garment FILE")
            garment_path, body_path = find_meshes(args.result)
        else:
            garment_path, body_path = args.garment, args.body
        if args.body is not None:
            body_path = args.body
        out = args.out or args.result or garment_path.parent
        make_dir(out)
        material_uv = None
        if garment_path.suffix.lower() == ".glb":
            from sandbox.render.export import read_glb_garment

            try:
                *garment, material_uv = read_glb_garment(garment_path)
            except SandboxError:  # a glTF from elsewhere: its meshes merged, untextured
                garment = read_mesh(garment_path)
        else:
            garment = read_mesh(garment_path)
        body = read_mesh(body_path) if body_path is not None else None
        t0 = time.perf_counter()
        if args.strain:
            return _strain_maps(args, out, garment, body, material_uv, garment_path, t0)
        studio = Studio(garment, body, size=args.size, backend=args.backend,
                        material_uv=material_uv)  # fmt: skip
        written = []
        for v in args.views:
            written.append(write_image(out / f"studio_{v}.png", studio.view(v)))
        if args.turntable:
            frames = studio.turntable(args.turntable)
            written.append(write_video(out / "turntable.gif", frames, args.fps))
            if args.mp4:
                written.append(write_video(out / "turntable.mp4", frames, args.fps))
        n = len(args.views) + max(0, args.turntable)
        print(f"rendered {n} images in {time.perf_counter() - t0:.1f} s ({studio.backend})")
        for w in written:
            print(f"  {w}")
        return 0
    except SandboxError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


def _strain_maps(args, out: Path, garment, body, material_uv, garment_path: Path, t0) -> int:
    from sandbox.render.strain import strain_figure

    if material_uv is None:
        raise SandboxError(f"{garment_path}: --strain needs the rest shape along warp and weft, "
                           "which garment.glb carries (written by drape)")  # fmt: skip
    written, summary = [], {}
    for v in args.views:
        if v not in VIEW_DIRECTIONS:
            raise SandboxError(f"unknown view {v!r}: choose from {', '.join(VIEW_DIRECTIONS)}")
        img, summary = strain_figure(garment[0], garment[1], material_uv, body=body, view=v,
                                     size=min(args.size), backend=args.backend)  # fmt: skip
        written.append(write_image(out / f"strain_{v}.png", img))
    print(f"rendered {len(written)} strain maps in {time.perf_counter() - t0:.1f} s")
    for name, s in summary.items():
        print(
            f"  {name:5s}: {s['min_percent']:+.1f} to {s['max_percent']:+.1f} %, 99 % of "
            f"triangles within ±{s['p99_percent']:.1f} % (scale ±{s['scale_percent']:.1f} %)"
        )
    for w in written:
        print(f"  {w}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
