"""The teaching programs in examples/: each runs as a script and prints what it should.

Each example is run as its own process (as a reader would run it) and the test reads the
numbers it prints: exit status 0, the stop rule met, and the figures against the paper's
rules or the references they quote.
"""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def run_example(name: str, *args: str, tmp_path: Path) -> str:
    """Run examples/<name>.py with --out into tmp_path; return its stdout."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    # The implicit solver's small banded factorisations (LAPACK through OpenBLAS) run
    # many times slower when OpenBLAS's threads compete for a busy CPU.
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
    proc = subprocess.run(
        [sys.executable, str(ROOT / "examples" / f"{name}.py"), *args, "--out", str(tmp_path)],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert (tmp_path / f"{name}.png").stat().st_size > 1000
    return proc.stdout


def number(text: str, pattern: str) -> float:
    """The first number captured by ``pattern`` (a regex with one group) in ``text``."""
    match = re.search(pattern, text)
    assert match, f"{pattern!r} not in:\n{text}"
    return float(match.group(1))


@pytest.mark.slow
def test_hanging_sheet_meets_the_stop_rule_and_hangs_its_length(tmp_path):
    out = run_example("hanging_sheet", "--quick", tmp_path=tmp_path)
    assert "stop rule met: True" in out
    assert number(out, r"max displacement ([\d.]+) mm") < 1.5
    assert number(out, r"mean ([\d.]+) mm \(< 0.1\)") < 0.1
    # a 50 cm sheet hung by its top corners: the bottom is about 50 cm below them
    assert 48.0 < number(out, r"lowest point ([\d.]+) cm below") < 53.0
    assert number(out, r"warp max ([\d.]+) %") < 5.0  # denim barely stretches


@pytest.mark.slow
def test_cantilever_matches_the_heavy_elastica(tmp_path):
    out = run_example("cantilever", tmp_path=tmp_path)  # λ = 8, 5 mm mesh
    assert "at rest: True" in out
    assert number(out, r"reference ([\d.]+) deg") == pytest.approx(41.49, abs=0.01)
    assert number(out, r"chord angle:\s+simulated ([\d.]+) deg") == pytest.approx(41.49, abs=1.5)
    assert number(out, r"tip error ([\d.]+) % of L") < 2.5


@pytest.mark.slow
def test_two_panels_are_sewn_the_right_way_round(tmp_path):
    out = run_example("sew_two_panels", tmp_path=tmp_path)
    assert "-> sew P1-P4, P2-P3" in out  # the edges were given running opposite ways
    assert "sewn: True" in out
    assert number(out, r"seam gap before ([\d.]+) mm") == pytest.approx(100.0, abs=0.5)
    assert number(out, r"seam gap before [\d.]+ mm, after ([\d.]+) mm") < 2.0


@pytest.mark.slow
def test_sheet_rests_on_the_sphere_without_entering_it(tmp_path):
    out = run_example("sheet_on_sphere", tmp_path=tmp_path)
    assert "inside the sphere: 0 vertices" in out
    assert "at rest after" in out and "slid off" not in out
    assert number(out, r"closest vertex (-?[\d.]+) mm") > 0.0
    assert number(out, r"centre slid ([\d.]+) cm") < 10.0


@pytest.mark.slow
def test_explicit_and_implicit_euler_agree_on_the_stiff_strip(tmp_path):
    out = run_example("explicit_vs_implicit", tmp_path=tmp_path)
    errors = [float(e) for e in re.findall(r"error ([\d.]+) % of L", out)]
    assert len(errors) == 2 and max(errors) < 2.5  # both against the exact elastica
    assert number(out, r"implicit: (\d+)x fewer steps") > 100
    assert number(out, r"differ by ([\d.]+) mm") < 0.1
