"""The stability report's pages: docs/stability.md (the stiffness × dt matrix and the extreme
cases) and docs/stability-contact.md (cloth on edges, rims, corners and floors), written by
``python -m sandbox report`` from the cells of :mod:`sandbox.validate.stability` and
:mod:`sandbox.validate.contact_cases`."""

from __future__ import annotations

import math

from sandbox.validate import stability
from sandbox.validate.cases import SHORT


def _fmt(v, spec=".3g", none="—"):
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return none
    return format(v, spec)


CELL_HEAD = (
    "| case | integrator | dt [s] | outcome | max strain | guard fired | rollbacks | "
    "final dt [s] | wall [s] | sim time [s] |\n|---|---|---|---|---|---|---|---|---|---|"
)


GUARD_TEXT = [
    "## The guard",
    "",
    "`run_scene` (`sandbox/scene/run.py`) advances every scene a frame at a time through "
    "`sandbox.sim.guard.StepGuard`. After each frame it checks for NaN/inf (the solver's "
    "`first_bad()` and the state), for a rise of the mechanical energy (kinetic + elastic + "
    "gravity) of more than M·|g|·L in one frame, for a warp/weft stretch above 4 (300 % "
    "strain), and for more than 10 % of the triangles turning over in the frame while the "
    "energy rose. On a failure it restores the last good state, halves dt (the frame is "
    "re-run with twice the steps) and goes on; after 10 good frames it doubles dt again, "
    "never above the scene's dt. After 6 halvings (dt/64) it restores the last good state "
    "and raises `SimulationDiverged` with the step, the vertex (and its cloth) and the "
    "reason; no mesh is written. `run_scene(..., guard=False)` keeps only the NaN check, "
    "`guard=GuardConfig(...)` sets the thresholds.",
    "",
    "metrics.json gains `guard_enabled`, `guard_fired`, `guard_rollbacks`, "
    "`guard_final_dt_s`, `guard_min_dt_s`, `guard_max_strain`, `guard_events` (frame, step, "
    "dt, reason, vertex of the first 20 rollbacks), `dt_policy` (`guard-adaptive`), and "
    "`dt_above_stable_limit` / `dt_warning`: a symplectic-Euler scene whose dt_s is above "
    "the builder's stability estimate (`sandbox.scene.build.stable_dt_estimate`) is warned "
    "(the message names that limit) and then runs on the guard's adaptive dt. The estimate "
    "is conservative (the hanging sheets stay stable up to about 1.8× it), so a warned run "
    "need not fire the guard.",
    "",
]


CONTACT_ENERGY_TEXT = [
    "## Where the energy comes from",
    "",
    "`python benchmarks/bench_energy.py SCENE.toml` splits a scene's energy frame by frame: "
    "kinetic, elastic (membrane, bending, seams), gravitational, what the mass damping took "
    "out, and what is left, the work the contact handlers did on the cloth. A stable contact "
    "takes energy out or adds none. On the disc on a cylinder "
    "(`sandbox/scenes/disc_on_cylinder.toml`: a 30 cm cotton disc, its centre pinned, on a "
    "9 cm cylinder's sharp rim) the contact work is −0.3 mJ after 0.2 s "
    "([results/disc_energy.txt](results/disc_energy.txt)). The body's response holds a vertex "
    "the thickness away from its closest point on the body along the line to that point; "
    "measured to the plane of the nearest face instead, a vertex resting on the top face "
    "beside a rim is 0 from the side face's plane and is pushed sideways by the whole "
    "thickness every step: 0.3 J in the first frame, whatever dt. Such energy, found by a "
    "guard that shrank dt 8 times without recovering, is named in the guard's message: it "
    "says the step size is not the cause and names the collider the vertex touched. The "
    "contact rows of the matrix: [stability-contact.md](stability-contact.md).",
    "",
]


def stability_markdown(data, cells, ext, p) -> str:
    m = p["matrix"]
    made = data.get("stability_written") or data  # when and where the matrix was run
    lines = [
        "# Stability matrix",
        "",
        f"Written by `{data['command']}` on {made['date']} ({made['machine']}). Raw numbers: "
        "[report/report.json](report/report.json). Code: `sandbox/validate/stability.py`.",
        "",
        "Matrix: a 20 × 20 cm sheet on a 2 cm mesh starts flat and horizontal and falls, "
        "hanging from its two top corners (damping 1/s), for "
        f"{m['time_s']:g} s of simulated time, each run capped at {m['wall']:g} s of wall "
        "time. Rows: the softest measured preset (sweater), denim, and denim with stretch "
        "and shear ×10, ×100, ×1000 (bending as measured). Outcome: **stable** = finished at "
        "the asked dt with no rollback; **guarded** = the guard (`sandbox/sim/guard.py`) "
        "rolled back and halved dt at least once, then finished (no NaN reached the state "
        "kept); **failed** = it could not recover and stopped with a message naming the "
        "step and vertex; **wall limit** = the cap stopped it first (sim time shows how far "
        "it got). Max strain is the largest warp/weft strain at any frame end.",
        "",
        *GUARD_TEXT,
        *CONTACT_ENERGY_TEXT,
        "## Summary (outcome per stiffness and dt)",
        "",
    ]
    dts = m["dts"]
    head = "| stiffness | integrator | " + " | ".join(f"dt = {d:.3g} s" for d in dts) + " |"
    lines += [head, "|---|---|" + "---|" * len(dts)]
    keyed = {}
    for c in cells:
        keyed.setdefault((c.case, c.integrator), []).append(c)
    for (case, integ), row in keyed.items():
        parts = []
        for c in row:
            s = c.outcome
            if c.outcome == "guarded":
                s += f" ({c.rollbacks}×, {c.final_dt_s:.2g} s)"
            if c.max_strain is not None and c.outcome != "failed":
                s += f", ε {c.max_strain:.2g}"
            parts.append(s)
        lines.append(f"| {case} | {SHORT[integ]} | " + " | ".join(parts) + " |")
    lines += ["", "## All cells", "", CELL_HEAD, *[stability.cell_row(c) for c in cells], ""]
    e = p["extremes"] or {"wall": 0.0}
    lines += [
        "## Extreme cases",
        "",
        f"Each at the integrator's automatic dt (symplectic: 0.9 × the stability estimate; "
        f"implicit: 1/60 s) unless stated, through the guard, capped at {e['wall']:g} s of "
        "wall time. Slivers: a 20 cm grid whose 6th column of vertices is moved to 10 µm from "
        "the 5th (a row of triangles with near-zero area). Crumpled: the sheet starts scaled "
        "to 10 % of its size with ±5 mm random offsets, hanging from one corner. Impact: a "
        "30 cm jersey sheet at 10 m/s against a cylinder of radius 3 cm, no gravity. Resize: "
        "a 40 cm sheet draped on a sphere (r = 8 cm) whose collider is scaled ×1.3 or ×0.7 in "
        "one frame half-way (`BodyCollider.update`). Seam: two 20 × 30 cm panels whose sewn "
        "edges start 30 cm apart, no gravity. Self-collision is off in these scenes (cost).",
        "",
        CELL_HEAD.replace("| sim time [s] |", "| sim time [s] | notes |").replace(
            "|---|\n", "|---|---|\n", 1
        ).replace("|---|---|---|---|---|---|---|---|---|---|", "|---|---|---|---|---|---|---|"
                  "---|---|---|---|"),
    ]  # fmt: skip
    for c in ext:
        notes = ", ".join(f"{k} {_fmt(v) if isinstance(v, float) else v}"
                          for k, v in c.extra.items())  # fmt: skip
        if c.dt_warning:
            notes += f"; dt above the stable limit {c.dt_limit_s:.3g} s (warned)"
        if c.message:
            notes += f"; {c.message}"
        lines.append(stability.cell_row(c) + f" {notes} |")
    lines.append("")
    return "\n".join(lines)


def contact_markdown(data, cells, p) -> str:
    """docs/stability-contact.md: the contact rows, one line per scene and fabric."""
    from sandbox.validate import contact_cases

    made = data.get("contact_written") or data
    c = p["contact"]
    lines = [
        "# Stability with contact",
        "",
        f"Written by `{data['command']} --only contact` on {made['date']} ({made['machine']}). "
        "Raw numbers: [report/report.json](report/report.json). Code: "
        "`sandbox/validate/contact_cases.py`.",
        "",
        "Cloth against the sharp edges, rims and corners of rigid bodies, piled on a floor and "
        f"dragged over an edge, for {c['time_s']:g} s of simulated time at the integrator's "
        "automatic dt, through the guard, each run capped at "
        f"{c['wall']:g} s of wall time; 1.5 cm meshes, contact thickness "
        f"{contact_cases.THICKNESS_M * 1e3:g} mm. The outcome is the stability matrix's "
        "([stability.md](stability.md)): **stable**, **guarded** (rolled back and finished), "
        "**failed** or **wall limit**.",
        "",
        contact_cases.__doc__.split("The scenes:")[1].strip(),
        "",
        "## Summary",
        "",
        "| scene (fabric) | " + " | ".join(SHORT[i] for i in c["integrators"]) + " |",
        "|---|" + "---|" * len(c["integrators"]),
    ]
    keyed = {}
    for cell in cells:
        keyed.setdefault(cell.case, {})[cell.integrator] = cell
    for case, by in keyed.items():
        parts = []
        for integ in c["integrators"]:
            cell = by.get(integ)
            s = "—" if cell is None else cell.outcome
            if cell is not None and cell.extra.get("vertices_inside_body"):
                s += f", {cell.extra['vertices_inside_body']} inside"
            parts.append(s)
        lines.append(f"| {case} | " + " | ".join(parts) + " |")
    failed = sum(cell.outcome == "failed" for cell in cells)
    lines += ["", f"Failed cells: {failed} of {len(cells)}.", "", "## All cells", "",
              CELL_HEAD.replace("| sim time [s] |", "| sim time [s] | notes |").replace(
                  "|---|---|---|---|---|---|---|---|---|---|",
                  "|---|---|---|---|---|---|---|---|---|---|---|")]  # fmt: skip
    for cell in cells:
        notes = ", ".join(f"{k} {_fmt(v) if isinstance(v, float) else v}"
                          for k, v in cell.extra.items())  # fmt: skip
        if cell.message:
            notes += f"; {cell.message}"
        lines.append(stability.cell_row(cell) + f" {notes} |")
    lines.append("")
    return "\n".join(lines)
