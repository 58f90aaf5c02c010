"""Bad and extreme pattern files: each is refused with one line naming the file and the item,
or loads with a warning that names them; nothing crashes, nothing runs unbounded."""

import copy
import json
import logging
import time
from pathlib import Path

import numpy as np
import pytest

from sandbox.errors import SandboxError
from sandbox.pattern.limits import PatternLimits
from sandbox.pattern.mesh2d import mesh_polygon
from sandbox.pattern.panel_mesh import mesh_pattern
from sandbox.pattern.spec import load_pattern

SKIRT = Path(__file__).parent / "data" / "pattern_skirt.json"
SECONDS = 20.0  # each case, on a slow shared CPU


def skirt() -> dict:
    return json.loads(SKIRT.read_text())


def square(n_side: int = 1, size: float = 40.0) -> dict:
    """A one-panel pattern: a square of ``size`` with ``n_side`` straight edges a side."""
    pts = []
    for (x0, y0), (x1, y1) in [((0, 0), (1, 0)), ((1, 0), (1, 1)), ((1, 1), (0, 1)),
                               ((0, 1), (0, 0))]:  # fmt: skip
        pts += [[size * (x0 + (x1 - x0) * k / n_side), size * (y0 + (y1 - y0) * k / n_side)]
                for k in range(n_side)]  # fmt: skip
    return polygon(pts)


def polygon(pts, units="cm", **top) -> dict:
    n = len(pts)
    edges = [{"name": f"e{k}", "from": k, "to": (k + 1) % n} for k in range(n)]
    return {"format": "sandbox-pattern/1", "units": units, "mesh_edge": 2.0, **top,
            "panels": {"body": {"vertices": pts, "edges": edges}}}  # fmt: skip


def front(d: dict) -> dict:
    return d["panels"]["front"]


def edit(d: dict, fn) -> dict:
    d = copy.deepcopy(d)
    fn(d)
    return d


def star(spikes: int) -> dict:
    t = np.linspace(0, 2 * np.pi, 2 * spikes, endpoint=False)
    r = np.where(np.arange(2 * spikes) % 2 == 0, 40.0, 0.01)
    return polygon(np.round(np.c_[r * np.cos(t), r * np.sin(t)], 6).tolist())


# name -> (file content: a dict, or raw text/bytes; expected text in the one-line error)
ERRORS = {
    "same corner twice in a row": (
        edit(
            skirt(),
            lambda d: front(d).update(
                vertices=[[-30, 0], [30, 0], [30, 0], [18, 60], [-18, 60]],
                edges=[
                    {"name": "hem", "from": 0, "to": 1},
                    {"name": "dup", "from": 1, "to": 2},
                    {"name": "side_left", "from": 2, "to": 3},
                    {"name": "waist", "from": 3, "to": 4},
                    {"name": "side_right", "from": 4, "to": 0},
                ],
            ),
        ),
        "panel 'front': edge 'dup' (#1): zero-length edge",
    ),  # fmt: skip
    "near-duplicate corner (0.1 micron)": (
        polygon([[0, 0], [40, 0], [40, 1e-5], [40, 40], [0, 40]]),
        "panel 'body': edge 'e1' (#1): zero-length edge",
    ),
    "corner repeated later (touching)": (
        polygon([[0, 0], [40, 0], [20, 20], [40, 40], [0, 40], [20, 20]]),
        "self-intersecting outline",
    ),
    "fold back along a line": (
        polygon([[0, 0], [40, 0], [20, 0], [20, 40]]),
        "panel 'body': edge 'e0' (#0) crosses edge 'e1' (#1)",
    ),
    "bow tie": (
        polygon([[0, 0], [40, 40], [40, 0], [0, 40]]),
        "panel 'body': edge 'e0' (#0) crosses edge 'e2' (#2) at (20, 20) cm: self-intersecting",
    ),
    "vertex touching another edge": (
        polygon([[0, 0], [40, 0], [40, 40], [20, 0.0], [0, 40]]),
        "self-intersecting outline",
    ),
    "curve crossing the opposite edge": (
        edit(skirt(), lambda d: front(d)["edges"][2].update(curve={"type": "arc", "sagitta": 70})),
        "panel 'front': edge 'hem' (#0) crosses edge 'waist' (#2) at (-24.41, -0.6751) cm",
    ),
    "cubic looping over itself": (
        edit(
            square(),
            lambda d: d["panels"]["body"]["edges"][0].update(
                curve={"type": "cubic", "controls": [[60, 30], [-20, 30]]}
            ),
        ),
        "panel 'body': edge 'e0' (#0) crosses itself",
    ),  # fmt: skip
    "collinear outline (zero area)": (
        polygon([[0, 0], [20, 0], [40, 0], [30, 0.0]]),
        "panel 'body': the outline has zero area (its corners are on one line)",
    ),
    "clockwise outline": (
        polygon([[0, 0], [0, 40], [40, 40], [40, 0]]),
        "panel 'body': the outline runs clockwise",
    ),
    "NaN coordinate": (
        '{"format": "sandbox-pattern/1", "panels": {"body": {"vertices": [[0, 0], [NaN, 0], '
        '[40, 40]], "edges": [{"from": 0, "to": 1}, {"from": 1, "to": 2}, {"from": 2, "to": 0}]}}}',
        "panel 'body': vertex 1 must be a list of 2 finite numbers",
    ),
    "infinite coordinate": (
        '{"format": "sandbox-pattern/1", "panels": {"body": {"vertices": [[0, 0], [40, 0], '
        '[1e400, 40]], "edges": [{"from": 0, "to": 1}, {"from": 1, "to": 2}, '
        '{"from": 2, "to": 0}]}}}',
        "panel 'body': vertex 2 must be a list of 2 finite numbers",
    ),
    "integer too large for a float": (
        '{"format": "sandbox-pattern/1", "panels": {"body": {"vertices": [[0, 0], [40, 0], '
        f'[{"9" * 400}, 40]], "edges": [{{"from": 0, "to": 1}}, {{"from": 1, "to": 2}}, '
        '{"from": 2, "to": 0}]}}}',
        "panel 'body': vertex 2 must be a list of 2 finite numbers",
    ),
    "number of 5000 digits": (
        '{"format": "sandbox-pattern/1", "mesh_edge": ' + "1" * 5000 + "}",
        "cannot read the JSON",
    ),
    "nesting 100000 deep": ("[" * 100_000 + "]" * 100_000, "cannot read the JSON"),
    "not UTF-8": (b"\xff\xfe\x00garbage\x81", "not a UTF-8 text file"),
    "not JSON": ("{panels: }", "not valid JSON (line 1, column 2"),
    "panel far from the origin": (
        polygon([[1e9, 0], [1e9 + 40, 0], [1e9 + 40, 40], [1e9, 40]]),
        "panel 'body': vertex 0 [1000000000.0, 0.0] lies more than 100 m from the origin",
    ),
    "control point far away": (
        edit(
            square(),
            lambda d: d["panels"]["body"]["edges"][0].update(
                curve={"type": "quadratic", "control": [20, -1e12]}
            ),
        ),
        "edge 'e0' (#0): quadratic control point 0",
    ),  # fmt: skip
    "arc sagitta of 1e300": (
        edit(
            square(),
            lambda d: d["panels"]["body"]["edges"][1].update(
                curve={"type": "arc", "sagitta": 1e300}
            ),
        ),
        "edge 'e1' (#1): arc sagitta 1e+300 is more than 1000 chords",
    ),  # fmt: skip
    "units m, numbers in cm (60 m panels)": (
        edit(skirt(), lambda d: d.update(units="m")),
        "panel 'front' is 60 m across, larger than the 4 m any garment panel needs "
        '(PatternLimits.max_panel_extent_m); the file says "units": "m": are its numbers in cm',
    ),
    "units cm, numbers in mm (a 6 m skirt)": (
        edit(
            skirt(),
            lambda d: (
                [
                    p["vertices"].__setitem__(
                        slice(None), [[10 * x, 10 * y] for x, y in p["vertices"]]
                    )
                    for p in d["panels"].values()
                ]
                or [e.pop("curve", None) for p in d["panels"].values() for e in p["edges"]]
            ),
        ),
        "panel 'front' is 6 m across",
    ),  # fmt: skip
    "20,001 corners": (
        polygon(
            np.round(
                np.c_[
                    30 * np.cos(np.linspace(0, 2 * np.pi, 20_001, endpoint=False)),
                    30 * np.sin(np.linspace(0, 2 * np.pi, 20_001, endpoint=False)),
                ],
                4,
            ).tolist()
        ),
        "panel 'body': 20,001 vertices, more than the limit of 20,000",
    ),  # fmt: skip
    "star of 6000 spikes": (star(6000), "panel 'body': the outline is too intricate to check"),
    "edge from a vertex to itself": (
        edit(
            square(),
            lambda d: d["panels"]["body"]["edges"].insert(1, {"name": "loop", "from": 1, "to": 1}),
        ),
        "panel 'body': edge 'loop' (#1): zero-length edge",
    ),  # fmt: skip
    "two corners only": (
        polygon([[0, 0], [40, 0]]),
        "panel 'body': the outline has zero area (its corners are on one line)",
    ),
}

MESH_ERRORS = {  # load, then refused when meshed (the file's mesh_edge)
    "mesh edge of 1 micron": (
        edit(skirt(), lambda d: d.update(mesh_edge=1e-4)),
        "would have about 734,818,100,926 vertices, more than the limit of 1,000,000",
    ),
    "mesh edge of 1e-300": (edit(skirt(), lambda d: d.update(mesh_edge=1e-300)), "overflowing"),
}

WARNINGS = {
    "units mm, numbers in cm (a 6 cm skirt)": (
        edit(skirt(), lambda d: d.update(units="mm")),
        "the largest panel, 'front', is only 6 cm across: small for a garment; the file says "
        '"units": "mm": are its numbers in cm',
    ),
    "seam sides 58 cm apart": (
        edit(skirt(), lambda d: d["seams"][0]["a"].append({"panel": "front", "edge": "hem"})),
        "seam #0: side a (front.side_left + front.hem) is 1.21 m long, side b (back.side_left) "
        "61.3 cm: they differ by 60.2 cm",
    ),
    "a 5 mm panel": (
        edit(
            skirt(),
            lambda d: d["panels"].update(
                tab=polygon([[0, 0], [0.5, 0], [0, 0.5]])["panels"]["body"]
            ),
        ),
        "panel 'tab' is only 5 mm across",
    ),  # fmt: skip
}


def write(tmp_path: Path, name: str, content) -> Path:
    path = tmp_path / (name.replace(" ", "_").replace("/", "_")[:40] + ".json")
    if isinstance(content, bytes):
        path.write_bytes(content)
    elif isinstance(content, str):
        path.write_text(content)
    else:
        path.write_text(json.dumps(content))
    return path


def one_line(msg: str, path: Path) -> None:
    assert "\n" not in msg and "Traceback" not in msg, msg
    assert msg.startswith(str(path)), msg


@pytest.mark.parametrize("name", list(ERRORS))
def test_bad_pattern_file_is_refused_in_one_line(tmp_path, name):
    content, expected = ERRORS[name]
    path = write(tmp_path, name, content)
    t0 = time.perf_counter()
    with pytest.raises(SandboxError) as err:
        mesh_pattern(load_pattern(path))
    assert time.perf_counter() - t0 < SECONDS
    one_line(str(err.value), path)
    assert expected in str(err.value), str(err.value)


@pytest.mark.parametrize("name", list(MESH_ERRORS))
def test_mesh_too_large_is_refused_before_meshing(tmp_path, name):
    content, expected = MESH_ERRORS[name]
    path = write(tmp_path, name, content)
    pattern = load_pattern(path)
    t0 = time.perf_counter()
    with pytest.raises(SandboxError) as err:
        mesh_pattern(pattern)
    assert time.perf_counter() - t0 < 2.0  # refused from the estimate, nothing sampled
    one_line(str(err.value), path)
    assert expected in str(err.value) and "PatternLimits.max_mesh_vertices" in str(err.value)


@pytest.mark.parametrize("name", list(WARNINGS))
def test_implausible_pattern_loads_with_a_warning(tmp_path, caplog, name):
    content, expected = WARNINGS[name]
    path = write(tmp_path, name, content)
    with caplog.at_level(logging.WARNING, logger="sandbox.pattern"):
        load_pattern(path)
    msgs = [r.getMessage() for r in caplog.records if r.name == "sandbox.pattern"]
    assert len(msgs) == 1, msgs
    one_line(msgs[0], path)
    assert expected in msgs[0], msgs[0]


def test_library_sizes_and_seams_raise_no_warning(caplog):
    from sandbox.drafting import draft, garment_names
    from sandbox.mannequin.measurements import size_entry

    with caplog.at_level(logging.WARNING, logger="sandbox.pattern"):
        for size in (6, 24):
            for name in garment_names():
                load_pattern(draft(name, size_entry(size).measurements), where=name)
    assert not caplog.records, [r.getMessage() for r in caplog.records]


def test_limits_are_settings(tmp_path):
    path = write(tmp_path, "big", edit(skirt(), lambda d: d.update(units="m")))
    load_pattern(path, limits=PatternLimits(max_panel_extent_m=100.0))  # on purpose
    with pytest.raises(SandboxError, match="more than the limit of 10 "):
        load_pattern(SKIRT, limits=PatternLimits(max_file_bytes=10))
    with pytest.raises(SandboxError, match="limit of 500 "):
        mesh_pattern(load_pattern(SKIRT), limits=PatternLimits(max_mesh_vertices=500))
    with pytest.raises(ValueError, match="max_mesh_vertices must be a positive number"):
        PatternLimits(max_mesh_vertices=0)


def test_ten_thousand_corner_outline_loads_fast(tmp_path):
    t = np.linspace(0, 2 * np.pi, 10_000, endpoint=False)
    r = 30 + np.sin(40 * t)
    path = write(tmp_path, "wavy", polygon(np.round(np.c_[r * np.cos(t), r * np.sin(t)], 5)
                                           .tolist(), mesh_edge=3.0))  # fmt: skip
    t0 = time.perf_counter()
    pattern = load_pattern(path)
    assert time.perf_counter() - t0 < 10.0  # 40-50 s and 7.5 GB with an all-pairs check
    mesh = mesh_pattern(pattern)["body"]
    assert len(mesh.boundary) == 10_000


def test_self_crossing_in_a_large_outline_is_located(tmp_path):
    t = np.linspace(0, 2 * np.pi, 4000, endpoint=False)
    pts = np.round(np.c_[30 * np.cos(t), 30 * np.sin(t)], 6)
    pts[[100, 2100]] = pts[[2100, 100]]
    path = write(tmp_path, "crossed", polygon(pts.tolist()))
    pattern = r"panel 'body': edge 'e\d+' \(#\d+\) crosses edge 'e\d+' \(#\d+\) at \(-?[\d.]+, "
    with pytest.raises(SandboxError, match=pattern):
        load_pattern(path)


# --------------------------------------------------------------------------------------
# Outlines of scene files (mesh_polygon): what reaches Triangle is cleaned or refused

SQUARE = [[0, 0], [0.4, 0], [0.4, 0.4], [0, 0.4]]
POLYGON_ERRORS = {
    "fold back": ([[0, 0], [0.4, 0], [0.2, 0], [0.2, 0.4]], (), "side 0-1 meets side 1-2"),
    "bow tie": ([[0, 0], [0.4, 0.4], [0.4, 0], [0, 0.4]], (), "at (0.2, 0.2) m"),
    "all points on a line": ([[0, 0], [0.2, 0], [0.4, 0]], (), "zero area"),
    "NaN": ([[0, 0], [np.nan, 0], [0.4, 0.4]], (), "NaN or infinite"),
    "one point three times": ([[0.1, 0.1]] * 3, (), "at least 3 distinct points"),
    "inner line of zero length": (SQUARE, [((0.1, 0.1), (0.1, 0.1))], "inner line 0 has zero"),
    "inner line outside": (SQUARE, [((0.1, 0.1), (0.9, 0.1))], "inner line 0 [[0.1, 0.1], "),
    "inner line with NaN": (SQUARE, [((0.1, np.nan), (0.2, 0.1))], "inner line 0 must be"),
    "1 km outline at 1 mm": ([[0, 0], [1e3, 0], [1e3, 1e3], [0, 1e3]], (), "limit of 1,000,000"),
    "1e200 m outline": ([[0, 0], [1e200, 0], [1e200, 1e200], [0, 1e200]], (), "too large"),
}


@pytest.mark.parametrize("name", list(POLYGON_ERRORS))
def test_bad_scene_outline_is_refused(name):
    outline, lines, expected = POLYGON_ERRORS[name]
    with pytest.raises(SandboxError) as err:
        mesh_polygon(np.array(outline, float), 0.001 if "1 mm" in name else 0.05,
                     where="s.toml: cloth[0]", inner_segments=lines)  # fmt: skip
    one_line(str(err.value), Path("s.toml"))
    assert expected in str(err.value), str(err.value)


def test_repeated_corners_of_a_scene_outline_are_dropped():
    dup = [[0, 0], [0.4, 0], [0.4, 0], [0.4, 0.4], [0.4, 0.4 + 1e-12], [0, 0.4], [0, 0]]
    pts, tris = mesh_polygon(np.array(dup, float), 0.05)
    ref, ref_tris = mesh_polygon(np.array(SQUARE, float), 0.05)
    assert len(pts) == len(ref) and len(tris) == len(ref_tris)


# --------------------------------------------------------------------------------------
# The commands that read pattern files


def test_check_pattern_command_refuses_in_one_line(tmp_path, capsys):
    from sandbox.cli import main

    path = write(tmp_path, "metres", edit(skirt(), lambda d: d.update(units="m")))
    assert main(["check-pattern", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: {path}: panel 'front' is 60 m across") and "\n" not in err


def test_check_pattern_command_warns_and_goes_on(tmp_path, capsys, caplog):
    from sandbox.cli import main

    path = write(tmp_path, "millimetres", edit(skirt(), lambda d: d.update(units="mm")))
    with caplog.at_level(logging.WARNING, logger="sandbox.pattern"):
        assert main(["check-pattern", str(path)]) == 0
    assert "are its numbers in cm" in caplog.text
    assert "panel front:" in capsys.readouterr().out


def test_drape_refuses_a_bad_pattern_before_it_starts(tmp_path, capsys):
    from sandbox.cli import main

    path = write(tmp_path, "bowtie", edit(skirt(), lambda d: front(d).update(
        vertices=[[-30, 0], [30, 0], [-18, 60], [18, 60]])))  # fmt: skip
    t0 = time.perf_counter()
    assert main(["drape", str(path), "--out", str(tmp_path / "out")]) == 2
    assert time.perf_counter() - t0 < SECONDS
    err = capsys.readouterr().err
    assert str(path) in err and "self-intersecting outline" in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()


def test_import_garmentcode_refuses_a_nan(tmp_path, capsys):
    from sandbox.cli import main

    spec = tmp_path / "gc_specification.json"
    spec.write_text('{"pattern": {"panels": {"p": {"vertices": [[0, 0], [NaN, 0], [1, 1]], '
                    '"edges": [{"endpoints": [0, 1]}, {"endpoints": [1, 2]}, {"endpoints": '
                    '[2, 0]}], "translation": [0, 0, 0], "rotation": [0, 0, 0]}}, '
                    '"stitches": []}, "properties": {"units_in_meter": 100}}')  # fmt: skip
    assert main(["import-garmentcode", str(spec), str(tmp_path / "out.json")]) == 2
    err = capsys.readouterr().err
    assert str(spec) in err and "finite" in err and "Traceback" not in err
    assert not (tmp_path / "out.json").exists()
