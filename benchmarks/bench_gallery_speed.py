"""Gallery speed: each library garment at 1 cm, size 12, its own fabric, timed and compared
with the reference drapes.

Usage:
    python benchmarks/bench_gallery_speed.py [GARMENT ...] [--method coarse_to_fine]
        [--set NAME=VALUE ...] [--tag TAG]
    python benchmarks/bench_gallery_speed.py --reference [GARMENT ...]

``--reference`` drapes with the paper's symplectic Euler all the way at 1 cm (the
``direct`` method) and stores each garment's final positions, rounded to 0.1 mm, in
``benchmarks/reference/GARMENT.npz`` with its metrics in ``reference.json``, and each vertex's
panel and pattern coordinates with the panels' triangles. Without it, each garment is
draped with ``--method`` and compared with its reference: ease at bust, waist and hip, hem
height (the garment's lowest point) and the vertex distance to the reference (mean and
95th percentile): vertex for vertex on the same mesh, else each vertex against the
reference's surface at its own pattern coordinates (a mesher change moves vertices, not
the pattern). The table goes to
``docs/results/gallery_speed_METHOD.md`` (and ``.json``), where ``python -m sandbox figures``
reads it, with the machine it ran on. Naming garments reruns only those: their rows replace
theirs in an existing results file. ``--set`` changes a ``DrapeConfig`` setting for the run
(for experiments; give them a ``--tag`` so the published file stays the defaults').
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REFERENCE = HERE / "reference"
RESULTS = HERE.parent / "docs" / "results"
QUANTUM_M = 1e-4  # stored positions are rounded to 0.1 mm


def _drape(garment: str, method: str, overrides: dict | None = None):
    from sandbox.garment import DrapeConfig, drape

    config = DrapeConfig(method=method, **(overrides or {}))
    out = Path("/tmp") / f"gallery_speed_{os.getpid()}" / garment
    return drape(garment, size=12, out_dir=out, edge_length_m=0.01, config=config,
                 render=False, meshes=False, progress=False)  # fmt: skip


def _summary(metrics: dict, x: np.ndarray, wall_s: float) -> dict:
    keys = (
        "vertex_count",
        "meets_acceptance",
        "sew_wall_time_s",
        "wall_time_s",
        "ease_bust_cm",
        "ease_waist_cm",
        "ease_hip_cm",
        "seam_gap_max_m",
        "residual_max_over_weight",
        "residual_mean_over_weight",
        "coarse_wall_time_s",
        "method",
        "coarse_fallback",
    )
    row = {k: metrics.get(k) for k in keys}
    row["total_s"] = wall_s
    row["hem_height_m"] = float(x[:, 1].min())
    return row


def write_reference(garments: list[str]) -> None:
    REFERENCE.mkdir(exist_ok=True)
    index_path = REFERENCE / "reference.json"
    index = json.loads(index_path.read_text()) if index_path.exists() else {}
    for g in garments:
        t0 = time.perf_counter()
        r = _drape(g, "direct")
        wall = time.perf_counter() - t0
        x = r.scene.state.positions().astype(np.float64)
        q = np.round(x / QUANTUM_M).astype(np.int32)
        tmp = REFERENCE / f".{g}.npz"
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, positions_01mm=q, **_pattern_arrays(r.scene))
        tmp.replace(REFERENCE / f"{g}.npz")
        index[g] = _summary(r.metrics, x, wall)
        index["_meta"] = _meta()
        print(g, json.dumps(index[g]), flush=True)
        tmp = index_path.with_suffix(".tmp")
        tmp.write_text(json.dumps(index, indent=1, sort_keys=True))
        tmp.replace(index_path)


def _meta() -> dict:
    """Where and with what code the references were draped."""
    import subprocess

    try:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=HERE, capture_output=True,
                                text=True, check=True).stdout.strip()  # fmt: skip
    except (OSError, subprocess.CalledProcessError):
        commit = None
    return {"commit": commit, "date": time.strftime("%Y-%m-%d"),
            "machine": f"{platform.machine()}, {os.cpu_count()} cores, Python "
                       f"{platform.python_version()}"}  # fmt: skip


def _pattern_arrays(scene) -> dict:
    """Each vertex's panel (index into ``panels``) and pattern coordinates [m], and the
    mesh's triangles: what places a vertex of another mesh of the same garment on it."""
    model, meshes = scene.model, scene.garment.meshes
    panel = np.empty(model.particle_count, np.int16)
    uv = np.empty((model.particle_count, 2), np.float32)
    for k, piece in enumerate(model.pieces):
        sl = slice(piece.particle_start, piece.particle_start + piece.particle_count)
        panel[sl] = k
        uv[sl] = meshes[piece.name].points
    return {"panel": panel, "uv_m": uv, "triangles": model.tri_indices_np.astype(np.int32),
            "panels": np.array([p.name for p in model.pieces])}  # fmt: skip


def load_reference(garment: str) -> dict:
    """The reference of ``garment``: ``x`` its final positions (n, 3) [m], and where stored
    ``panel``, ``uv_m``, ``triangles`` and ``panels`` (:func:`_pattern_arrays`)."""
    with np.load(REFERENCE / f"{garment}.npz") as z:
        out = {k: z[k] for k in z.files if k != "positions_01mm"}
        out["x"] = z["positions_01mm"].astype(np.float64) * QUANTUM_M
    return out


def reference_distance(scene, x: np.ndarray, ref: dict) -> np.ndarray | None:
    """Each vertex's distance to the reference [m], (n,): vertex for vertex on the same
    mesh, else to the reference's surface at the vertex's own pattern coordinates (its
    panel's reference triangle holding them, by barycentric coordinates). None when
    neither applies (an old reference of another mesh, or a panel it does not have)."""
    from sandbox.scene.multilevel import barycentric_locate

    xr = ref["x"]
    if xr.shape == x.shape:
        return np.linalg.norm(x - xr, axis=1)
    if "uv_m" not in ref:
        return None
    mine = _pattern_arrays(scene)
    names = [str(n) for n in ref["panels"]]
    tris = ref["triangles"]
    tri_panel = ref["panel"][tris[:, 0]]
    d = np.empty(len(x))
    for k, name in enumerate(str(n) for n in mine["panels"]):
        if name not in names:
            return None
        ours = mine["panel"] == k
        own = tris[tri_panel == names.index(name)]
        t, w = barycentric_locate(mine["uv_m"][ours], ref["uv_m"], own)
        at = np.einsum("pk,pkd->pd", w, xr[own[t]])
        d[ours] = np.linalg.norm(x[ours] - at, axis=1)
    return d


def parse_overrides(items: list[str]) -> dict:
    """``["coarse_self_collision=true", "fine_damping_per_s=30"]`` -> DrapeConfig keywords
    (values read as JSON: numbers, true/false, null)."""
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep:
            raise SystemExit(f"--set {item!r}: expected NAME=VALUE")
        try:
            out[name.strip()] = json.loads(value)
        except json.JSONDecodeError:
            msg = f"--set {item!r}: the value is not a number, true, false or null"
            raise SystemExit(msg) from None
    return out


def merge_rows(old: list[dict], new: list[dict], order: list[str]) -> list[dict]:
    """``old`` with each garment in ``new`` replaced or added, in ``order``."""
    by_name = {r["garment"]: r for r in old}
    by_name.update({r["garment"]: r for r in new})
    return [by_name[g] for g in order if g in by_name]


def compare(garments: list[str], method: str, overrides: dict | None = None) -> list[dict]:
    ref_index = json.loads((REFERENCE / "reference.json").read_text())
    ref_index.pop("_meta", None)
    rows = []
    for g in garments:
        t0 = time.perf_counter()
        r = _drape(g, method, overrides)
        wall = time.perf_counter() - t0
        x = r.scene.state.positions().astype(np.float64)
        row = {"garment": g, **_summary(r.metrics, x, wall)}
        ref = ref_index.get(g)
        if ref is not None:
            d = reference_distance(r.scene, x, load_reference(g))
            row["ref_total_s"] = ref["total_s"]
            for k in ("ease_bust_cm", "ease_waist_cm", "ease_hip_cm"):
                a, b = row.get(k), ref.get(k)
                row[k.replace("_cm", "_delta_cm")] = None if a is None or b is None else a - b
            row["hem_delta_cm"] = 100.0 * (row["hem_height_m"] - ref["hem_height_m"])
            row["dist_mean_cm"] = None if d is None else 100.0 * float(d.mean())
            row["dist_p95_cm"] = None if d is None else 100.0 * float(np.percentile(d, 95))
        rows.append(row)
        print(g, json.dumps(row), flush=True)
    return rows


def _fmt(v, spec):
    return "–" if v is None else format(v, spec)


def _ran(row: dict) -> str:
    ran = row.get("method") or "–"
    return f"{ran} (coarse level not at rest)" if row.get("coarse_fallback") else ran


def write_table(rows: list[dict], method: str, extra: str = "", load: str = "") -> str:
    totals = sorted(r["total_s"] for r in rows)
    median = (
        totals[len(totals) // 2]
        if len(totals) % 2
        else 0.5 * sum(totals[len(totals) // 2 - 1 : len(totals) // 2 + 1])
    )
    lines = [
        f"# Gallery speed: method `{method}`, 1 cm, size 12, each garment's own fabric",
        "",
        f"Machine: {platform.machine()}, {os.cpu_count()} cores, Python "
        f"{platform.python_version()}, {time.strftime('%Y-%m-%d')}. "
        f"Command: `python benchmarks/bench_gallery_speed.py --method {method}{extra}`."
        + (f" Load: {load}" if load else ""),
        "",
        f"Median total {median:.1f} s, slowest {totals[-1]:.1f} s; "
        f"{sum(bool(r['meets_acceptance']) for r in rows)} of {len(rows)} meet the acceptance.",
        "",
        "`ran`: the method the drape used; a coarse-to-fine drape whose coarse level ends "
        "short of rest goes direct (docs/drape.md), its coarse level counted in its total.",
        "",
        "| garment | ran | vertices | sewing s | drape s | total s | reference s "
        "| residual max / mean "
        "| ease Δ bust / waist / hip cm | hem Δ cm | distance mean / 95 % cm | meets |",
        "|---|---|---:|---:|---:|---:|---:|---|---|---:|---|---|",
    ]
    for r in rows:
        ease = " / ".join(
            _fmt(r.get(k), "+.2f")
            for k in ("ease_bust_delta_cm", "ease_waist_delta_cm", "ease_hip_delta_cm")
        )
        lines.append(
            f"| {r['garment']} | {_ran(r)} | {r['vertex_count']} "
            f"| {_fmt(r['sew_wall_time_s'], '.1f')} "
            f"| {_fmt(r['wall_time_s'], '.1f')} | {r['total_s']:.1f} "
            f"| {_fmt(r.get('ref_total_s'), '.0f')} "
            f"| {_fmt(r['residual_max_over_weight'], '.2f')} / "
            f"{_fmt(r['residual_mean_over_weight'], '.3f')} | {ease} "
            f"| {_fmt(r.get('hem_delta_cm'), '+.2f')} "
            f"| {_fmt(r.get('dist_mean_cm'), '.2f')} / {_fmt(r.get('dist_p95_cm'), '.2f')} "
            f"| {'yes' if r['meets_acceptance'] else 'no'} |"
        )
    return "\n".join(lines) + "\n"


def _write(path: Path, text: str) -> None:
    """Write ``text`` to a temporary file beside ``path``, then rename it into place."""
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(text)
    tmp.replace(path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("garments", nargs="*")
    ap.add_argument(
        "--reference",
        action="store_true",
        help="drape the references (the direct method: symplectic Euler at 1 cm) and store them",
    )
    ap.add_argument("--method", default="coarse_to_fine")
    ap.add_argument("--tag", default=None, help="results file suffix (default: the method)")
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                    help="a DrapeConfig setting for this run (repeatable)")  # fmt: skip
    ap.add_argument("--load", default="", help="what else the machine ran meanwhile, for the "
                    "table's header (its times are then upper bounds)")  # fmt: skip
    args = ap.parse_args()
    overrides = parse_overrides(args.set)
    from sandbox import runtime
    from sandbox.garment import garment_names

    runtime.init("cpu")
    garments = args.garments or garment_names()
    if args.reference:
        write_reference(garments)
        return
    rows = compare(garments, args.method, overrides)
    RESULTS.mkdir(parents=True, exist_ok=True)
    tag = args.tag or args.method
    old = RESULTS / f"gallery_speed_{tag}.json"
    if args.garments and old.exists():  # a rerun of some garments keeps the others' rows
        rows = merge_rows(json.loads(old.read_text()), rows, list(garment_names()))
    _write(RESULTS / f"gallery_speed_{tag}.json", json.dumps(rows, indent=1))
    table = write_table(rows, args.method, "".join(f" --set {i}" for i in args.set), args.load)
    _write(RESULTS / f"gallery_speed_{tag}.md", table)
    sys.stdout.write(table)


if __name__ == "__main__":
    main()
