"""The report on a tiny configuration: tables, plot and JSON."""

import json

import numpy as np
import pytest
from PIL import Image

from sandbox.validate.plot import loglog_png


def test_loglog_plot_draws_finite_points_only(tmp_path):
    pts = [(0.5, 2.0, "implicit", "cantilever"), (20.0, 0.3, "symplectic", "strip"),
           (1.0, float("nan"), "implicit", "sheet")]  # fmt: skip
    path = tmp_path / "p.png"
    assert loglog_png(pts, path, title="t", xlabel="x", ylabel="y", hline=1.0) == 2
    img = np.asarray(Image.open(path).convert("RGB"))
    assert img.shape == (700, 1000, 3)
    assert ((img[:, :, 0] > 200) & (img[:, :, 1] < 80)).any()  # a red (second series) marker


@pytest.mark.slow
def test_tiny_report_writes_tables_plot_and_json(tmp_path):
    import subprocess
    import sys

    # a child process with a fresh Taichi runtime: the report builds dozens of scenes, and
    # doing that after the rest of the suite in one process crashed inside Taichi's
    # field allocation (a segfault in CI)
    proc = subprocess.run([sys.executable, "-m", "sandbox", "report", "--tiny", "--float64",
                        "--out", str(tmp_path)], capture_output=True, text=True,
                       timeout=900)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-2000:]
    md = (tmp_path / "error-vs-runtime.md").read_text()
    head = ("| case | integrator | h [mm] | dt [µs] | vertices | steps | error [%] | error of |"
            " wall [s] | outcome | rollbacks | Newton / CG per step |")  # fmt: skip
    assert head in md and "report/error_vs_runtime.png" in md
    for case in ("cantilever λ=30", "strip", "sheet", "incline"):
        for integ in ("symplectic", "implicit"):
            assert f"| {case} | {integ} |" in md
    assert "presets meet the target" in md
    assert (tmp_path / "report" / "error_vs_runtime.png").stat().st_size > 1000
    data = json.loads((tmp_path / "report" / "report.json").read_text())
    runs = data["runs"]
    assert len(runs) == 8
    for r in runs:
        assert r["outcome"] in ("ok", "guarded") and r["error_pct"] is not None
        assert r["wall_time_s"] > 0 and r["steps"] > 0
    strip = [r for r in runs if r["case"] == "strip"]
    assert all(r["error_pct"] < 2.0 for r in strip)  # the model's exact extension
    st = (tmp_path / "stability.md").read_text()
    assert "| sweater x1 | symplectic |" in st and "| sweater x1 | implicit |" in st
    cells = data["matrix"]
    assert len(cells) == 4
    for c in cells:
        assert c["outcome"] in ("stable", "guarded", "failed", "wall limit")
    big = [c for c in cells if c["integrator"] == "symplectic_euler" and c["dt_s"] > 0.03][0]
    assert big["guard_fired"] and big["dt_warning"] and "stable limit" in big["dt_warning"]
    assert "written to" in proc.stdout
    contact = data["contact"]
    assert [c["case"] for c in contact] == ["cylinder rim (cotton x1)"] * 2
    assert all(c["outcome"] in ("stable", "guarded") for c in contact)
    page = (tmp_path / "stability-contact.md").read_text()
    assert "| cylinder rim (cotton x1) |" in page and "Failed cells: 0 of 2." in page
