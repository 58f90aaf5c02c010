"""The README's table of figures is the one the generator reads from the generated files."""

import json
from pathlib import Path

import pytest

from sandbox.errors import SandboxError
from sandbox.validate import figures as fig

ROOT = Path(__file__).resolve().parents[1]


def test_readme_table_is_generated_from_the_files_under_docs():
    figs = fig.figures(ROOT)
    readme = (ROOT / fig.README).read_text(encoding="utf-8")
    assert fig.readme_block(readme) == fig.table(figs), (
        "README.md's figures table is out of date: run `python -m sandbox figures`"
    )
    page = (ROOT / fig.FIGURES_PAGE).read_text(encoding="utf-8")
    assert page == fig.page(figs), "docs/figures.md is out of date: run python -m sandbox figures"


def test_every_source_and_link_exists():
    for f in fig.figures(ROOT):
        assert (ROOT / f.source).is_file(), f.source
    # the page's links are relative to docs/
    for f in fig.figures(ROOT):
        assert (ROOT / "docs" / f.source.removeprefix("docs/")).is_file()


def _gallery(tmp_path: Path, rows: list[dict]) -> str:
    rel = "g/gallery.json"
    (tmp_path / "g").mkdir()
    (tmp_path / rel).write_text(json.dumps({"settings": "x", "garments": rows}))
    return rel


def test_gallery_counts_passes_and_takes_median_and_range(tmp_path):
    rows = [
        {"garment": "a", "wall_time_s": 100.0, "meets_acceptance": True, "seam_gap_max_m": 1e-3},
        {"garment": "b", "wall_time_s": 300.0, "meets_acceptance": False, "seam_gap_max_m": 2.5e-3},
        {"garment": "c", "wall_time_s": 1200.0, "meets_acceptance": True, "seam_gap_max_m": None},
        {"garment": "d", "error": "diverged"},
    ]
    passed, times = fig.gallery_figures(tmp_path, _gallery(tmp_path, rows), "G", "cmd")
    assert passed.value == "2 of 4; largest seam gap 2.50 mm"
    assert times.value == "median 300 s (100–1,200 s)"
    assert passed.command == "cmd" and passed.source == "g/gallery.json"


def test_missing_or_bad_source_is_one_line_naming_the_file(tmp_path):
    with pytest.raises(SandboxError, match=r"docs/demo/metrics.json: missing"):
        fig.demo_figure(tmp_path)
    (tmp_path / "docs/report").mkdir(parents=True)
    (tmp_path / fig.REPORT).write_text("{not json")
    with pytest.raises(SandboxError, match=r"docs/report/report.json: cannot read"):
        fig.cantilever_figures(tmp_path)


def test_step_figure_takes_the_first_run_and_the_row_nearest_16k(tmp_path):
    (tmp_path / "docs/results").mkdir(parents=True)
    (tmp_path / fig.BENCH_STEP).write_text(
        "$ python benchmarks/bench_step.py\n"
        "machine: x86_64, 4 cores, ?, float32\n"
        " vertices triangles  hinges   serial fused  parallel step   [M vertex-steps/s]\n"
        "     4508      8778   13049           8.86           7.50\n"
        "    17883     35292   52702           8.34          11.46\n"
        "    70630    140314  209999           7.61          12.78\n"
        "\n$ an older run\n"
        "    16000     35292   52702           1.00           1.00\n"
    )
    f = fig.step_figure(tmp_path)
    assert f.value == "11.5 M vertex-steps/s"
    assert "17,883 vertices" in f.name and "4-core" in f.name


def test_cantilever_takes_the_finest_explicit_mesh_per_lambda(tmp_path):
    def run(lam, edge, err, integ="symplectic_euler"):
        return {"case": "cantilever", "integrator": integ, "edge_length_m": edge,
                "error_pct": err, "params": {"lambda": lam}}  # fmt: skip

    data = {
        "mode": "quick",
        "runs": [run(1, 0.005, 0.5), run(1, 0.0025, 0.1), run(8, 0.0025, 0.52),
                 run(8, 0.001, 0.0, "implicit_euler")],
        "speedup": {"lambda": 30.0, "target_tip_error_pct_L": 1.0, "speedup": 12.5,
                    "symplectic_euler": {"wall_time_s": 25.0},
                    "implicit_euler": {"wall_time_s": 2.0}},
    }  # fmt: skip
    (tmp_path / "docs/report").mkdir(parents=True)
    (tmp_path / fig.REPORT).write_text(json.dumps(data))
    err, speed = fig.cantilever_figures(tmp_path)
    assert err.value == "λ = 1: 0.10, λ = 8: 0.52 % of L"
    assert "2.5 mm mesh" in err.name
    assert speed.value == "12.5× faster (2.00 s against 25.0 s)"
    assert err.command == "python -m sandbox report --quick"


def test_readme_with_replaces_only_the_block():
    figs = [fig.Figure("f", "1 | 2", "c", "s")]
    text = f"intro\n{fig.BEGIN}\nold table\n{fig.END}\nrest\n"
    new = fig.readme_with(text, figs)
    assert new.startswith("intro\n") and new.endswith(f"{fig.END}\nrest\n")
    assert fig.readme_block(new) == fig.table(figs)
    assert "1 \\| 2" in fig.table(figs)
    with pytest.raises(SandboxError, match="README.md: no"):
        fig.readme_with("no markers", figs)


def test_gallery_speed_figures_quote_time_and_distance_to_the_reference(tmp_path):
    rows = [
        {"garment": "a", "total_s": 10.0, "ref_total_s": 100.0, "dist_mean_cm": 0.5,
         "dist_p95_cm": 1.2, "ease_bust_delta_cm": -0.3, "ease_waist_delta_cm": 0.1,
         "ease_hip_delta_cm": None, "hem_delta_cm": -0.4, "meets_acceptance": True},
        {"garment": "b", "total_s": 30.0, "ref_total_s": 300.0, "dist_mean_cm": 0.9,
         "dist_p95_cm": 2.0, "ease_bust_delta_cm": 0.6, "ease_waist_delta_cm": None,
         "ease_hip_delta_cm": None, "hem_delta_cm": 0.2, "meets_acceptance": False},
    ]  # fmt: skip
    (tmp_path / fig.GALLERY_SPEED).parent.mkdir(parents=True)
    (tmp_path / fig.GALLERY_SPEED).write_text(json.dumps(rows))
    time_fig, shape_fig = fig.gallery_speed_figures(tmp_path)
    assert (
        time_fig.value == "median 20 s (10–30 s); the direct 1 cm reference: median 200 s "
        "(100–300 s)"
    )
    assert "median 0.70 cm, largest 0.90 cm (95th percentile up to 2.00 cm)" in shape_fig.value
    assert "ease within 0.60 cm, lowest point within 0.40 cm; 1 of 2 meet" in shape_fig.value
