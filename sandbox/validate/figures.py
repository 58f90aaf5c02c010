"""The table of headline figures, read from the generated files under ``docs/``.

``python -m sandbox figures`` reads the files the gallery, the demo, the report and the
step benchmark wrote, and writes one Markdown table (figure, value, the command that
reproduces it, the file it was read from) to ``docs/figures.md`` and between the markers
:data:`BEGIN` and :data:`END` in ``README.md``. ``--check`` writes nothing and exits with
status 1 when either file differs from what it would write. No figure is typed by hand:
re-running a command that regenerates a source file and then ``python -m sandbox figures``
updates both pages.
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import sys
from dataclasses import dataclass
from pathlib import Path

from sandbox.errors import SandboxError

BEGIN = "<!-- figures:begin -->"
END = "<!-- figures:end -->"
FIGURES_PAGE = "docs/figures.md"
README = "README.md"

GALLERY = "docs/gallery/gallery.json"
GALLERY_IMPLICIT = "docs/gallery-implicit/gallery.json"
DEMO = "docs/demo/metrics.json"
REPORT = "docs/report/report.json"
BENCH_STEP = "docs/results/bench_step.txt"
GALLERY_SPEED = "docs/results/gallery_speed_coarse_to_fine.json"
PEER_REST = "docs/results/peer_sheet_rest.json"
#: GarmentCode's examples (benchmarks/bench_garmentcode.py): (table tag, what it drapes on)
GARMENTCODE = (("mean_all_3cm", "3 cm, on the body they were drafted for (mean_all)"),
               ("mean_all_1.5cm", "1.5 cm (coarse to fine), on mean_all"),
               ("size8_3cm", "3 cm, on size 8"), ("size18_3cm", "3 cm, on size 18"))  # fmt: skip

STEP_VERTICES = 16_000
"""The sheet size whose throughput is quoted (the nearest row of the benchmark's table)."""


@dataclass(frozen=True)
class Figure:
    """One row of the table: what was measured, its value, how to reproduce it, where from."""

    name: str
    value: str
    command: str
    source: str


def _read_json(root: Path, rel: str) -> dict:
    path = root / rel
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise SandboxError(f"{rel}: missing (the figures are read from it)") from None
    except (OSError, ValueError) as exc:
        raise SandboxError(f"{rel}: cannot read it as JSON ({exc})") from None


def _seconds(values: list[float]) -> str:
    return f"median {statistics.median(values):,.0f} s ({min(values):,.0f}–{max(values):,.0f} s)"


def gallery_figures(root: Path, rel: str, label: str, command: str) -> list[Figure]:
    """How many garments of a gallery meet the acceptance, and their wall times."""
    rows = _read_json(root, rel).get("garments")
    if not rows:
        raise SandboxError(f"{rel}: no garments")
    done = [r for r in rows if "error" not in r]
    passed = sum(bool(r.get("meets_acceptance")) for r in done)
    gaps = [r["seam_gap_max_m"] for r in done if r.get("seam_gap_max_m") is not None]
    gap = f"; largest seam gap {max(gaps) * 1e3:.2f} mm" if gaps else ""
    times = [float(r["wall_time_s"]) for r in done]
    return [
        Figure(f"{label}: garments that meet the acceptance", f"{passed} of {len(rows)}{gap}",
               command, rel),
        Figure(f"{label}: wall time per garment", _seconds(times) if times else "-",
               command, rel),
    ]  # fmt: skip


def gallery_speed_figures(root: Path) -> list[Figure]:
    """Coarse to fine against the direct 1 cm reference drapes: time, and how far apart the
    rest shapes are (benchmarks/bench_gallery_speed.py)."""
    rows = _read_json(root, GALLERY_SPEED)
    if not isinstance(rows, list) or not rows:
        raise SandboxError(f"{GALLERY_SPEED}: no garments")
    command = "python benchmarks/bench_gallery_speed.py"
    total = [float(r["total_s"]) for r in rows]
    ref = [float(r["ref_total_s"]) for r in rows if r.get("ref_total_s") is not None]
    label = f"Coarse to fine (3 cm, then 1 cm), {len(rows)} garments, size 12"
    time_value = _seconds(total)
    if ref:
        time_value += f"; the direct 1 cm reference: {_seconds(ref)}"
    dist = [r["dist_mean_cm"] for r in rows if r.get("dist_mean_cm") is not None]
    p95 = [r["dist_p95_cm"] for r in rows if r.get("dist_p95_cm") is not None]
    ease = [
        abs(r[k])
        for r in rows
        for k in ("ease_bust_delta_cm", "ease_waist_delta_cm", "ease_hip_delta_cm")
        if r.get(k) is not None
    ]
    hem = [abs(r["hem_delta_cm"]) for r in rows if r.get("hem_delta_cm") is not None]
    meets = sum(bool(r.get("meets_acceptance")) for r in rows)
    over = "" if len(dist) == len(rows) else f" (over the {len(dist)} with a reference)"
    shape = (f"mean vertex distance{over} median {statistics.median(dist):.2f} cm, largest "
             f"{max(dist):.2f} cm (95th percentile up to {max(p95):.2f} cm); ease within "
             f"{max(ease):.2f} cm, lowest point within {max(hem):.2f} cm; {meets} of "
             f"{len(rows)} meet the acceptance") if dist else "-"  # fmt: skip
    return [
        Figure(f"{label}: total time per garment", time_value, command, GALLERY_SPEED),
        Figure(f"{label}: the same rest shape as the direct 1 cm reference?", shape, command,
               GALLERY_SPEED),
    ]  # fmt: skip


def peer_rest_figure(root: Path) -> Figure:
    """The peer's sheet on a sphere brought to rest, coarse to fine against direct
    (benchmarks/bench_peer_rest.py)."""
    r = _read_json(root, PEER_REST)
    try:
        ml, d, shapes = r["coarse_to_fine"], r["direct"], r["shapes"]
        value = (f"{ml['wall_s']:.1f} s coarse to fine (residual mean "
                 f"{ml['residual_mean_over_weight']:.2f} weights), {d['wall_s']:.1f} s direct "
                 f"({d['residual_mean_over_weight']:.2f}); rest shapes "
                 f"{shapes['distance_mean_m'] * 100:.1f} cm apart on average")  # fmt: skip
    except (KeyError, TypeError) as exc:
        raise SandboxError(f"{PEER_REST}: missing {exc}") from None
    return Figure("A peer's 1 m sheet (65 x 65 grid) dropped on a sphere: wall time to rest, "
                  "certified by the equilibrium residual", value,
                  "python benchmarks/bench_peer_rest.py", PEER_REST)  # fmt: skip


def garmentcode_figures(root: Path) -> list[Figure]:
    """How many of GarmentCode's example designs meet the acceptance, per body, and the wall
    time per design (benchmarks/bench_garmentcode.py's tables)."""
    out = []
    for tag, label in GARMENTCODE:
        rel = f"docs/results/garmentcode_{tag}.json"
        rows = _read_json(root, rel).get("designs")
        if not rows:
            raise SandboxError(f"{rel}: no designs")
        done = [r for r in rows if "error" not in r]
        passed = sum(bool(r["metrics"].get("meets_acceptance")) for r in done)
        times = _seconds([float(r["wall_s"]) for r in done]) if done else "-"
        body = "--body tests/data/garmentcode/bodies/mean_all.yaml" if tag.startswith(
            "mean_all") else f"--size {tag[4:].split('_')[0]}"  # fmt: skip
        edge = tag.rsplit("_", 1)[1][: -len("cm")]
        edge = "" if edge == "3" else f" --edge-cm {edge}"
        command = f"python benchmarks/bench_garmentcode.py{edge} {body} --jobs 2"
        every = len(list((root / "tests" / "data" / "garmentcode").glob("*_specification.json")))
        if len(rows) < every:  # the designs it drapes are named
            command += " " + " ".join(sorted(r["spec"] for r in rows))
        out.append(Figure(f"GarmentCode's example designs, {label}: designs that meet the "
                          "acceptance; wall time per design",
                          f"{passed} of {len(rows)}; {times}", command, rel))  # fmt: skip
    return out


def demo_figure(root: Path) -> Figure:
    """The demo drape's acceptance checks and ease."""
    m = _read_json(root, DEMO)

    def cm(key):
        v = m.get(key)
        return "-" if v is None else f"{v:+.1f}"

    verdict = "meets the acceptance" if m.get("meets_acceptance") else "misses the acceptance"
    state = "converged" if m.get("converged") else f"stopped ({m.get('stop_reason')})"
    gap = m.get("seam_gap_max_m")
    value = (
        f"{verdict}: {state}, seam gap {'-' if gap is None else f'{gap * 1e3:.2f}'} mm, "
        f"{m.get('vertices_inside_body')} vertices inside the body, "
        f"{m.get('body_through_cloth_vertices')} body vertices through the cloth, "
        f"{m.get('intersecting_triangle_pairs')} intersecting pairs; "
        f"ease {cm('ease_bust_cm')} / {cm('ease_waist_cm')} / {cm('ease_hip_cm')} cm "
        "(bust / waist / hip)"
    )
    edge = m.get("edge_length_m")
    mesh = "-" if edge is None else f"{edge * 100:g}"
    name = (
        f"Demo: {m.get('garment')} in {m.get('fabric')}, size {m.get('mannequin_size')}, "
        f"{mesh} cm mesh, {m.get('vertex_count', 0):,} vertices"
    )
    return Figure(name, value, "python -m sandbox demo --out docs/demo", DEMO)


def cantilever_figures(root: Path) -> list[Figure]:
    """The explicit cantilever's tip error on the finest mesh, and the implicit speed-up."""
    data = _read_json(root, REPORT)
    command = "python -m sandbox report" + (" --quick" if data.get("mode") == "quick" else "")
    made = data.get("error_written") or data  # the error runs' own date and machine
    machine = str(made.get("machine", ""))
    when = "float32" if "float32" in machine else "float64" if "float64" in machine else ""
    if made.get("date"):
        when = f"{when}, {str(made['date'])[:10]}".strip(", ")
    when = f"; {when}" if when else ""
    finest: dict[float, dict] = {}
    for r in data.get("runs", []):
        lam = (r.get("params") or {}).get("lambda")
        if r.get("case") != "cantilever" or r.get("integrator") != "symplectic_euler":
            continue
        if lam is None or r.get("error_pct") is None:
            continue
        best = finest.get(lam)
        if best is None or r["edge_length_m"] < best["edge_length_m"]:
            finest[lam] = r
    out = []
    if finest:
        edges = {r["edge_length_m"] for r in finest.values()}
        mesh = f"{min(edges) * 1e3:g} mm mesh" if len(edges) == 1 else "finest mesh"
        errs = ", ".join(f"λ = {lam:g}: {r['error_pct']:.2f}" for lam, r in sorted(finest.items()))
        out.append(Figure(
            f"Cantilever tip error against the heavy elastica (symplectic Euler, {mesh}{when})",
            f"{errs} % of L", command, REPORT,
        ))  # fmt: skip
    s = data.get("speedup") or {}
    se, ie = s.get("symplectic_euler"), s.get("implicit_euler")
    if se and ie and s.get("speedup"):
        out.append(Figure(
            f"Cantilever λ = {s['lambda']:g} at tip error ≤ {s['target_tip_error_pct_L']:g} % L: "
            "implicit against symplectic Euler" + (f" ({when[2:]})" if when else ""),
            f"{s['speedup']:.1f}× faster ({ie['wall_time_s']:.2f} s against "
            f"{se['wall_time_s']:.1f} s)",
            command, REPORT,
        ))  # fmt: skip
    if not out:
        raise SandboxError(f"{REPORT}: no cantilever runs")
    return out


def contact_figure(root: Path) -> list[Figure]:
    """The contact rows of the stability matrix: how many cells ran to their end."""
    data = _read_json(root, REPORT)
    cells = data.get("contact") or []
    if not cells:
        return []
    ok = sum(c.get("outcome") in ("stable", "guarded") for c in cells)
    failed = sum(c.get("outcome") == "failed" for c in cells)
    made = data.get("contact_written") or data
    when = f", {str(made['date'])[:10]}" if made.get("date") else ""
    return [Figure(
        f"Contact stability: cloth on edges, rims, corners and a floor (3 fabrics, both "
        f"integrators{when})",
        f"{ok} of {len(cells)} runs stable or guarded, {failed} failed",
        "python -m sandbox report --only contact", REPORT,
    )]  # fmt: skip


_STEP_ROW = re.compile(r"^\s*(\d+)\s+(\d+)\s+(\d+)\s+([\d.]+)\s+([\d.]+)\s*$")


def step_figure(root: Path) -> Figure:
    """The explicit step's throughput from the first table of the step benchmark's log."""
    path = root / BENCH_STEP
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except OSError:
        raise SandboxError(f"{BENCH_STEP}: missing (the figures are read from it)") from None
    rows, machine = [], ""
    for line in lines:
        if line.startswith("$") and rows:
            break  # only the first run in the file
        if line.startswith("machine:"):
            machine = line.split(":", 1)[1].strip()
        m = _STEP_ROW.match(line)
        if m:
            rows.append((int(m[1]), float(m[5])))
    if not rows:
        raise SandboxError(f"{BENCH_STEP}: no table of vertices and vertex-steps/s")
    n, rate = min(rows, key=lambda r: abs(r[0] - STEP_VERTICES))
    cores = re.search(r"(\d+) cores", machine)
    where = f", {cores[1]}-core CPU" if cores else ""
    return Figure(
        f"Explicit step throughput, hanging sheet of {n:,} vertices (float32{where})",
        f"{rate:.1f} M vertex-steps/s", "python benchmarks/bench_step.py", BENCH_STEP,
    )  # fmt: skip


def figures(root: Path | str = ".") -> list[Figure]:
    """Every figure of the table, in its order, read from the files under ``root``."""
    root = Path(root)
    return [
        *gallery_figures(root, GALLERY, "Gallery, 1 cm, size 12, direct symplectic Euler",
                         "python -m sandbox gallery --method direct --jobs 2"),
        *gallery_speed_figures(root),
        peer_rest_figure(root),
        *gallery_figures(root, GALLERY_IMPLICIT, "Gallery, 3 cm, size 12, implicit Euler",
                         "python -m sandbox gallery --integrator implicit_euler --jobs 2 "
                         "--out docs/gallery-implicit"),
        *garmentcode_figures(root),
        demo_figure(root),
        *cantilever_figures(root),
        *contact_figure(root),
        step_figure(root),
    ]  # fmt: skip


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def table(figs: list[Figure]) -> str:
    """The Markdown table (no trailing newline); source links are relative to the repo root."""
    lines = ["| figure | value | reproduce | source |", "|---|---|---|---|"]
    for f in figs:
        lines.append(f"| {_cell(f.name)} | {_cell(f.value)} | `{f.command}` | "
                     f"[{f.source}]({f.source}) |")  # fmt: skip
    return "\n".join(lines)


def page(figs: list[Figure]) -> str:
    """``docs/figures.md``: the table with links relative to ``docs/``."""
    body = table(figs).replace("](docs/", "](")
    return (
        "# Figures\n\n"
        "Each figure is read from a file a command generated; the table says which command "
        "and which file. Written by `python -m sandbox figures`, which also puts the same "
        "table into the README; `tests/test_figures.py` fails when the README's copy is out "
        "of date. Wall times are of a shared 2-core x86-64 CPU unless the source says "
        "otherwise.\n\n" + body + "\n"
    )


def readme_with(readme: str, figs: list[Figure]) -> str:
    """``readme`` with the text between the markers replaced by the table."""
    start, end = readme.find(BEGIN), readme.find(END)
    if start < 0 or end < start:
        raise SandboxError(f"{README}: no {BEGIN} ... {END} block for the figures")
    return readme[: start + len(BEGIN)] + "\n" + table(figs) + "\n" + readme[end:]


def readme_block(readme: str) -> str:
    """The table between the markers of ``readme`` (without the markers)."""
    start, end = readme.find(BEGIN), readme.find(END)
    if start < 0 or end < start:
        raise SandboxError(f"{README}: no {BEGIN} ... {END} block for the figures")
    return readme[start + len(BEGIN) : end].strip("\n")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m sandbox figures",
        description="Read the headline figures from the generated files under docs/ and write "
        "docs/figures.md and the README's figures table.",
    )
    ap.add_argument("--root", type=Path, default=Path("."), help="repository root (default: .)")
    ap.add_argument(
        "--check", action="store_true", help="write nothing; exit 1 if a page is out of date"
    )
    args = ap.parse_args(argv)
    try:
        figs = figures(args.root)
        readme_path, page_path = args.root / README, args.root / FIGURES_PAGE
        if not readme_path.is_file():
            raise SandboxError(f"{readme_path}: missing")
        old_readme = readme_path.read_text(encoding="utf-8")
        new_readme, new_page = readme_with(old_readme, figs), page(figs)
        old_page = page_path.read_text(encoding="utf-8") if page_path.is_file() else ""
        pairs = ((README, old_readme, new_readme), (FIGURES_PAGE, old_page, new_page))
        stale = [p for p, old, new in pairs if old != new]
        if args.check:
            for p in stale:
                print(f"{p}: out of date; run python -m sandbox figures", file=sys.stderr)
            return 1 if stale else 0
        from sandbox.atomic import write_text

        write_text(page_path, new_page)
        write_text(readme_path, new_readme)
        print(table(figs))
        return 0
    except SandboxError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
