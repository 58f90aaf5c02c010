"""Valid but implausible scene values load with one warning each, naming the value, the
usual range and the likely unit mistake; the packaged scenes and every fabric of the
library load without one. Seam segments off their cloth's outline are refused when the
scene is read, before Taichi starts; ``check-pattern`` never starts (or prints) Taichi."""

import copy
import json
import logging
import subprocess
import sys
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from sandbox import runtime
from sandbox.cli import main
from sandbox.errors import SandboxError
from sandbox.scene.plausible import PlausibleRanges, material_warnings, scene_warnings
from sandbox.scene.spec import load_scene, scene_from_dict
from sandbox.sim.materials import get_material, list_presets, material_from_spec
from tests.helpers import small_sheet_toml

DATA = Path(__file__).parent / "data"
SCENES = sorted(Path(str(resources.files("sandbox") / "scenes")).glob("*.toml"))

BASE = {
    "scene": {"name": "plausible"},
    "stop": {"time_limit_s": 0.1},
    "cloth": [{"name": "sheet", "size_m": [0.2, 0.2], "edge_length_m": 0.05,
               "material": "denim", "pins": [{"corners": "top"}]}],
}  # fmt: skip


def data(**edits) -> dict:
    """The base scene with ``edits``: ``"section.key"`` (``cloth.key`` for the cloth,
    ``material.key`` for its material table, ``collider`` for a list of colliders)."""
    d = copy.deepcopy(BASE)
    for path, value in edits.items():
        section, _, key = path.partition(".")
        if section == "collider":
            d["collider"] = value
        elif section == "cloth":
            d["cloth"][0][key] = value
        elif section == "material":
            m = d["cloth"][0]["material"]
            m = {"preset": m} if isinstance(m, str) else m
            d["cloth"][0]["material"] = {**m, key: value}
        else:
            d.setdefault(section, {})[key] = value
    return d


def warnings_of(**edits) -> list[str]:
    return scene_warnings(scene_from_dict(data(**edits), source="s.toml"))


# (id, edits, the fragments the one warning must hold: entry, value, usual range, cause)
ODD = [
    ("speed-cm-s", {"cloth.velocity_m_s": [0.0, -50.0, 0.0]},
     ["cloth[0].velocity_m_s", "50 m/s", "above 20 m/s", "cm/s given as m/s (50 cm/s = 0.5"]),
    ("piece-30m", {"cloth.size_m": [30.0, 20.0], "cloth.edge_length_m": 1.0},
     ["cloth[0]: the piece is 30 m across", "above 4 m", "centimetres given as metres"]),
    ("piece-5mm", {"cloth.size_m": [0.005, 0.004], "cloth.edge_length_m": 0.001},
     ["the piece is 0.005 m across", "below 0.01 m"]),
    ("density-g-m2", {"material.density_kg_m2": 220},
     ["cloth[0].material: density_kg_m2 = 220 kg/m²", "above 2 kg/m²", "0.05-0.6",
      "g/m² given as kg/m² (220 g/m² = 0.22 kg/m²)"]),
    ("density-tiny", {"material.density_kg_m2": 0.00022},
     ["density_kg_m2 = 0.00022 kg/m²", "below 0.01 kg/m²", "divided by 1000"]),
    ("stretch-pascal", {"material.stretch_u_N_m": 2e8},
     ["stretch_u_N_m = 2e+08 N/m", "above 50000 N/m", "Young's modulus in Pa"]),
    ("shear-kn-m", {"material.shear_N_m": 0.02},
     ["shear_N_m = 0.02 N/m", "below 0.5 N/m", "kN/m or N/mm given as N/m"]),
    ("bend-micro", {"material.bend_Nm": 24.0},
     ["bend_Nm = 24 N·m", "above 0.001 N·m", "µN·m", "(24 µN·m = 2.4e-05 N·m)"]),
    ("bend-n-mm", {"material.bend_weft_Nm": 0.02},
     ["bend_weft_Nm = 0.02 N·m", "N·mm given as N·m"]),
    ("bend-tiny", {"material.bend_Nm": 1e-9}, ["bend_Nm = 1e-09 N·m", "below 1e-07 N·m"]),
    ("gravity-cm", {"simulation.gravity_m_s2": [0.0, -981.0, 0.0]},
     ["[simulation] |gravity_m_s2| = 981 m/s²", "9.81", "cm/s² given as m/s²"]),
    ("gravity-in-g", {"simulation.gravity_m_s2": [0.0, -1.0, 0.0]},
     ["|gravity_m_s2| = 1 m/s²", "below 2 m/s²", "multiples of g"]),
    ("frame-time", {"simulation.frame_rate_hz": 0.0333},
     ["frame_rate_hz = 0.0333 Hz", "below 1 Hz", "a frame time in s given as a rate"]),
    ("frame-rate-huge", {"simulation.frame_rate_hz": 1e4},
     ["frame_rate_hz = 10000 Hz", "stop rule", "15 m/s"]),
    ("time-limit-ms", {"stop.time_limit_s": 8000.0},
     ["[stop] time_limit_s = 8000 s", "above 300 s", "milliseconds given as seconds"]),
    ("wall-limit-ms", {"stop.wall_limit_s": 3.6e6},
     ["wall_limit_s = 3.6e+06 s", "above 604800 s", "milliseconds given as seconds"]),
    ("min-time-past-limit", {"stop.min_time_s": 1.0},
     ["min_time_s = 1 s is past time_limit_s = 0.1 s", "unconverged"]),
    ("thickness-mm", {"collision.thickness_m": 3.0},
     ["[collision] thickness_m = 3 m", "above 0.02 m", "millimetres given as metres"]),
    ("edge-cm", {"cloth.edge_length_m": 2.0},
     ["cloth[0].edge_length_m = 2 m", "0.2 m", "centimetres given as metres (2 cm"]),
    ("origin-cm", {"cloth.origin_m": [-50.0, 150.0, 0.0]},
     ["cloth[0].origin_m", "158.1 m from the world's origin", "centimetres given as metres"]),
    ("sphere-cm", {"collider": [{"shape": "sphere", "center_m": [0, -0.3, 0],
                                 "radius_m": 30.0}]},
     ["collider[0] radius_m: the sphere's diameter is 60 m", "above 50 m", "centimetres"]),
    ("box-too-thin", {"collider": [{"shape": "box", "center_m": [0, -0.3, 0],
                                    "size_m": [0.5, 2e-4, 0.5]}]},
     ["collider[0] size_m: the box's smallest side is 0.0002 m", "below 0.001 m"]),
]  # fmt: skip


@pytest.mark.parametrize("edits, fragments", [c[1:] for c in ODD], ids=[c[0] for c in ODD])
def test_an_odd_value_gives_one_warning_with_value_range_and_cause(edits, fragments):
    messages = warnings_of(**edits)
    assert len(messages) == 1, messages
    assert messages[0].startswith("s.toml: ")
    for text in fragments:
        assert text in messages[0], (text, messages[0])


@pytest.mark.parametrize("edits", [
    {"simulation.gravity_m_s2": [0.0, 0.0, 0.0]},  # no gravity: a choice
    {"material.bend_Nm": 0.0},  # no bending: a choice
    {"simulation.gravity_m_s2": [0.0, -3.71, 0.0]},  # Mars
    {"cloth.velocity_m_s": [0.0, -6.0, 0.0]},  # dropped from 2 m
    {"cloth.size_m": [1.5, 3.0], "cloth.edge_length_m": 0.05},  # a large sheet
    {"material.density_kg_m2": 0.015},  # tulle
    {"collider": [{"shape": "mannequin", "size": 16}]},
    {"collider": [{"shape": "plane"}]},  # the default 10 m floor
], ids=["no-gravity", "no-bending", "mars", "dropped", "bedsheet", "tulle", "mannequin",
        "floor"])  # fmt: skip
def test_deliberate_or_unusual_but_sane_values_give_no_warning(edits):
    assert warnings_of(**edits) == []


def test_every_packaged_scene_loads_without_a_warning(caplog):
    assert len(SCENES) >= 5
    with caplog.at_level(logging.WARNING, logger="sandbox.scene"):
        for path in SCENES:
            spec = load_scene(path)
            assert scene_warnings(spec) == [], path
    assert not caplog.records, [r.getMessage() for r in caplog.records]


def test_every_preset_and_library_fabric_is_plausible():
    from sandbox.drafting.garments import garment_names, load_garment

    for name in list_presets():
        assert material_warnings(get_material(name), name) == [], name
    for name in garment_names():
        fabric = load_garment(name).fabric
        assert material_warnings(material_from_spec(fabric, where=name), name) == [], name


def test_a_scene_file_logs_its_warnings_when_read(tmp_path, caplog):
    path = tmp_path / "odd.toml"
    path.write_text(small_sheet_toml('{ preset = "denim", density_kg_m2 = 300 }',
                                     cloth_extra="velocity_m_s = [0.0, 0.0, 80.0]"))  # fmt: skip
    with caplog.at_level(logging.WARNING, logger="sandbox.scene"):
        load_scene(path)
    got = [(r.name, r.levelno, r.getMessage()) for r in caplog.records]
    assert [(n, lv) for n, lv, _ in got] == [("sandbox.scene", logging.WARNING)] * 2, got
    assert "80 m/s" in got[0][2] and "cm/s given as m/s" in got[0][2]
    assert "300 kg/m²" in got[1][2] and "g/m² given as kg/m²" in got[1][2]
    assert all(m.startswith(f"{path}: cloth[0]") for _, _, m in got)


def test_own_ranges_let_a_value_through_and_bad_ranges_are_refused():
    spec = scene_from_dict(data(**{"cloth.velocity_m_s": [0.0, 0.0, 50.0]}), source="s.toml")
    assert len(scene_warnings(spec)) == 1
    assert scene_warnings(spec, PlausibleRanges(max_speed_m_s=100.0)) == []
    with pytest.raises(ValueError, match="max_speed_m_s must be a positive number"):
        PlausibleRanges(max_speed_m_s=0.0)
    with pytest.raises(ValueError, match="min_density_kg_m2 must be below max_density_kg_m2"):
        PlausibleRanges(min_density_kg_m2=3.0)


def test_a_mesh_collider_in_centimetres_is_named_with_the_scale_to_use(tmp_path):
    corners = 170.0 * np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)])
    faces = [(1, 2, 4), (2, 3, 4), (5, 8, 6), (5, 7, 8), (1, 5, 2), (2, 5, 6), (3, 4, 8),
             (3, 8, 7), (1, 3, 5), (3, 7, 5), (2, 6, 4), (4, 6, 8)]  # fmt: skip
    lines = [f"v {x} {y} {z}" for x, y, z in corners] + [f"f {a} {b} {c}" for a, b, c in faces]
    (tmp_path / "body.obj").write_text("\n".join(lines) + "\n")
    collider = [{"shape": "mesh", "path": str(tmp_path / "body.obj")}]
    messages = warnings_of(collider=collider)
    assert len(messages) == 1, messages
    assert "the mesh's largest side is 170 m" in messages[0]
    assert "a model in centimetres (try scale = 0.01)" in messages[0]
    assert warnings_of(collider=[{**collider[0], "scale": 0.01}]) == []


# ---------------------------------------------------------------------------- CLI
@pytest.fixture
def trapped(monkeypatch):
    """Taichi's start replaced by a trap: what happens before it can be seen."""

    class TaichiStarted(Exception):
        pass

    def trap(*args, **kwargs):
        raise TaichiStarted

    monkeypatch.setattr(runtime, "init", trap)
    monkeypatch.setattr(runtime, "ensure_init", trap)
    return TaichiStarted


def test_run_warns_before_taichi_starts(tmp_path, caplog, trapped):
    path = tmp_path / "s.toml"
    path.write_text(small_sheet_toml(cloth_extra="velocity_m_s = [0.0, -50.0, 0.0]"))
    with caplog.at_level(logging.WARNING, logger="sandbox.scene"):
        with pytest.raises(trapped):
            main(["run", str(path), "--out", str(tmp_path / "o"), "--quiet"])
    messages = [r.getMessage() for r in caplog.records if r.name == "sandbox.scene"]
    assert len(messages) == 1 and "50 m/s" in messages[0] and "cm/s" in messages[0], messages
    assert not (tmp_path / "o").exists()


def test_drape_warns_about_a_pattern_files_fabric_before_taichi_starts(tmp_path, caplog,
                                                                       trapped):  # fmt: skip
    pattern = json.loads((DATA / "pattern_skirt.json").read_text())
    pattern["fabric"] = {"preset": "cotton", "density_kg_m2": 180}
    (tmp_path / "p.json").write_text(json.dumps(pattern))
    with caplog.at_level(logging.WARNING, logger="sandbox.pattern"):
        with pytest.raises(trapped):
            main(["drape", str(tmp_path / "p.json"), "--out", str(tmp_path / "o"), "--quiet"])
    messages = [r.getMessage() for r in caplog.records if r.name == "sandbox.pattern"]
    assert len(messages) == 1, messages
    assert messages[0].startswith(f"{tmp_path / 'p.json'}: fabric: density_kg_m2 = 180 kg/m²")
    assert "(180 g/m² = 0.18 kg/m²)" in messages[0]


def test_check_pattern_does_not_start_taichi():
    r = subprocess.run([sys.executable, "-m", "sandbox", "check-pattern",
                        str(DATA / "pattern_skirt.json")],
                       capture_output=True, text=True, timeout=300)  # fmt: skip
    assert r.returncode == 0, r.stderr[-2000:]
    assert "panel front" in r.stdout
    assert "[Taichi]" not in r.stdout + r.stderr


# ---------------------------------------------------------------------------- seams
def seam_scene(a: dict, *, mesher="irregular", edge=0.05, lines=None) -> dict:
    """Two 40 x 30 cm sheets, side ``a`` on the first sewn to the second's edge 0."""
    sheet = {"name": "front", "size_m": [0.4, 0.3], "edge_length_m": edge, "material": "denim",
             "mesher": mesher}  # fmt: skip
    if lines:
        sheet["mesh_lines_m"] = lines
    back = {"name": "back", "size_m": [0.4, 0.3], "edge_length_m": 0.05, "material": "denim",
            "origin_m": [0.0, 0.0, 0.1]}  # fmt: skip
    seam = {"name": "side", "a": [{"cloth": "front", **a}], "b": [{"cloth": "back", "edge": 0}]}
    return {"cloth": [sheet, back], "seam": [seam]}


@pytest.mark.parametrize("a, expected", [
    ({"from_m": [0.1, 0.05], "to_m": [0.1, 0.2]},
     "seam[0].a[0]: from_m [0.1, 0.05] to_m [0.1, 0.2] does not lie on the outline of cloth "
     "'front' (first point off it: (0.1, 0.05) m; the outline spans u 0..0.4 m, v 0..0.3 m)"),
    ({"from_m": [0.2, 0.0], "to_m": [0.6, 0.0]},
     "does not lie on the outline of cloth 'front' (first point off it: (0.4, 0) m"),
    ({"from_m": [10.0, 0.0], "to_m": [30.0, 0.0]}, "(first point off it: (10, 0) m"),
    ({"from_m": [0.1, 0.0], "to_m": [0.12, 0.0]},
     "to_m [0.12, 0.0] is shorter than the mesh's spacing along it: 1 mesh vertex lies on it"),
    ({"from_m": [0.4, 0.1], "to_m": [0.4, 0.1]}, "to_m [0.4, 0.1] has zero length"),
], ids=["inside", "past-a-corner", "centimetres", "shorter-than-an-edge",
        "zero-length"])  # fmt: skip
def test_a_seam_segment_off_its_outline_is_refused_when_read(a, expected):
    with pytest.raises(SandboxError) as err:
        scene_from_dict(seam_scene(a), source="s.toml")
    assert str(err.value).startswith("s.toml: seam[0].a[0]: ")
    assert expected in str(err.value)


def test_seam_segments_on_the_outline_or_a_mesh_line_pass():
    for a in ({"from_m": [0.0, 0.0], "to_m": [0.4, 0.0]},  # a whole side
              {"from_m": [0.4, 0.3], "to_m": [0.1, 0.3]},  # part of one, backwards
              {"from_m": [0.1, 0.0], "to_m": [0.16, 0.0]}):  # fmt: skip
        scene_from_dict(seam_scene(a), source="s.toml")
    line = [[[0.1, 0.0], [0.1, 0.3]]]
    scene_from_dict(seam_scene({"from_m": [0.1, 0.05], "to_m": [0.1, 0.2]}, lines=line))
    with pytest.raises(SandboxError, match="does not lie on the outline of cloth 'front'"):
        scene_from_dict(seam_scene({"from_m": [0.1, 0.05], "to_m": [0.1, 0.2]}, mesher="grid"))


def test_an_outline_edge_of_zero_length_is_refused():
    d = seam_scene({"edge": 1})
    del d["cloth"][0]["size_m"]
    d["cloth"][0].update(shape="polygon",
                         outline_m=[[0, 0], [0.4, 0], [0.4, 0], [0.4, 0.3], [0, 0.3]])  # fmt: skip
    with pytest.raises(SandboxError, match=r"seam\[0\]\.a\[0\] edge: 1 has zero length"):
        scene_from_dict(d, source="s.toml")


@pytest.mark.parametrize("mesher", ["irregular", "grid"])
def test_a_seam_segment_that_passes_has_two_mesh_vertices_on_the_built_mesh(mesher):
    """What passes when the scene is read passes the builder (sandbox.sim.seams.edge_vertices
    on the real mesh), for random segments along, past and beside the sides."""
    from sandbox.pattern.mesh2d import mesh_grid, mesh_polygon
    from sandbox.scene.spec import _seam_segment_problem
    from sandbox.sim.seams import edge_vertices

    rng = np.random.default_rng(7)
    passed = refused = 0
    for edge in (0.013, 0.03, 0.07):
        c = scene_from_dict(seam_scene({"edge": 0}, mesher=mesher, edge=edge)).cloths[0]
        o = np.asarray(c.outline_m)
        uv = mesh_grid(0.4, 0.3, edge)[0] if mesher == "grid" else mesh_polygon(o, edge)[0]
        for _ in range(150):
            k = rng.integers(4)
            t0, t1 = np.sort(rng.choice([0.0, 0.25, 0.5, 1.0, *rng.uniform(-0.1, 1.1, 2)], 2))
            a, b = o[k] + (o[(k + 1) % 4] - o[k]) * np.array([[t0], [t1]])
            a, b = tuple(map(float, a)), tuple(map(float, b))
            if _seam_segment_problem(c, a, b) is None:
                assert len(edge_vertices(uv, a, b, where="seam")) >= 2
                passed += 1
            else:
                refused += 1
    assert passed > 100 and refused > 50
