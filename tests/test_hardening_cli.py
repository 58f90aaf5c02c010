"""Bad input to every command is refused up front: exit status 2, one line on stderr naming
the flag or file, no traceback, nothing written, and Taichi never started.

Each case runs ``sandbox.cli.main`` in this process with ``runtime.init`` replaced by a trap,
so a check that came after Taichi started fails the test. Nothing here simulates.
"""

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest

from sandbox import runtime
from sandbox.cli import main
from tests.helpers import small_sheet_toml

DATA = Path(__file__).parent / "data"
UNWRITABLE = "/sys/sandbox-test-out"  # not writable, not even by root

MANNEQUIN = '[[collider]]\nshape = "mannequin"\n'


def scene(material='"denim"', pins='{ corners = "top" }', collider=""):
    return small_sheet_toml(material, pins, after=collider)


def script(*actions):
    return json.dumps(list(actions))


SCRIPT = ["gui", "--offscreen", "--script", "{t}/s.json"]
RUN = ["run", "{t}/s.toml", "--out", "{t}/o"]
GC_SPEC = str(DATA / "garmentcode_skirt_specification.json")


def gui(name, actions, expected):
    """A case of a GUI script with these actions."""
    return name, SCRIPT, {"s.json": script(*actions)}, expected


def run(name, toml, expected):
    """A case of ``run`` on a scene file with this text."""
    return name, RUN, {"s.toml": toml}, expected


def cmd(name, argv, expected, files=None):
    return name, argv, files or {}, expected


def mannequin(text):
    return scene(collider=MANNEQUIN + text)


def material(text):
    return scene(material=text)


def seam(a):
    """The sheet's edge 2 (its top) sewn to a ``from_m``/``to_m`` segment ``a``."""
    return scene(collider=f'[[seam]]\na = [{{ cloth = "sheet", {a} }}]\n'
                          'b = [{ cloth = "sheet", edge = 2 }]\n')  # fmt: skip


# (id, argv with {t} for the test folder, files to write {name: text}, what stderr names)
CASES = [
    # ------------------------------------------------------------ output paths
    cmd("run-out-is-file", ["run", "{t}/ok.toml", "--out", "{t}/afile"],
        "--out {t}/afile: exists and is not a directory"),
    cmd("run-out-under-file", ["run", "{t}/ok.toml", "--out", "{t}/afile/a/b"],
        "{t}/afile is a file, not a directory"),
    cmd("run-out-unwritable", ["run", "{t}/ok.toml", "--out", UNWRITABLE],
        f"--out {UNWRITABLE}: cannot write"),
    cmd("run-out-metrics-is-dir", ["run", "{t}/ok.toml", "--out", "{t}/adir"],
        "adir/metrics.json is a directory"),
    cmd("demo-out-is-file", ["demo", "--out", "{t}/afile"], "--out {t}/afile: exists and is not"),
    cmd("demo-scene-out-under-file", ["demo", "--scene", "--out", "{t}/afile/x"],
        "--out {t}/afile/x"),
    cmd("drape-out-is-file", ["drape", "sheath-dress", "--out", "{t}/afile"], "--out {t}/afile"),
    cmd("drape-out-under-file", ["drape", "t-shirt", "--out", "{t}/afile/x"],
        "is a file, not a directory"),
    cmd("drape-out-unwritable", ["drape", "t-shirt", "--out", UNWRITABLE], "cannot write"),
    cmd("gallery-out-is-file", ["gallery", "--out", "{t}/afile"], "--out {t}/afile"),
    cmd("cusick-out-is-file", ["validate", "cusick", "--out", "{t}/afile"], "--out {t}/afile"),
    cmd("pattern-out-is-dir", ["pattern", "a-line-skirt", "--out", "{t}/adir"],
        "--out {t}/adir: is a directory"),
    cmd("pattern-out-under-file", ["pattern", "a-line-skirt", "--out", "{t}/afile/p.json"],
        "--out {t}/afile/p.json"),
    cmd("pattern-out-device", ["pattern", "a-line-skirt", "--out", "/dev/null"],
        "--out /dev/null: exists and is not a regular file"),
    cmd("pattern-png-under-file",
        ["pattern", "a-line-skirt", "--out", "{t}/p.json", "--png", "{t}/afile/p.png"],
        "--png {t}/afile/p.png"),
    cmd("pattern-png-suffix",
        ["pattern", "a-line-skirt", "--out", "{t}/p.json", "--png", "{t}/p.jpg"],
        "--png {t}/p.jpg: must end in .png"),
    cmd("mannequin-out-is-file", ["mannequin", "--out", "{t}/afile"], "--out {t}/afile"),
    cmd("mannequin-out-unwritable", ["mannequin", "--out", UNWRITABLE], "cannot write"),
    cmd("garmentcode-out-is-dir", ["import-garmentcode", GC_SPEC, "{t}/adir"],
        "OUTPUT {t}/adir: is a directory"),
    cmd("garmentcode-out-under-file", ["import-garmentcode", GC_SPEC, "{t}/afile/o.json"],
        "OUTPUT {t}/afile/o.json"),
    cmd("gui-out-is-file", [*SCRIPT, "--out", "{t}/afile"], "--out {t}/afile",
        {"s.json": script({"run_frames": 1})}),
    cmd("render-out-is-file", ["render", "{t}/adir", "--out", "{t}/afile"], "--out {t}/afile"),
    cmd("report-out-is-file", ["report", "--tiny", "--out", "{t}/afile"], "--out {t}/afile"),
    # ------------------------------------------------------------ window and image sizes
    cmd("gui-size-zero", [*SCRIPT, "--width", "0", "--height", "0"],
        "--width/--height 0x0: each side must be 64-8192", {"s.json": script({"undo": True})}),
    cmd("gui-size-huge", ["gui", "--width", "100000", "--height", "100000"],
        "--width/--height 100000x100000"),
    cmd("gui-size-negative", ["gui", "--width", "-5"], "--width/--height -5x768"),
    cmd("render-size-zero", ["render", "{t}/adir", "--size", "0", "0"], "--size 0x0"),
    # ------------------------------------------------------------ numeric flags
    cmd("mannequin-resolution-zero", ["mannequin", "--resolution", "0", "--out", "{t}/m"],
        "--resolution 0: must be a multiple of 16"),
    cmd("mannequin-resolution-negative", ["mannequin", "--resolution", "-16", "--out", "{t}/m"],
        "--resolution -16"),
    cmd("drape-edge-zero", ["drape", "t-shirt", "--edge-cm", "0", "--out", "{t}/d"],
        "--edge-cm 0.0"),
    cmd("drape-edge-inf", ["drape", "t-shirt", "--edge-cm", "inf", "--out", "{t}/d"],
        "--edge-cm inf"),
    cmd("gallery-jobs-zero", ["gallery", "--jobs", "0", "--out", "{t}/g"], "--jobs 0"),
    cmd("gui-fps-zero", ["gui", "--fps", "0"], "--fps 0.0"),
    cmd("gui-edge-zero", ["gui", "--edge-cm", "0"], "--edge-cm 0.0"),
    cmd("render-turntable-negative", ["render", "{t}/adir", "--turntable", "-3"],
        "--turntable -3"),
    cmd("cantilever-lambda-negative", ["validate", "cantilever", "--lambdas", "-1"],
        "--lambdas -1.0"),
    # ------------------------------------------------------------ names: fabric, size, body
    cmd("drape-unknown-fabric", ["drape", "t-shirt", "--fabric", "tweedy", "--out", "{t}/d"],
        "--fabric: unknown material preset 'tweedy'"),
    cmd("drape-unknown-size", ["drape", "t-shirt", "--size", "99", "--out", "{t}/d"],
        "--size 99: not in the size database"),
    cmd("drape-bust-out-of-range", ["drape", "t-shirt", "--bust", "500", "--out", "{t}/d"],
        "--bust=500 cm is outside"),
    cmd("drape-pattern-zero-stretch", ["drape", "{t}/p.json", "--out", "{t}/d"],
        "'stretch_u_N_m' must be > 0", {"p.json": "ZERO_STRETCH_PATTERN"}),
    cmd("gallery-unknown-garment", ["gallery", "--only", "cape", "--out", "{t}/g"],
        "--only cape: not a library garment"),
    cmd("gallery-unknown-size", ["gallery", "--size", "7", "--out", "{t}/g"], "--size 7"),
    cmd("cusick-unknown-preset", ["validate", "cusick", "--presets", "tweedy", "--out", "{t}/c"],
        "--presets: unknown material preset"),
    cmd("gui-unknown-fabric", ["gui", "--fabric", "tweedy"], "--fabric: unknown material preset"),
    cmd("gui-unknown-size", ["gui", "--size", "99"], "--size 99"),
    cmd("gui-unknown-garment", ["gui", "cape"], "unknown garment 'cape'"),
    cmd("mannequin-unknown-size", ["mannequin", "--size", "99", "--out", "{t}/m"], "--size 99"),
    cmd("mannequin-missing-body", ["mannequin", "--body", "{t}/none.obj", "--out", "{t}/m"],
        "--body {t}/none.obj: no such body mesh file"),
    # ------------------------------------------------------------ GUI scripts
    cmd("script-missing", ["gui", "--offscreen", "--script", "{t}/none.json"],
        "{t}/none.json: no such script file"),
    cmd("script-not-json", SCRIPT, "{t}/s.json: not valid JSON", {"s.json": "[{"}),
    cmd("script-not-list", SCRIPT, "a script is a JSON list", {"s.json": "{}"}),
    gui("script-frames-text", [{"run_frames": "ten"}],
        "{t}/s.json: action 0: 'run_frames' takes a whole number"),
    gui("script-unknown-measurement", [{"run_frames": 1}, {"set": {"bust": 90}}],
        "action 1: 'set': unknown measurement 'bust'"),
    gui("script-measurement-range", [{"set": {"hip_girth": 1000}}],
        "'set': hip_girth must be a number of cm"),
    gui("script-unknown-size", [{"size": 99}], "'size' 99 is not in the size database"),
    gui("script-unknown-fabric", [{"fabric": "tweedy"}], "'fabric': unknown material preset"),
    gui("script-frame-outside-out", [{"save_frame": "../x.png"}],
        "'save_frame' takes a file name ending in .png"),
    gui("script-two-actions", [{"undo": True, "clear": True}], "one action per object"),
    gui("script-bad-click", [{"click": [2, 0.5]}], "'click' takes [u, v]"),
    gui("script-bad-sew", [{"sew": {"a": [["front", "one"]], "b": []}}], "'sew' takes an object"),
    gui("script-sew-unknown-panel", [{"sew": {"a": [["front", 1]], "b": [["sleeve", 0]]}}],
        "action 0: no panel 'sleeve' in garment 'sheath-dress' (panels: front, back)"),
    gui("script-click-edge-past-the-panel", [{"run_frames": 1}, {"click_edge": ["back", 40]}],
        "action 1: panel 'back' has edges 0..12, not 40"),
    cmd("gui-offscreen-no-script", ["gui", "--offscreen"], "--offscreen needs --script"),
    # ------------------------------------------------------------ scene files
    run("scene-mannequin-nan", mannequin("measurements_cm = { bust_girth = nan }"),
        "{t}/s.toml: collider[0] measurements_cm bust_girth: must be finite"),
    run("scene-mannequin-string", mannequin('measurements_cm = { hip_girth = "100" }'),
        "{t}/s.toml: collider[0] measurements_cm hip_girth: must be a number"),
    run("scene-mannequin-unknown-key", mannequin("measurements_cm = { hips = 100 }"),
        "{t}/s.toml: collider[0] measurements_cm: unknown key 'hips'"),
    run("scene-mannequin-range", mannequin("measurements_cm = { bust_girth = 300 }"),
        "s.toml: collider[0]: measurements: measurements_cm.bust_girth=300 cm is outside"),
    run("scene-mannequin-size", mannequin("size = 99"),
        "{t}/s.toml: collider[0] size: 99 is not in the size database"),
    run("scene-zero-stretch", material('{ preset = "denim", stretch_v_N_m = 0 }'),
        "{t}/s.toml: cloth[0].material: 'stretch_v_N_m' must be > 0"),
    run("scene-zero-shear", material('{ preset = "denim", shear_N_m = 0.0 }'),
        "{t}/s.toml: cloth[0].material: 'shear_N_m' must be > 0"),
    run("scene-negative-stretch", material('{ preset = "denim", stretch_u_N_m = -5 }'),
        "{t}/s.toml: cloth[0].material: 'stretch_u_N_m' must be >= 0"),
    run("scene-pin-negative", scene(pins="{ vertices = [-1] }"),
        "{t}/s.toml: cloth[0].pins[0].vertices: index -1 is negative"),
    run("scene-pin-past-mesh", scene(pins="{ vertices = [100000] }"),
        "{t}/s.toml: cloth[0].pins[0].vertices: index 100000 is out of range"),
    run("scene-pin-region-outside", scene(pins="{ region_m = [[1, 1], [2, 2]] }"),
        "{t}/s.toml: cloth[0].pins[0].region_m: the box lies outside"),
    run("scene-pin-region-inverted", scene(pins="{ region_m = [[0.1, 0], [0, 0.1]] }"),
        "{t}/s.toml: cloth[0].pins[0].region_m: must be [[u_min, v_min]"),
    cmd("scene-missing", ["run", "{t}/none.toml", "--out", "{t}/o"],
        "{t}/none.toml: no such scene file"),
    run("scene-seam-off-outline", seam("from_m = [0.05, 0.05], to_m = [0.05, 0.15]"),
        "{t}/s.toml: seam[0].a[0]: from_m [0.05, 0.05] to_m [0.05, 0.15] does not lie on the "
        "outline of cloth 'sheet'"),
    run("scene-seam-past-corner", seam("from_m = [0.1, 0.0], to_m = [0.3, 0.0]"),
        "{t}/s.toml: seam[0].a[0]: from_m [0.1, 0.0] to_m [0.3, 0.0] does not lie on the "
        "outline of cloth 'sheet' (first point off it: (0.2, 0) m"),
    run("scene-seam-shorter-than-edge", seam("from_m = [0.06, 0.0], to_m = [0.09, 0.0]"),
        "{t}/s.toml: seam[0].a[0]: from_m [0.06, 0.0] to_m [0.09, 0.0] is shorter than the "
        "mesh's spacing along it"),
    run("scene-seam-zero-length", seam("from_m = [0.2, 0.1], to_m = [0.2, 0.1]"),
        "{t}/s.toml: seam[0].a[0]: from_m [0.2, 0.1] to_m [0.2, 0.1] has zero length"),
]  # fmt: skip


class TaichiStarted(AssertionError):
    """Raised by the trap that replaces ``runtime.init`` in these tests."""


@pytest.fixture
def folder(tmp_path, monkeypatch):
    """A test folder with a regular file, a result-like folder and a good scene; Taichi's
    start replaced by a trap."""

    def trap(*args, **kwargs):
        raise TaichiStarted("Taichi started before the bad input was refused")

    monkeypatch.setattr(runtime, "init", trap)
    monkeypatch.setattr(runtime, "ensure_init", trap)
    (tmp_path / "afile").write_text("a regular file\n")
    (tmp_path / "adir" / "metrics.json").mkdir(parents=True)
    (tmp_path / "ok.toml").write_text(scene())
    return tmp_path


def _tree(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


def _zero_stretch_pattern() -> str:
    data = json.loads((DATA / "pattern_skirt.json").read_text())
    data["fabric"] = {"preset": "cotton", "stretch_u_N_m": 0}
    return json.dumps(data)


@pytest.mark.parametrize("argv, files, expected", [c[1:] for c in CASES],
                         ids=[c[0] for c in CASES])  # fmt: skip
def test_bad_input_is_refused_before_taichi(folder, capsys, argv, files, expected):
    for name, text in files.items():
        text = _zero_stretch_pattern() if text == "ZERO_STRETCH_PATTERN" else text
        (folder / name).write_text(text)
    before = _tree(folder)
    capsys.readouterr()
    t0 = time.perf_counter()
    status = main([a.format(t=folder) for a in argv])
    elapsed = time.perf_counter() - t0
    out, err = capsys.readouterr()
    assert status == 2, (out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    assert "Traceback" not in err
    assert expected.format(t=folder) in lines[0], lines[0]
    assert _tree(folder) == before  # nothing written, not even an empty folder
    assert elapsed < 10.0  # first imports included; the checks themselves take milliseconds


def test_the_corpus_covers_every_writing_command():
    commands = {c[1][0] for c in CASES}
    assert len(CASES) >= 40
    assert commands >= {"run", "demo", "drape", "gallery", "validate", "pattern", "mannequin",
                        "import-garmentcode", "gui", "render", "report"}  # fmt: skip


def test_a_child_process_exits_2_without_traceback(tmp_path):
    """The real process: exit status 2 (not a Vulkan abort, 134) and one line."""
    r = subprocess.run([sys.executable, "-m", "sandbox", "gui", "--offscreen", "--width",
                        "100000", "--height", "100000", "--script", "none.json"],
                       capture_output=True, text=True, timeout=120, cwd=tmp_path)  # fmt: skip
    assert r.returncode == 2, r.stderr[-2000:]
    assert "Traceback" not in r.stderr
    assert r.stderr.strip().splitlines()[-1].startswith("error: --width/--height 100000x100000")
    assert list(tmp_path.iterdir()) == []


def test_atomic_writes_name_the_path_instead_of_a_traceback(tmp_path):
    from sandbox.atomic import make_dir, write_text
    from sandbox.errors import SandboxError

    (tmp_path / "afile").write_text("x")
    with pytest.raises(SandboxError, match="afile: exists and is not a directory"):
        make_dir(tmp_path / "afile")
    with pytest.raises(SandboxError, match="afile: exists and is not a directory"):
        write_text(tmp_path / "afile" / "x.txt", "y")
    (tmp_path / "d").mkdir()
    with pytest.raises(SandboxError, match="d: cannot write it"):
        write_text(tmp_path / "d", "y")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile", "d"]
    assert list((tmp_path / "d").iterdir()) == []


def test_good_paths_pass_and_create_nothing(tmp_path):
    from sandbox.preflight import check_output_dir, check_output_file

    check_output_dir(tmp_path / "new" / "deeper")
    check_output_dir(tmp_path)
    check_output_file(tmp_path / "new" / "p.json", suffixes=(".json",))
    assert list(tmp_path.iterdir()) == []


def test_a_mannequin_collider_takes_some_measurements_and_the_rest_from_its_size():
    from sandbox.mannequin.measurements import size_entry
    from sandbox.scene.spec import scene_from_dict

    data = {"cloth": [{"size_m": [0.2, 0.2], "edge_length_m": 0.05, "material": "denim"}],
            "collider": [{"shape": "mannequin", "size": 14,
                          "measurements_cm": {"bust_girth": 96}}]}  # fmt: skip
    params = scene_from_dict(data, source="s.toml").colliders[0].params
    expected = size_entry(14).measurements.replace(bust_girth=96.0).to_dict()
    assert params == {"size": 14, "measurements_cm": expected}


def test_zero_bending_is_still_allowed():
    from sandbox.sim.materials import material_from_spec

    m = material_from_spec({"preset": "denim", "bend_Nm": 0}, where="x")
    assert m.bend_warp_Nm == 0.0 and m.stretch_u_N_m > 0


def test_the_guard_summary_line():
    from sandbox.sim.guard import summary_line

    quiet = {"guard_enabled": True, "dt_s": 1.2e-4, "guard_rollbacks": 0}
    assert summary_line(quiet) == "guard: no rollbacks, dt 0.12 ms throughout"
    fired = {"guard_enabled": True, "dt_s": 1.2e-4, "guard_rollbacks": 3,
             "guard_min_dt_s": 3e-5, "guard_final_dt_s": 6e-5}  # fmt: skip
    assert summary_line(fired) == ("guard: 3 rollbacks, dt 0.12 -> 0.03 ms (smallest), "
                                   "0.06 ms at the end")  # fmt: skip
    assert summary_line({"guard_enabled": False}).startswith("guard: off")
