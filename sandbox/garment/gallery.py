"""The garment gallery (paper Fig. 7): drape every library garment, one contact sheet.

``python -m sandbox gallery [--out docs/gallery] [--quick]`` drapes each garment of
:func:`sandbox.drafting.garment_names` on one mannequin and writes into ``--out``:

* ``gallery.png``: the front views in a grid, each with the garment's name;
* ``gallery.md``: a Markdown table (garment, vertices, wall time, converged, seam gap,
  vertices inside the body, intersecting triangle pairs, ease at bust/waist/hip);
* ``gallery.json``: the same rows as JSON;
* ``<garment>/``: ``render.png``, ``render_back.png`` and ``metrics.json`` (and the meshes
  with ``meshes=True``).

A garment that fails (bad pattern, diverged run) gets a row saying why; the others go on.
With ``resume=True`` (``--resume``) a garment whose ``<garment>/metrics.json`` and
``render.png`` are already in ``--out`` for the same mannequin size, mesh edge and fabric is
read back instead of draped again: an interrupted gallery goes on where it stopped, and a
sheet can be put together from drapes run one by one (``python -m sandbox drape GARMENT
--out DIR/GARMENT``, or ``benchmarks/bench_drape.py``, whose output folders have the same
files).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from pathlib import Path

import numpy as np

from sandbox import runtime
from sandbox.errors import SandboxError

log = logging.getLogger(__name__)

QUICK_EDGE_M = 0.03
QUICK_FABRIC = "jersey"
QUICK_TIME_LIMIT_S = 4.0
TILE_PX = 320
COLUMNS = 5


def gallery(
    out_dir="docs/gallery",
    *,
    quick: bool = False,
    size: int = 12,
    names: list[str] | None = None,
    edge_length_m: float | None = None,
    meshes: bool = False,
    progress: bool = True,
    resume: bool = False,
    jobs: int = 1,
    integrator: str = "symplectic_euler",
    method: str = "coarse_to_fine",
) -> list[Path]:
    """Drape the library's garments and write the contact sheet and the table.

    ``quick``: 3 cm meshes, every garment in jersey (soft: large explicit steps), 4 s limit.
    ``resume``: read back a garment already draped in ``out_dir`` with the same settings
    (:func:`earlier_drape`). ``jobs`` > 1: drape that many garments at once, each in its
    own ``python -m sandbox drape`` process (:func:`drape_in_processes`) with the CPU's
    threads shared out, then read them back. ``integrator``: ``"implicit_euler"`` drapes
    with backward Euler, on 3 cm meshes unless ``edge_length_m`` says otherwise
    (:data:`~sandbox.garment.config.IMPLICIT_GARMENT_EDGE_M`). ``method``: the
    :attr:`DrapeConfig.method` (``"direct"``: sew and drape the mesh itself). Returns the
    written paths (sheet, table, JSON).
    """
    from sandbox.garment import DrapeConfig, default_edge_m
    from sandbox.garment.pipeline import method_run

    chosen = _chosen_garments(names, jobs, integrator)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    edge = edge_length_m
    if edge is None:
        edge = QUICK_EDGE_M if quick else default_edge_m(integrator)
    fabric = QUICK_FABRIC if quick else None
    time_limit_s = QUICK_TIME_LIMIT_S if quick else None
    config = DrapeConfig(integrator=integrator, method=method)
    if time_limit_s is not None:
        config = dataclasses.replace(config, time_limit_s=time_limit_s)

    ran = method_run(edge, config)  # a 3 cm drape is direct whatever the method

    def read_back(names):  # {name: (metrics, front image)} of those already in out
        found = {n: earlier_drape(out / n, n, size, edge, fabric, integrator, ran)
                 for n in names}  # fmt: skip
        return {n: got for n, got in found.items() if got is not None}

    earlier = read_back(chosen) if resume else {}
    draped: dict = {}  # drapes run in their own processes (jobs > 1), read back
    failed: dict[str, str] = {}
    if jobs > 1:
        todo = [n for n in chosen if n not in earlier]
        failed = drape_in_processes(todo, out, size=size, edge_length_m=edge, jobs=jobs,
                                    meshes=meshes, progress=progress, fabric=fabric,
                                    time_limit_s=time_limit_s,
                                    integrator=integrator, method=method)  # fmt: skip
        draped = read_back([n for n in todo if n not in failed])
    rows, tiles = [], []
    here = _InProcess(out, size=size, edge_length_m=edge, fabric=fabric, config=config,
                      meshes=meshes)  # fmt: skip
    for i, name in enumerate(chosen):
        if name in failed:
            rows.append({"garment": name, "error": failed[name], "wall_time_s": 0.0})
            tiles.append((name, None))
            continue
        got = earlier.get(name) or draped.get(name)
        if got is not None:
            m, tile = got
            rows.append(_row(name, m))
            tiles.append((name, tile))
            if progress and name in earlier:
                print(f"[{i + 1}/{len(chosen)}] {name}: read back from {out / name} "
                      f"({m['vertex_count']} vertices, {rows[-1]['wall_time_s']:.0f} s then)",
                      flush=True)  # fmt: skip
            continue
        if progress:
            print(f"[{i + 1}/{len(chosen)}] {name} ...", flush=True)
        row, tile = here.drape(name)
        rows.append(row)
        tiles.append((name, tile))
        if progress and "error" not in row:
            print(f"    {row['vertices']} vertices, {row['wall_time_s']:.0f} s, converged "
                  f"{row['converged']}, seam gap {_mm(row['seam_gap_max_m'])} mm, inside "
                  f"{row['vertices_inside_body']}, pairs {row['intersecting_triangle_pairs']}",
                  flush=True)  # fmt: skip
    header = _header(out_dir=out_dir, size=size, edge_m=edge, quick=quick,
                     integrator=integrator, method=method, jobs=jobs, read_back=len(earlier),
                     total=len(chosen))  # fmt: skip
    return [
        write_sheet(out / "gallery.png", tiles),
        write_table(out / "gallery.md", rows, header),
        _write_json(out / "gallery.json", rows, header),
    ]


def _chosen_garments(names, jobs, integrator) -> list[str]:
    """The library garments to drape (all by default), after checking the arguments."""
    from sandbox.garment import garment_names
    from sandbox.scene.spec import INTEGRATORS

    library = garment_names()
    chosen = list(names) if names else library
    unknown = [n for n in chosen if n not in library]
    if unknown:
        raise SandboxError(f"gallery: unknown garment(s) {', '.join(unknown)}; the library has "
                           f"{', '.join(library)}")  # fmt: skip
    if not (isinstance(jobs, int) and jobs >= 1):
        raise SandboxError(f"gallery: jobs must be a whole number >= 1, got {jobs!r}")
    if integrator not in INTEGRATORS:
        raise SandboxError(f"gallery: integrator must be one of {', '.join(INTEGRATORS)}, got "
                           f"{integrator!r}")  # fmt: skip
    return chosen


class _InProcess:
    """Drapes garments one after the other in this process, on one mannequin (built for the
    first); a garment that fails gets a row saying why."""

    def __init__(self, out: Path, *, size, edge_length_m, fabric, config, meshes):
        self.out, self.size, self.edge = out, size, edge_length_m
        self.fabric, self.config, self.meshes = fabric, config, meshes
        self.mannequin = None

    def drape(self, name: str) -> tuple[dict, np.ndarray | None]:
        """(table row, front tile or None) of one garment."""
        from sandbox.garment import drape, make_mannequin

        t0 = time.perf_counter()
        runtime.recycle()  # the garments before are written out: free Taichi's field trees
        self.mannequin = self.mannequin or make_mannequin(self.size)
        try:
            res = drape(name, mannequin=self.mannequin, out_dir=self.out / name,
                        edge_length_m=self.edge, fabric=self.fabric, config=self.config,
                        progress=False, meshes=self.meshes)  # fmt: skip
        except SandboxError as exc:  # includes SimulationDiverged
            log.warning("%s: %s", name, exc)
            return {"garment": name, "error": str(exc),
                    "wall_time_s": time.perf_counter() - t0}, None  # fmt: skip
        return _row(name, res.metrics), _front_tile(res)


def _header(*, out_dir, size, edge_m, quick, integrator, method, jobs, read_back,
            total) -> str:  # fmt: skip
    """The table's first line: what was draped and the command that reproduces it."""
    from sandbox.garment import DrapeConfig
    from sandbox.garment.pipeline import method_run

    implicit = integrator == "implicit_euler"
    fabrics = f", every garment in {QUICK_FABRIC}" if quick else ", each garment's fabric"
    header = f"Size {size} mannequin, {'quick: ' if quick else ''}{edge_m * 100:g} cm mesh edges"
    if implicit:
        header += ", implicit Euler (backward Euler at 1/60 s steps)"
    if method_run(edge_m, DrapeConfig(method=method)) == "coarse_to_fine":
        header += ", coarse to fine (docs/performance.md)"
    header += fabrics + ". Reproduce: `python -m sandbox gallery" + (" --quick" if quick else "")
    header += " --integrator implicit_euler" if implicit else ""
    header += f" --method {method}" if method != "coarse_to_fine" else ""
    header += (f" --size {size}" if size != 12 else "") + (f" --jobs {jobs}" if jobs > 1 else "")
    header += f" --out {Path(out_dir).as_posix()}" if Path(out_dir) != Path("docs/gallery") else ""
    header += "`"
    if read_back:
        header += (f" ({read_back} of {total} garments read back from earlier drapes with "
                   "the same settings, `--resume`; their wall times are those runs')")  # fmt: skip
    return header


def drape_in_processes(names, out_dir, *, size: int, edge_length_m: float, jobs: int,
                       meshes: bool = False, progress: bool = True, fabric: str | None = None,
                       time_limit_s: float | None = None,
                       integrator: str = "symplectic_euler",
                       method: str = "coarse_to_fine") -> dict[str, str]:  # fmt: skip
    """Drape ``names`` with ``python -m sandbox drape`` processes, ``jobs`` at a time, each
    into ``out_dir/<name>`` (its output in ``drape.log`` there).

    Each process gets ``TI_CPU_MAX_NUM_THREADS`` = the CPU count / ``jobs`` (at least 1;
    unless the variable is set already) and this process's arch and precision. Returns
    ``{name: reason}`` for the garments whose process failed (the last line of its log).
    """
    import os
    import subprocess
    import sys

    out = Path(out_dir)
    env = dict(os.environ)
    env.setdefault("TI_CPU_MAX_NUM_THREADS", str(max(1, (os.cpu_count() or 1) // jobs)))
    flags = ["--arch", runtime.arch(), "--float64" if runtime.is_float64() else "--float32"]
    flags += ["--size", str(size), "--edge-cm", f"{edge_length_m * 100:.10g}", "--quiet"]
    if fabric is not None:
        flags += ["--fabric", fabric]
    if time_limit_s is not None:
        flags += ["--time-limit", f"{time_limit_s:.10g}"]
    flags += ["--integrator", integrator, "--method", method]
    if not meshes:
        flags.append("--no-meshes")
    waiting, running, failed = list(names), {}, {}
    done = 0
    while waiting or running:
        while waiting and len(running) < jobs:
            name = waiting.pop(0)
            (out / name).mkdir(parents=True, exist_ok=True)
            log_file = open(out / name / "drape.log", "w")  # noqa: SIM115 (closed below)
            cmd = [sys.executable, "-m", "sandbox", "drape", name, "--out", str(out / name)]
            proc = subprocess.Popen(cmd + flags, stdout=log_file, stderr=subprocess.STDOUT,
                                    env=env)  # fmt: skip
            running[name] = (proc, log_file, time.perf_counter())
            if progress:
                print(f"  started {name} ({len(running)} running, {len(waiting)} waiting)",
                      flush=True)  # fmt: skip
        time.sleep(0.2)
        for name, (proc, log_file, t0) in list(running.items()):
            if proc.poll() is None:
                continue
            log_file.close()
            del running[name]
            done += 1
            if proc.returncode != 0:
                lines = (out / name / "drape.log").read_text(errors="replace").splitlines()
                failed[name] = (lines[-1] if lines else f"exit status {proc.returncode}")[:300]
            if progress:
                state = f"failed: {failed[name]}" if name in failed else "done"
                print(f"[{done}/{len(names)}] {name} {state} "
                      f"({time.perf_counter() - t0:.0f} s)", flush=True)  # fmt: skip
    return failed


def earlier_drape(folder, name: str, size: int, edge_length_m: float, fabric: str | None = None,
                  integrator: str = "symplectic_euler",
                  method: str = "coarse_to_fine"):  # fmt: skip
    """``(metrics, front image)`` of a drape of garment ``name`` already written to
    ``folder`` (``metrics.json`` and ``render.png``) on the database mannequin ``size`` with
    mesh edge ``edge_length_m`` [m] (and ``fabric``, if not None) by ``integrator`` (metrics
    without the key are symplectic Euler's: it was the only one), or None when there is none,
    it was made otherwise (metrics without ``edge_length_m`` included), or its files cannot
    be read (a warning says which)."""
    import imageio.v3 as iio

    folder = Path(folder)
    path, image = folder / "metrics.json", folder / "render.png"
    if not path.is_file():
        return None
    try:
        import json

        m = json.loads(path.read_text())
        tile = np.asarray(iio.imread(image))[:, :, :3]
    except (OSError, ValueError, IndexError) as exc:
        log.warning("%s: cannot read the earlier drape (%s); draping again", folder, exc)
        return None
    differs = []
    if m.get("garment") != name:
        differs.append(f"garment {m.get('garment')!r}")
    if m.get("mannequin_size") != size:
        differs.append(f"size {m.get('mannequin_size')}")
    edge = m.get("edge_length_m")
    if edge is None:
        differs.append("no mesh edge recorded")
    elif not math.isclose(edge, edge_length_m, rel_tol=1e-6):
        differs.append(f"mesh edge {edge * 100:g} cm")
    if fabric is not None and m.get("fabric") != fabric:
        differs.append(f"fabric {m.get('fabric')}")
    if m.get("integrator", "symplectic_euler") != integrator:
        differs.append(f"integrator {m.get('integrator')}")
    made = m.get("method", "direct")  # metrics without the key are the direct method's
    # a coarse-to-fine drape whose coarse level found no rest shape went direct
    if made != method and not (method == "coarse_to_fine" and m.get("coarse_fallback")):
        differs.append(f"method {made}")
    if "vertex_count" not in m or "wall_time_s" not in m:
        differs.append("no vertex count or wall time")
    if differs:
        log.warning("%s: made with %s; draping again", path, ", ".join(differs))
        return None
    return m, tile


def _row(name: str, m: dict) -> dict:
    return {
        "garment": name,
        "fabric": m.get("fabric"),
        "vertices": m["vertex_count"],
        "wall_time_s": m.get("total_wall_time_s", m["wall_time_s"]),
        "sim_time_s": m["sim_time_s"] + m.get("sew_sim_time_s", 0.0),
        "converged": bool(m["converged"]),
        "seam_gap_max_m": m.get("seam_gap_max_m"),
        "vertices_inside_body": m.get("vertices_inside_body"),
        "body_through_cloth_vertices": m.get("body_through_cloth_vertices"),
        "body_through_cloth_max_m": m.get("body_through_cloth_max_m"),
        "intersecting_triangle_pairs": m.get("intersecting_triangle_pairs"),
        "ease_bust_cm": m.get("ease_bust_cm"),
        "ease_waist_cm": m.get("ease_waist_cm"),
        "ease_hip_cm": m.get("ease_hip_cm"),
        "top_below_anchor_m": m.get("top_below_anchor_m"),
        "slid_off": m.get("slid_off"),
        "hem_rise_m": m.get("hem_rise_m"),
        "folded_area_pct": m.get("folded_area_pct"),
        "rolled_up": m.get("rolled_up"),
        "meets_acceptance": m.get("meets_acceptance"),
    }


def _front_tile(res) -> np.ndarray:
    import imageio.v3 as iio

    path = res.paths.get("render_front")
    if path is not None:
        return np.asarray(iio.imread(path))[:, :, :3]
    from sandbox.garment.output import drape_image

    scene = res.scene
    return drape_image(
        res.run.positions,
        scene.model.tri_indices_np,
        scene.garment.mannequin,
        material_uv=scene.model.material_uv_np,
    )


def write_sheet(path, tiles: list[tuple[str, np.ndarray | None]], *, tile_px: int = TILE_PX):
    """A grid of front views with the garment's name under each (PNG, atomic)."""
    from PIL import Image, ImageDraw, ImageFont

    from sandbox.atomic import atomic_path

    cols = min(COLUMNS, max(1, len(tiles)))
    rows = math.ceil(len(tiles) / cols)
    label = 28
    sheet = Image.new("RGB", (cols * tile_px, rows * (tile_px + label)), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    try:
        font = ImageFont.load_default(size=18)
    except TypeError:  # old Pillow
        font = ImageFont.load_default()
    for k, (name, img) in enumerate(tiles):
        x0, y0 = (k % cols) * tile_px, (k // cols) * (tile_px + label)
        if img is not None:
            tile = Image.fromarray(np.asarray(img, np.uint8)).resize((tile_px, tile_px))
            sheet.paste(tile, (x0, y0))
        else:
            draw.text((x0 + 20, y0 + tile_px // 2), "failed", fill=(200, 0, 0), font=font)
        w = draw.textlength(name, font=font)
        draw.text((x0 + (tile_px - w) / 2, y0 + tile_px + 4), name, fill=(0, 0, 0), font=font)
    path = Path(path)
    with atomic_path(path) as tmp:
        sheet.save(tmp, format="PNG")
    return path


def _mm(v) -> str:
    return "-" if v is None else f"{v * 1e3:.2f}"


def _cm(v) -> str:
    return "-" if v is None else f"{v:+.1f}"


ACCEPTANCE_HEAD = (
    "converged | seam gap max (mm) | inside body | body through (deepest mm) | "
    "intersecting pairs | folded (% area) | meets acceptance"
)


def acceptance_cells(r: dict) -> str:
    """The acceptance checks of one drape's metrics as Markdown cells, in the order of
    :data:`ACCEPTANCE_HEAD` (shared by the gallery table and ``benchmarks/bench_drape.py``)."""
    folded = r.get("folded_area_pct")
    through = r.get("body_through_cloth_vertices")
    through = "-" if through is None else f"{through} ({_mm(r.get('body_through_cloth_max_m'))})"
    return (
        f"{'yes' if r.get('converged') else 'no'} | {_mm(r.get('seam_gap_max_m'))} | "
        f"{r.get('vertices_inside_body')} | {through} | {r.get('intersecting_triangle_pairs')} | "
        f"{'-' if folded is None else f'{folded:.1f}'} | "
        f"{'**yes**' if r.get('meets_acceptance') else 'no'}"
    )


def write_table(path, rows: list[dict], header: str = "") -> Path:
    """The gallery's Markdown table."""
    from sandbox.atomic import write_text

    lines = ["# Garment gallery", ""]
    if header:
        lines += [header + ".", ""]
    lines += ["![gallery](gallery.png)", ""]
    lines += [
        "| garment | fabric | vertices | wall time (s) | top below anchor (cm) | "
        + ACCEPTANCE_HEAD
        + " | ease bust (cm) | ease waist (cm) | ease hip (cm) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    passed = 0
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['garment']} | failed: {r['error'][:120]} |" + "  |" * 13)
            continue
        passed += bool(r.get("meets_acceptance"))
        below = r.get("top_below_anchor_m")
        lines.append(
            f"| {r['garment']} | {r['fabric']} | {r['vertices']} | {r['wall_time_s']:.0f} | "
            f"{'-' if below is None else f'{below * 100:+.1f}'} | {acceptance_cells(r)} | "
            f"{_cm(r['ease_bust_cm'])} | {_cm(r['ease_waist_cm'])} | {_cm(r['ease_hip_cm'])} |"
        )
    times = sorted(r["wall_time_s"] for r in rows if "error" not in r)
    median = f"{np.median(times):.0f} s" if times else "-"
    lines += [
        "",
        f"{passed} of {len(rows)} meet the acceptance; median wall time {median}.",
        "",
        "Seam gap: the largest distance between a seam's two sides (each point of one "
        "side to the point of the same parameter on the other, Fig. 5b). Inside body: "
        "garment vertices inside the closed mannequin. Body through: mannequin vertices "
        "that show through the garment where it covers them, and how far the deepest stands "
        "out (docs/collision_metrics.md). Intersecting pairs: garment triangle "
        "pairs that cross (exact test). "
        "Top below anchor: how far the garment's highest point ends below the landmark it "
        "hangs from (shoulder point or waist; negative: above it); more than 3 cm counts as "
        "slid off. Folded: the share of the garment's area that ended turned over (normal "
        "turned more than 90 degrees from the placed one, and facing the body with the side "
        "that faced away from it; more than 3 cm from the body, where flutes hang free, "
        "only cloth hanging upside down); more than 2 % counts as rolled up. Meets "
        "acceptance: "
        "converged, seam gap "
        "<= 2 mm, nothing inside the body deeper than 1 mm, the body through the cloth by "
        "no more than 1 mm, no intersecting pairs, neither "
        "slid off nor rolled up. Ease: garment girth "
        "minus body girth at the bust, waist and hip heights (convex hull of the section, as "
        "the tape measure); '-' where the garment does not reach. See docs/drape.md.",
        "",
    ]
    return write_text(Path(path), "\n".join(lines))


def _write_json(path, rows, header) -> Path:
    from sandbox.atomic import write_json
    from sandbox.scene.output import _jsonable

    return write_json(Path(path), _jsonable({"settings": header, "garments": rows}))
