"""The pattern commands of ``python -m sandbox`` (they call the same code as scripts do)."""

import json
from pathlib import Path

from sandbox.cli import main

DATA = Path(__file__).parent / "data"


def test_pattern_list_and_check_pattern(capsys, tmp_path):
    assert main(["pattern", "--list"]) == 0
    names = capsys.readouterr().out.split()
    assert len(names) == 14 and "t-shirt" in names and "circle-skirt" in names
    out = tmp_path / "skirt.json"
    assert main(["pattern", "a-line-skirt", "--size", "12", "--out", str(out)]) == 0
    assert json.loads(out.read_text())["format"] == "sandbox-pattern/1"
    capsys.readouterr()
    assert main(["check-pattern", str(out)]) == 0
    report = capsys.readouterr().out
    assert "panel" in report and "seam 0" in report


def test_import_garmentcode_and_bad_input(capsys, tmp_path):
    src = DATA / "garmentcode_skirt_specification.json"
    out = tmp_path / "gc.json"
    assert main(["import-garmentcode", str(src), str(out)]) == 0
    assert json.loads(out.read_text())["format"] == "sandbox-pattern/1"
    assert main(["check-pattern", str(tmp_path / "missing.json")]) == 2
    assert "missing.json" in capsys.readouterr().err


def test_demo_is_drape_with_its_defaults(monkeypatch, tmp_path):
    """`make demo` runs `demo`, which must hand `drape` a complete set of its options (it
    once broke when drape gained --integrator)."""
    import sandbox.cli as cli

    seen = {}
    monkeypatch.setattr(cli, "cmd_drape", lambda args: seen.update(vars(args)) or 0)
    assert main(["demo", "--out", str(tmp_path), "--edge-cm", "4", "--no-render", "-q"]) == 0
    assert seen["garment"] == cli.DEFAULT_GARMENT and seen["list"] is False
    assert seen["edge_cm"] == 4.0 and seen["out"] == tmp_path and seen["no_render"]
    assert seen["integrator"] is None and seen["config"] is None  # DrapeConfig's defaults
    assert seen["fabric"] is None
    assert seen["time_limit"] is None and not seen["no_self_collision"]
