"""Checks that run before anything heavy: output paths, window sizes, numbers and names.

Every command checks its flags, input files and output paths with these before Taichi
starts or a mesh is built, so a mistake costs a second and not a simulation. Each check
raises :class:`~sandbox.errors.SandboxError` with one line naming the flag (or file), the
value and the problem. docs/errors.md lists what each command checks here and what later.
"""

from __future__ import annotations

import logging
import math
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

from sandbox.errors import SandboxError

RUN_OUTPUTS = ("mesh.obj", "mesh.ply", "render.png", "metrics.json")
"""Files ``run`` (and ``demo --scene``) writes into --out."""
DRAPE_OUTPUTS = ("garment.obj", "garment.ply", "body.obj", "render.png", "render_back.png",
                 "metrics.json")  # fmt: skip
"""Files ``drape`` (and ``demo``) writes into --out."""


@dataclass(frozen=True)
class WindowLimits:
    """Accepted window and image sizes [pixels], each side.

    Below ``min_px`` the window's sliders and text do not fit (and 0 aborts Vulkan's
    swapchain); above ``max_px`` the image exceeds what Vulkan guarantees and most GPUs
    and the software rasteriser (llvmpipe) accept (``maxImageDimension2D``, 8192 or more
    on common hardware; the specification promises 4096): larger sizes abort inside the
    driver. An 8192 x 8192 RGBA frame is already 256 MiB.
    """

    min_px: int = 64
    max_px: int = 8192


WINDOW_LIMITS = WindowLimits()


# --------------------------------------------------------------------------- paths
def _nearest_existing(path: Path, flag: str) -> Path:
    """The path itself or its nearest existing ancestor; refuse a file among its parents."""
    probe = path
    while True:
        try:
            if probe.is_symlink() and not probe.exists():
                raise SandboxError(f"{flag} {path}: {probe} is a broken symbolic link")
            if probe.exists():
                break
        except OSError as exc:
            raise SandboxError(f"{flag} {path}: cannot look at {probe} ({exc.strerror})") from None
        if probe.parent == probe:
            break
        probe = probe.parent
    if probe != path and not probe.is_dir():
        raise SandboxError(f"{flag} {path}: {probe} is a file, not a directory")
    return probe


def _check_writable(folder: Path, flag: str, path: Path) -> None:
    """Create and remove a scratch file in ``folder``: the only test that also holds for
    root, read-only mounts and full disks."""
    if not os.access(folder, os.W_OK | os.X_OK):
        raise SandboxError(f"{flag} {path}: no permission to write in {folder}")
    try:
        fd, scratch = tempfile.mkstemp(prefix=".sandbox-write-test.", dir=folder)
    except OSError as exc:
        raise SandboxError(f"{flag} {path}: cannot write in {folder} ({exc.strerror})") from None
    os.close(fd)
    os.unlink(scratch)


def check_output_dir(path, flag: str = "--out", *, names: tuple[str, ...] = ()) -> Path:
    """Refuse an output directory that cannot be created or written.

    ``path`` may exist (a directory) or not (it is created later, with its parents); no
    regular file may stand at the path or on its parents, and the nearest existing folder
    must be writable. ``names``: files that will be written inside; none may be a folder.
    Nothing is created.
    """
    p = Path(path)
    if str(path) == "":
        raise SandboxError(f"{flag}: an empty path")
    existing = _nearest_existing(p, flag)
    if existing == p:
        if not p.is_dir():
            raise SandboxError(f"{flag} {p}: exists and is not a directory")
        for name in names:
            if (p / name).is_dir():
                raise SandboxError(f"{flag} {p}: {p / name} is a directory; it must be a file")
    _check_writable(existing, flag, p)
    return p


def check_output_file(path, flag: str = "--out", *, suffixes: tuple[str, ...] = ()) -> Path:
    """Refuse an output file that cannot be written: a folder, a device or other special
    file, a regular file among its parents, an unwritable folder; ``suffixes`` (e.g.
    ``(".json",)``) are the accepted endings, when given. Nothing is created."""
    p = Path(path)
    if str(path) == "":
        raise SandboxError(f"{flag}: an empty path")
    existing = _nearest_existing(p, flag)
    if existing == p:
        if p.is_dir():
            raise SandboxError(f"{flag} {p}: is a directory; give a file name")
        if not p.is_file():
            raise SandboxError(f"{flag} {p}: exists and is not a regular file")
        folder = p.parent
    else:
        folder = existing
    if suffixes and p.suffix.lower() not in suffixes:
        raise SandboxError(f"{flag} {p}: must end in {' or '.join(suffixes)}")
    _check_writable(folder, flag, p)
    return p


def check_input_file(path, flag: str, what: str = "file") -> Path:
    """Refuse an input file that does not exist or is a folder."""
    p = Path(path)
    if not p.is_file():
        problem = "is a directory" if p.is_dir() else f"no such {what}"
        raise SandboxError(f"{flag} {p}: {problem}")
    return p


# --------------------------------------------------------------------------- numbers
def check_positive(value, flag: str, *, minimum: float | None = None) -> None:
    """Refuse a number that is not finite and > 0 (or >= ``minimum`` when given)."""
    if value is None:
        return
    if minimum is not None:
        if not (math.isfinite(value) and value >= minimum):
            raise SandboxError(f"{flag} {value}: must be a number >= {minimum:g}")
    elif not (math.isfinite(value) and value > 0):
        raise SandboxError(f"{flag} {value}: must be a positive number")


def check_window_size(width: int, height: int, flag: str = "--width/--height", *,
                      limits: WindowLimits = WINDOW_LIMITS) -> None:  # fmt: skip
    """Refuse a window or image size outside ``limits`` (see :class:`WindowLimits`)."""
    for side in (width, height):
        if not limits.min_px <= side <= limits.max_px:
            raise SandboxError(f"{flag} {width}x{height}: each side must be "
                               f"{limits.min_px}-{limits.max_px} pixels")  # fmt: skip


# --------------------------------------------------------------------------- names
def check_size(size, flag: str = "--size") -> None:
    """Refuse a mannequin size that is not in the database."""
    if size is None:
        return
    from sandbox.mannequin.measurements import load_size_table

    sizes = [e.size for e in load_size_table()]
    if size not in sizes:
        raise SandboxError(f"{flag} {size}: not in the size database (sizes {sizes})")


def check_measurements(args) -> None:
    """Refuse measurement flags outside the supported ranges or contradicting each other."""
    from sandbox.mannequin.cli import FLAGS
    from sandbox.mannequin.measurements import KEYS, size_entry, validate

    given = {k: getattr(args, k) for k in KEYS if getattr(args, k, None) is not None}
    check_size(getattr(args, "size", None))
    if given:
        size = args.size if args.size is not None else 12
        validate(size_entry(size).measurements.replace(**given), flag_names=FLAGS)


def check_fabric(name, flag: str = "--fabric") -> None:
    """Refuse an unknown fabric preset."""
    if name is None:
        return
    from sandbox.sim.materials import get_material

    get_material(name, where=flag)


# --------------------------------------------------------------------------- commands
def check_drape(args) -> None:
    """``drape`` and ``demo``: --out, the body, the fabric and a pattern file's content."""
    check_output_dir(args.out, "--out", names=DRAPE_OUTPUTS)
    check_positive(args.edge_cm, "--edge-cm")
    check_measurements(args)
    check_fabric(args.fabric)
    check_pattern_file(args.garment, args.fabric)


def check_pattern_file(garment, fabric=None) -> None:
    """Read and check a pattern file and the fabric it will be draped in (a library
    garment's name passes: it is drafted from checked data); a fabric whose constants are
    valid but odd gets one warning each (logger ``sandbox.pattern``,
    :mod:`sandbox.scene.plausible`)."""
    path = Path(str(garment))
    if path.is_file():
        from sandbox.garment.inputs import material_for
        from sandbox.pattern.spec import load_pattern
        from sandbox.scene.plausible import material_warnings

        pattern = load_pattern(path)
        material = material_for(pattern, fabric)
        where = f"{pattern.source}: fabric" if fabric is None else "--fabric"
        for text in material_warnings(material, where):
            logging.getLogger("sandbox.pattern").warning("%s", text)


def check_gallery(args) -> None:
    """``gallery``: --out, --size, --jobs, --edge-cm and the --only names."""
    check_output_dir(args.out, "--out")
    check_size(args.size)
    if args.jobs < 1:
        raise SandboxError(f"--jobs {args.jobs}: must be at least 1")
    check_positive(args.edge_cm, "--edge-cm")
    if args.only:
        from sandbox.garment import garment_names

        names = garment_names()
        unknown = [n for n in args.only if n not in names]
        if unknown:
            raise SandboxError(f"--only {unknown[0]}: not a library garment ({', '.join(names)})")


def check_validate(args) -> None:
    """``validate``: cusick's --out and presets, the cantilever's λ values."""
    for lam in args.lambdas or []:
        check_positive(lam, "--lambdas")
    if args.case == "cusick":
        check_output_dir(args.out or Path("out/validate-cusick"), "--out")
        for name in args.presets or []:
            check_fabric(name, "--presets")


def check_mannequin(args) -> None:
    """``mannequin``: --out, --resolution, --body, --size and the measurements."""
    check_output_dir(args.out, "--out")
    if args.resolution is not None and (args.resolution % 16 or not 32 <= args.resolution <= 128):
        raise SandboxError(f"--resolution {args.resolution}: must be a multiple of 16 in 32-128")
    if args.body is not None:
        check_input_file(args.body, "--body", "body mesh file")
    check_measurements(args)


def check_render(args) -> None:
    """``render``: --out (or the result folder it defaults to), --size, --turntable, --fps."""
    width, height = args.size
    check_window_size(width, height, "--size")
    if args.turntable < 0:
        raise SandboxError(f"--turntable {args.turntable}: must be 0 (none) or a frame count")
    check_positive(args.fps, "--fps")
    for flag, path in (("--garment", args.garment), ("--body", args.body)):
        if path is not None:
            check_input_file(path, flag, "mesh file")
    out = args.out or args.result or (args.garment.parent if args.garment else None)
    if out is not None:
        check_output_dir(out, "--out" if args.out else "RESULT")


def check_gui(args) -> list | None:
    """``gui``: every flag and the script's content; returns the script's actions."""
    check_window_size(args.width, args.height)
    check_positive(args.fps, "--fps")
    check_positive(args.sim_ms, "--sim-ms")
    check_positive(args.edge_cm, "--edge-cm")
    check_positive(getattr(args, "newton", None), "--newton", minimum=1)
    check_positive(getattr(args, "steps", None), "--steps", minimum=1)
    check_size(args.size)
    check_fabric(args.fabric)
    from sandbox.garment.inputs import check_garment

    check_garment(args.garment)
    check_pattern_file(args.garment, args.fabric)
    if args.offscreen and args.script is None:
        raise SandboxError("--offscreen needs --script FILE (a JSON list of actions)")
    if args.script is None:
        return None
    from sandbox.app.script import check_script_edges, load_script

    actions = load_script(args.script)
    if any("sew" in a or "click_edge" in a for a in actions):
        check_script_edges(actions, _pattern_of(args), args.script)
    if args.offscreen:
        check_output_dir(args.out, "--out", names=("summary.json", "session.gif"))
    return actions


def _pattern_of(args):
    """The window's pattern, loaded or drafted (for the size given) without Taichi."""
    from sandbox.pattern.spec import load_pattern

    path = Path(str(args.garment))
    if path.is_file():
        return load_pattern(path)
    from sandbox.drafting import draft
    from sandbox.mannequin.measurements import size_entry

    name = str(args.garment)
    data = draft(name, size_entry(args.size if args.size is not None else 12).measurements)
    return load_pattern(data, where=f"garment {name!r}")
