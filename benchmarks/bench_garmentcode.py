"""GarmentCode's example designs, imported and draped: one table and one contact sheet.

Usage:
    python benchmarks/bench_garmentcode.py [SPEC ...] [--edge-cm 3] [--jobs 2]
        [--body tests/data/garmentcode/bodies/mean_all.yaml | --size N] [--tag TAG]
        [--rewrite] [DRAPE FLAGS ...]

Each specification in ``tests/data/garmentcode/`` (or those named, by the part of the file
name before ``_specification.json``) is imported with ``python -m sandbox import-garmentcode``
and draped with ``python -m sandbox drape`` on the body its design was made for (GarmentCode's
``mean_all`` unless ``--body`` or ``--size`` says otherwise), each in its own process, so
a failed drape is a row of the table, not the end of the run. ``--jobs 2`` drapes two at a
time with one thread each (the times are then per core). The table goes to
``docs/results/garmentcode_TAG.md`` (and ``.json``) and the front views to
``docs/garmentcode/TAG.png``; TAG defaults to the body and the edge, e.g. ``mean_all_3cm``.
Naming designs reruns only those: their rows replace theirs in an existing table.
Flags the script does not know are passed to ``drape`` (``--fabric jersey``). ``--rewrite``
rewrites a table from its JSON without draping.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
DATA = ROOT / "tests" / "data" / "garmentcode"
RESULTS = ROOT / "docs" / "results"
SHEETS = ROOT / "docs" / "garmentcode"
SUFFIX = "_specification.json"


def _specs(names: list[str]) -> list[Path]:
    every = sorted(DATA.glob(f"*{SUFFIX}"))
    if not names:
        return every
    chosen = []
    for n in names:
        p = DATA / f"{n}{SUFFIX}"
        if not p.is_file():
            sys.exit(f"{n}: no {p.name} in {DATA} (have: "
                     + ", ".join(s.name[: -len(SUFFIX)] for s in every) + ")")  # fmt: skip
        chosen.append(p)
    return chosen


def _run(cmd: list[str], env: dict, log: Path) -> int:
    with open(log, "a") as f:
        f.write("$ " + " ".join(cmd) + "\n")
        f.flush()
        return subprocess.run(cmd, env=env, stdout=f, stderr=subprocess.STDOUT, cwd=ROOT).returncode


def _drape(spec: Path, out: Path, args, threads: int | None) -> dict:
    name = spec.name[: -len(SUFFIX)]
    folder = out / name
    folder.mkdir(parents=True, exist_ok=True)
    log = folder / "log.txt"
    log.write_text("")
    env = dict(os.environ)
    if threads:
        env["TI_CPU_MAX_NUM_THREADS"] = str(threads)
    py = sys.executable
    pattern = folder / "pattern.json"
    t0 = time.perf_counter()
    if _run([py, "-m", "sandbox", "import-garmentcode", str(spec), str(pattern)], env, log):
        return {"spec": name, "error": "import failed", "log": str(log)}
    body = ["--size", str(args.size)] if args.size else ["--garmentcode-body", str(args.body)]
    cmd = [py, "-m", "sandbox", "drape", str(pattern), *body, "--edge-cm", str(args.edge_cm),
           "--out", str(folder / "drape"), *args.extra]  # fmt: skip
    rc = _run(cmd, env, log)
    wall = time.perf_counter() - t0
    metrics = folder / "drape" / "metrics.json"
    if rc or not metrics.is_file():
        tail = log.read_text().strip().splitlines()[-1:] or ["?"]
        return {"spec": name, "error": tail[0][:200], "wall_s": wall, "log": str(log)}
    m = json.loads(metrics.read_text())
    return {"spec": name, "wall_s": wall, "metrics": m,
            "front": str(folder / "drape" / "render.png")}  # fmt: skip


def _fails(m: dict) -> str:
    """Which acceptance checks a drape misses, in words."""
    from sandbox.garment.metrics import acceptance_failures

    return ", ".join(acceptance_failures(m)) or "-"


def _fit(m: dict) -> str:
    """The levels where the pattern is short of the body before the drape (the fit check's
    warnings, ``metrics["fit"]``), e.g. ``"hip 99.1 < 103.5 cm"``; "-" where it fits."""
    short = [f"{f['level']} {f['garment_cm']:.1f} < {f['body_cm']:.1f} cm"
             for f in m.get("fit", []) if not f.get("fits", True)]  # fmt: skip
    return ", ".join(short) or "-"


def _ease(m: dict) -> str:
    """Ease at the bust, waist and hip after the drape [cm] (garment girth minus body girth:
    a design too large for the body shows here), "–" where the garment does not reach."""
    out = []
    for level in ("bust", "waist", "hip"):
        e = m.get(f"ease_{level}_cm")
        out.append("–" if e is None else f"{e:+.1f}")
    return " / ".join(out)


def _table(rows: list[dict], header: str, tag: str) -> str:
    from sandbox.garment.gallery import ACCEPTANCE_HEAD, acceptance_cells

    lines = ["# GarmentCode examples", "", header + ".", "",
             f"![front views](../garmentcode/{tag}.png)", "",
             "| design | vertices | fabric | wall s | sim s | " + ACCEPTANCE_HEAD
             + " | fails | ease bust / waist / hip (cm) | short of the body |",
             "|---|---|---|---|---|" + "---|" * 10]  # fmt: skip
    met = 0
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['spec']} | failed: {r['error']} |" + " |" * 13)
            continue
        m = r["metrics"]
        met += bool(m.get("meets_acceptance"))
        cells = acceptance_cells(m)
        lines.append(
            f"| {r['spec']} | {m.get('vertex_count')} | {m.get('fabric')} | {r['wall_s']:.0f} | "
            f"{m.get('sim_time_s', 0):.2f} | {cells} | {_fails(m)} | {_ease(m)} | {_fit(m)} |"
        )
    lines += ["", f"{met} of {len(rows)} meet the acceptance ([drape.md](../drape.md); the "
              "columns as in the [gallery](../gallery/gallery.md)). Wall times are per drape, "
              "import and mesh included. Ease: the garment's girth less the body's after the "
              "drape. The last column: where the pattern's girth is short of "
              "the body's before the drape, by more than its fabric stretches (the fit "
              "check's warning, [drape.md](../drape.md)).", ""]  # fmt: skip
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("specs", nargs="*")
    ap.add_argument("--edge-cm", type=float, default=3.0)
    ap.add_argument("--body", type=Path, default=DATA / "bodies" / "mean_all.yaml")
    ap.add_argument("--size", type=int, default=None, help="a database size instead of --body")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--tag", default=None)
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "bench_garmentcode")
    ap.add_argument("--load", default="", metavar="TEXT",
                    help="what else ran on the machine meanwhile, for the table's header "
                    "(its times are then upper bounds)")  # fmt: skip
    ap.add_argument("--rewrite", action="store_true",
                    help="rewrite the table from its JSON (no drapes)")  # fmt: skip
    args, extra = ap.parse_known_args(argv)  # the rest: flags for `drape`
    args.extra = [a for a in extra if a != "--"]
    who = f"size{args.size}" if args.size else args.body.stem
    tag = args.tag or f"{who}_{args.edge_cm:g}cm"
    if args.rewrite:
        old = json.loads((RESULTS / f"garmentcode_{tag}.json").read_text())
        (RESULTS / f"garmentcode_{tag}.md").write_text(_table(old["designs"], old["settings"], tag))
        print(f"wrote {RESULTS / f'garmentcode_{tag}.md'}")
        return 0
    out = args.out / tag
    specs = _specs(args.specs)
    threads = 1 if args.jobs > 1 else None
    t0 = time.perf_counter()
    with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        rows = list(pool.map(lambda s: _drape(s, out, args, threads), specs))
    for r in rows:
        state = r.get("error") or ("meets" if r["metrics"].get("meets_acceptance") else
                                   "fails: " + _fails(r["metrics"]))  # fmt: skip
        print(f"{r['spec']}: {state} ({r.get('wall_s', 0):.0f} s)", flush=True)
    header = (f"`python benchmarks/bench_garmentcode.py --edge-cm {args.edge_cm:g} "
              + (f"--size {args.size}" if args.size else f"--body {args.body.relative_to(ROOT)}")
              + f" --jobs {args.jobs}`" + (" -- " + " ".join(args.extra) if args.extra else "")
              + f", on {platform.machine()} with {os.cpu_count()} cores"
              + (f", {args.jobs} drapes at a time on one thread each" if args.jobs > 1 else "")
              + f"; {time.perf_counter() - t0:.0f} s in all"
              + (f"; meanwhile the machine also ran {args.load} (the times are upper bounds)"
                 if args.load else ""))  # fmt: skip
    RESULTS.mkdir(parents=True, exist_ok=True)
    SHEETS.mkdir(parents=True, exist_ok=True)
    earlier = RESULTS / f"garmentcode_{tag}.json"
    for r in rows:
        r["ran"] = header  # each row keeps the run it came from
    if args.specs and earlier.is_file():  # the designs not named keep their earlier rows
        done = {r["spec"] for r in rows}
        old = json.loads(earlier.read_text())
        kept = [r for r in old["designs"] if r["spec"] not in done]
        for r in kept:
            r.setdefault("ran", old["settings"])
        rows = sorted(rows + kept, key=lambda r: r["spec"])
        runs = list(dict.fromkeys(r["ran"] for r in kept))
        header = (f"rows of {', '.join(sorted(done))} from {header}"
                  + "".join(f"; rows of {', '.join(r['spec'] for r in kept if r['ran'] == run)}"
                            f" from {run}" for run in runs))  # fmt: skip
    (RESULTS / f"garmentcode_{tag}.md").write_text(_table(rows, header, tag))
    (RESULTS / f"garmentcode_{tag}.json").write_text(json.dumps(
        {"settings": header, "designs": [{k: v for k, v in r.items() if k != "front"}
                                         for r in rows]}, indent=1, default=str))  # fmt: skip
    import imageio.v3 as iio

    from sandbox.garment.gallery import write_sheet

    def front(r):
        path = r.get("front") or (str(out / r["spec"] / "drape" / "render.png"))
        return iio.imread(path)[:, :, :3] if Path(path).is_file() else None

    tiles = [(r["spec"], front(r)) for r in rows]
    write_sheet(SHEETS / f"{tag}.png", tiles)
    print(f"wrote {RESULTS / f'garmentcode_{tag}.md'} and {SHEETS / f'{tag}.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
