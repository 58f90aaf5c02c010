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
