"""Pattern files: loading and validation, curves, panel meshes, seams, GarmentCode import."""

import copy
import json
import math
from pathlib import Path

import jsonschema
import numpy as np
import pytest
from scipy.spatial import cKDTree

from sandbox.errors import SandboxError
from sandbox.pattern import curves
from sandbox.pattern.garmentcode import garmentcode_to_dict, load_garmentcode, main
from sandbox.pattern.mesh2d import min_angle_deg
from sandbox.pattern.panel_mesh import main as check_main
from sandbox.pattern.panel_mesh import mesh_panel, mesh_pattern, pattern_seam_sides
from sandbox.pattern.reader import pattern_schema
from sandbox.pattern.spec import load_pattern, rotation_matrix_xyz_deg, save_pattern

DATA = Path(__file__).parent / "data"
SKIRT = DATA / "pattern_skirt.json"
GC_SKIRT = DATA / "garmentcode_skirt_specification.json"


def skirt_dict() -> dict:
    return json.loads(SKIRT.read_text())


# --------------------------------------------------------------------------------------
# Loading and validation


def test_load_good_file():
    p = load_pattern(SKIRT)
    assert p.name == "two-panel-skirt"
    assert p.units_to_m == 0.01
    assert p.mesh_edge_m == pytest.approx(0.02)
    assert p.fabric == "cotton"
    front = p.panels["front"]
    np.testing.assert_allclose(front.vertices_m[2], [0.18, 0.60])
    assert [e.name for e in front.edges] == ["hem", "side_left", "waist", "side_right"]
    assert [e.kind for e in front.edges] == ["arc", "quadratic", "arc", "quadratic"]
    assert front.edges[0].sagitta_m == pytest.approx(-0.02)
    np.testing.assert_allclose(front.edges[1].controls_m, [[0.25, 0.40]])
    np.testing.assert_allclose(front.grain, [0, 1])
    assert front.grain_rad == pytest.approx(math.pi / 2)
    # placement: raw in file units, and in metres
    assert front.placement["anchor"] == [0, 60]
    pm = front.placement_m
    np.testing.assert_allclose(pm["anchor_m"], [0, 0.6])
    assert pm["clearance_m"] == pytest.approx(0.02) and pm["landmark"] == "waist_front"
    assert p.seams[0].side_a == [("front", 1)] and p.seams[0].side_b == [("back", 3)]
    assert p.seams[1].side_b == [("back", 1)]  # referenced by index
    assert p.seams[0].direction == "auto" and p.seams[0].stiffness_N_m is None


def _bad(mutate):
    d = skirt_dict()
    mutate(d)
    return d


def _set(path, value):
    def f(d):
        t = d
        for k in path[:-1]:
            t = t[k]
        t[path[-1]] = value

    return f


def _front_edges(d):
    return d["panels"]["front"]["edges"]


BAD_CASES = {
    "unknown top key": (_set(["colour"], "red"), "top level: unknown key 'colour'"),
    "unknown panel key": (
        _set(["panels", "front", "vertexes"], []),
        "panel 'front': unknown key 'vertexes'",
    ),
    "unknown edge key": (
        lambda d: _front_edges(d)[2].update(bend=1),
        "panel 'front': edge 'waist' (#2): unknown key 'bend'",
    ),
    "loop not closed": (
        lambda d: _front_edges(d)[3].update(to=2),
        "panel 'front': edge 'side_right' (#3) ends at vertex 2 but the next edge 'hem' (#0) "
        "starts at vertex 0: the edge loop does not close",
    ),
    "not consecutive": (
        lambda d: _front_edges(d).insert(1, _front_edges(d).pop(2)),
        "panel 'front': edge 'hem' (#0) ends at vertex 1 but the next edge 'waist' (#1) starts "
        "at vertex 2: the edge loop is not consecutive",
    ),
    "vertex out of range": (
        lambda d: _front_edges(d)[1].update(to=7),
        "panel 'front': edge 'side_left' (#1): 'to' = 7 is out of range; the panel has 4 vertices",
    ),
    "unknown edge in seam": (
        lambda d: d["seams"][0]["b"][0].update(edge="side_l"),
        "seam #0: b[0]: panel 'back' has no edge named 'side_l'",
    ),
    "edge index out of range in seam": (
        lambda d: d["seams"][0]["b"][0].update(edge=9),
        "seam #0: b[0]: panel 'back' has no edge number 9",
    ),
    "unknown panel in seam": (
        lambda d: d["seams"][0]["a"][0].update(panel="sleeve"),
        "seam #0: a[0]: unknown panel 'sleeve'",
    ),
    "edge sewn twice": (
        lambda d: d["seams"][1]["b"].append({"panel": "back", "edge": "side_left"}),
        "seam #1: panel 'back': edge 'side_left' (#3) is sewn twice (also in seam #0)",
    ),
    "self-intersecting": (
        _set(["panels", "front", "vertices"], [[-30, 0], [30, 0], [-18, 60], [18, 60]]),
        "panel 'front': edge 'side_left' (#1) crosses edge 'side_right' (#3) at (0, 49.56) cm: "
        "self-intersecting outline",
    ),
    "curve crossing another edge": (
        lambda d: _front_edges(d)[2].update(curve={"type": "arc", "sagitta": 70}),
        "self-intersecting outline",
    ),
    "zero-length edge": (
        _set(["panels", "front", "vertices"], [[-30, 0], [30, 0], [30, 0], [-18, 60]]),
        "panel 'front': edge 'side_left' (#1): zero-length edge",
    ),
    "bad sagitta": (
        lambda d: _front_edges(d)[0].update(curve={"type": "arc", "sagitta": "deep"}),
        "panel 'front': edge 'hem' (#0): arc 'sagitta' must be a finite number",
    ),
    "bad control point": (
        lambda d: _front_edges(d)[1].update(curve={"type": "quadratic", "control": [1, 2, 3]}),
        "panel 'front': edge 'side_left' (#1): quadratic 'control' must be a list of 2",
    ),
    "missing control": (
        lambda d: _front_edges(d)[1].update(curve={"type": "cubic", "control": [1, 2]}),
        "panel 'front': edge 'side_left' (#1): cubic curve: unknown key 'control'",
    ),
    "unknown curve type": (
        lambda d: _front_edges(d)[1].update(curve={"type": "spline"}),
        "panel 'front': edge 'side_left' (#1): unknown curve type 'spline'",
    ),
    "unknown units": (_set(["units"], "inch"), "unknown units 'inch'; use one of cm, mm, m"),
    "clockwise": (
        lambda d: d["panels"].update(
            front={
                "vertices": [[0, 0], [0, 10], [10, 10], [10, 0]],
                "edges": [{"from": i, "to": (i + 1) % 4} for i in range(4)],
            }  # fmt: skip
        ),
        "panel 'front': the outline runs clockwise",
    ),
    "duplicate edge names": (
        lambda d: _front_edges(d)[2].update(name="hem"),
        "panel 'front': edge name 'hem' is used by more than one edge",
    ),
    "unknown fabric": (_set(["fabric"], "tweed"), "fabric: unknown material preset 'tweed'"),
    "wrong format": (_set(["format"], "pattern/2"), "'format' must be 'sandbox-pattern/1'"),
    "unknown landmark": (
        lambda d: d["panels"]["front"]["placement"].update(landmark="belly_button"),
        "panel 'front': placement: unknown landmark 'belly_button'",
    ),
    "zero grain": (_set(["panels", "back", "grain"], [0, 0]), "panel 'back': 'grain' must be"),
    "bad direction": (
        lambda d: d["seams"][0].update(direction="backwards"),
        "seam #0: 'direction' must be auto, same or reverse",
    ),
    "mixed placement": (
        lambda d: d["panels"]["back"]["placement"].update(translation=[0, 0, 0]),
        "panel 'back': placement (explicit form): unknown keys",
    ),
}


@pytest.mark.parametrize("case", list(BAD_CASES))
def test_bad_input_messages(case):
    mutate, expected = BAD_CASES[case]
    with pytest.raises(SandboxError) as info:
        load_pattern(_bad(mutate), where="skirt.json")
    msg = str(info.value)
    assert msg.startswith("skirt.json: "), msg
    assert expected in msg, msg


def _scaled(d, f):
    """The skirt with every length multiplied by f."""
    d = copy.deepcopy(d)
    d["mesh_edge"] *= f
    for p in d["panels"].values():
        p["vertices"] = [[x * f, y * f] for x, y in p["vertices"]]
        for e in p["edges"]:
            c = e.get("curve", {})
            if "sagitta" in c:
                c["sagitta"] *= f
            if "control" in c:
                c["control"] = [v * f for v in c["control"]]
        pl = p["placement"]
        pl["anchor"] = [v * f for v in pl["anchor"]]
        if "clearance" in pl:
            pl["clearance"] *= f
    return d


@pytest.mark.parametrize("units, f", [("mm", 10.0), ("m", 0.01)])
def test_units(units, f):
    ref = load_pattern(SKIRT)
    d = _scaled(skirt_dict(), f)
    d["units"] = units
    p = load_pattern(d)
    assert p.mesh_edge_m == pytest.approx(ref.mesh_edge_m)
    for name, panel in p.panels.items():
        r = ref.panels[name]
        np.testing.assert_allclose(panel.vertices_m, r.vertices_m, rtol=1e-12)
        for e, g in zip(panel.edges, r.edges, strict=True):
            assert e.length_m == pytest.approx(g.length_m, rel=1e-12)
        np.testing.assert_allclose(panel.placement_m["anchor_m"], r.placement_m["anchor_m"])
        assert panel.placement_m["clearance_m"] == pytest.approx(0.02)
        assert panel.placement["anchor"] == d["panels"][name]["placement"]["anchor"]  # raw


def test_two_vertex_panel_with_arcs_and_degenerate_ones():
    lens = {"format": "sandbox-pattern/1", "panels": {"lens": {"vertices": [[0, 0], [20, 0]],
            "edges": [{"from": 0, "to": 1, "curve": {"type": "arc", "sagitta": -5}},
                      {"from": 1, "to": 0, "curve": {"type": "arc", "sagitta": -5}}]}}}  # fmt: skip
    m = mesh_panel(load_pattern(lens).panels["lens"], 0.01)
    assert min_angle_deg(m.points, m.triangles) >= 25.0
    flat = copy.deepcopy(lens)
    for e in flat["panels"]["lens"]["edges"]:
        del e["curve"]
    with pytest.raises(SandboxError, match="panel 'lens': the outline has zero area"):
        load_pattern(flat)


def test_bad_files(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"format": "sandbox-pattern/1",\n "panels": {,}}')
    with pytest.raises(SandboxError, match=r"bad.json: not valid JSON \(line 2"):
        load_pattern(bad)
    with pytest.raises(SandboxError, match="missing.json: cannot read"):
        load_pattern(tmp_path / "missing.json")
    with pytest.raises(SandboxError, match="looks like a GarmentCode specification"):
        load_pattern(GC_SKIRT)


def test_save_round_trip(tmp_path):
    p = load_pattern(SKIRT)
    out = save_pattern(p, tmp_path / "skirt.json")
    q = load_pattern(out)
    assert q.to_dict() == p.to_dict()
    for name in p.panels:
        np.testing.assert_allclose(q.panels[name].vertices_m, p.panels[name].vertices_m, atol=1e-15)
        for e, f in zip(p.panels[name].edges, q.panels[name].edges, strict=True):
            assert (e.name, e.start, e.end, e.kind) == (f.name, f.start, f.end, f.kind)
            assert e.sagitta_m == pytest.approx(f.sagitta_m, abs=1e-15)
            np.testing.assert_allclose(e.controls_m, f.controls_m, atol=1e-15)
    assert q.seams == p.seams
    # the file text keeps points on one line
    assert "[-30, 0]" in out.read_text()
    # an edited pattern (as a GUI would) is written back
    p.panels["front"].edges[0].sagitta_m = -0.03
    r = load_pattern(save_pattern(p, tmp_path / "edited.json"))
    assert r.panels["front"].edges[0].sagitta_m == pytest.approx(-0.03)
    # a dict is validated before anything is written
    bad = skirt_dict()
    bad["units"] = "inch"
    with pytest.raises(SandboxError, match="unknown units"):
        save_pattern(bad, tmp_path / "bad.json")
    assert not (tmp_path / "bad.json").exists()


# --------------------------------------------------------------------------------------
# JSON Schema


def test_schema_accepts_good_files_and_rejects_bad_ones(tmp_path):
    schema = pattern_schema()
    jsonschema.Draft202012Validator.check_schema(schema)
    v = jsonschema.Draft202012Validator(schema)
    v.validate(skirt_dict())
    v.validate(load_pattern(SKIRT).to_dict())
    v.validate(load_garmentcode(GC_SKIRT).to_dict())
    for mutate in (
        _set(["colour"], "red"),
        lambda d: _front_edges(d)[1].update(curve={"type": "cubic", "control": [1, 2]}),
        lambda d: _front_edges(d)[0].update(curve={"type": "arc"}),
        _set(["units"], "inch"),
        lambda d: d["seams"][0].update(direction="backwards"),
        lambda d: d["panels"]["front"]["placement"].update(body="head"),
    ):
        assert not v.is_valid(_bad(mutate))


# --------------------------------------------------------------------------------------
# Curves


def test_arc_length_is_r_theta():
    for chord, sag in ((2.0, 1.0), (0.3, 0.02), (0.3, -0.5), (1.0, 0.9)):
        r = (chord**2 / 4 + sag**2) / (2 * abs(sag))
        half = math.asin(min(1.0, chord / (2 * r)))
        theta = 2 * half if abs(sag) <= chord / 2 else 2 * math.pi - 2 * half
        length = curves.curve_length("arc", [0, 0], [chord, 0], sagitta=sag)
        assert length == pytest.approx(r * theta, rel=1e-12)
        pts = curves.sample_curve("arc", [0, 0], [chord, 0], 0.01, sagitta=sag)
        centre = np.array([chord / 2, sag - math.copysign(r, sag)])
        np.testing.assert_allclose(np.linalg.norm(pts - centre, axis=1), r, rtol=1e-12)
        # the midpoint of the arc is the sagitta above the chord's midpoint (left = +y)
        if len(pts) % 2 == 1:
            np.testing.assert_allclose(pts[len(pts) // 2], [chord / 2, sag], atol=1e-12)
    assert curves.curve_length("arc", [0, 0], [1, 0], sagitta=0.0) == 1.0


@pytest.mark.parametrize(
    "kind, controls",
    [
        ("quadratic", [[0.5, 0.4]]),
        ("cubic", [[0.1, 0.5], [0.9, -0.3]]),
        ("cubic", [[1.2, 0.6], [-0.2, 0.6]]),
    ],  # fmt: skip
)
def test_bezier_length_and_even_spacing(kind, controls):
    p0, p1 = np.array([0.0, 0.0]), np.array([1.0, 0.0])
    nodes = np.vstack([p0, controls, p1])
    dense = curves.bezier_point(nodes, np.linspace(0, 1, 400001))
    ref = np.linalg.norm(np.diff(dense, axis=0), axis=1).sum()
    length = curves.curve_length(kind, p0, p1, controls=controls)
    assert length == pytest.approx(ref, rel=1e-8)
    h = 0.013
    pts = curves.sample_curve(kind, p0, p1, h, controls=controls)
    assert len(pts) - 1 == math.ceil(length / h)
    np.testing.assert_array_equal(pts[0], p0)
    np.testing.assert_array_equal(pts[-1], p1)
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    assert seg.max() <= h
    # evenly spaced by arc length: the dense arc length between samples is L / k
    s_dense = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(dense, axis=0), axis=1))])
    nearest = cKDTree(dense).query(pts)[1]
    np.testing.assert_allclose(np.diff(s_dense[nearest]), length / (len(pts) - 1), atol=2e-5)


# --------------------------------------------------------------------------------------
# Panel meshes


def _boundary_edges(tris):
    e = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    uniq, count = np.unique(e, axis=0, return_counts=True)
    return {tuple(x) for x in uniq[count == 1]}


@pytest.mark.parametrize("h", [0.01, 0.02])
def test_panel_mesh_quality_and_edges(h):
    p = load_pattern(SKIRT)
    panel = p.panels["front"]
    m = mesh_panel(panel, h)
    assert min_angle_deg(m.points, m.triangles) >= 25.0
    # counter-clockwise triangles
    q = m.points[m.triangles]
    cross = (q[:, 1, 0] - q[:, 0, 0]) * (q[:, 2, 1] - q[:, 0, 1]) - (q[:, 1, 1] - q[:, 0, 1]) * (
        q[:, 2, 0] - q[:, 0, 0]
    )
    assert np.all(cross > 0)
    # every edge's vertices are exactly its arc-length samples, in order
    for e, idx in zip(panel.edges, m.edge_vertices, strict=True):
        np.testing.assert_array_equal(m.points[idx], e.sample(h))
    # corners are shared by neighbouring edges
    for k, idx in enumerate(m.edge_vertices):
        assert idx[-1] == m.edge_vertices[(k + 1) % len(m.edge_vertices)][0]
    # the edges cover the whole boundary of the mesh and nothing else
    along = set()
    for idx in m.edge_vertices:
        along |= {tuple(sorted(x)) for x in zip(idx[:-1], idx[1:], strict=True)}
    assert along == _boundary_edges(m.triangles)
    # mean edge length near the target
    ed = np.linalg.norm(np.diff(m.points[m.triangles[:, [0, 1, 2, 0]]], axis=1), axis=2)
    assert 0.7 * h < ed.mean() < 1.2 * h
    assert m.grain_rad == pytest.approx(math.pi / 2)


def _point_to_polyline(q, poly):
    a, b = poly[:-1], poly[1:]
    t = np.clip(np.sum((q - a) * (b - a), axis=1) / np.sum((b - a) ** 2, axis=1), 0, 1)
    return float(np.min(np.linalg.norm(a + t[:, None] * (b - a) - q, axis=1)))


def _tiny_edge_panel(tiny_cm: float):
    """A panel with an edge ``tiny_cm`` long (#3) between 20 cm edges, and a cubic hem."""
    d = {
        "format": "sandbox-pattern/1",
        "panels": {
            "p": {
                "vertices": [[0, 0], [40, 0], [40, 50], [20 + tiny_cm, 50], [20, 50], [0, 50]],
                "edges": [{"name": "hem", "from": 0, "to": 1,
                           "curve": {"type": "cubic", "controls": [[10, -5], [30, -5]]}}]
                + [{"from": i, "to": (i + 1) % 6} for i in range(1, 6)],
            }
        },
    }  # fmt: skip
    return load_pattern(d).panels["p"]


def test_panel_mesh_grades_towards_tiny_edges():
    # a 5 mm edge (GarmentCode patterns have such), a quarter of the mesh edge
    panel = _tiny_edge_panel(0.5)
    h = 0.02
    m = mesh_panel(panel, h)
    assert min_angle_deg(m.points, m.triangles) >= 25.0
    assert len(m.edge_vertices[3]) == 2  # the tiny edge: its two corners, nothing inside
    for e, idx in zip(panel.edges, m.edge_vertices, strict=True):
        q = m.points[idx]
        dense = e.sample(h / 50)
        assert max(_point_to_polyline(x, dense) for x in q) < 1e-6  # on the edge
        s = [int(np.argmin(np.linalg.norm(dense - x, axis=1))) for x in q]
        assert np.all(np.diff(s) > 0)  # in order from start to end
        seg = np.linalg.norm(np.diff(q, axis=0), axis=1)
        assert seg.max() <= h * (1 + 1e-6)
    # next to the tiny edge the segments grow gradually (at most ~20 % + rounding)
    seg = np.linalg.norm(np.diff(m.points[m.edge_vertices[2]], axis=0), axis=1)
    assert seg[-1] < 0.0065 and np.all(seg[:-1] / seg[1:] < 1.35)
    along = set()
    for idx in m.edge_vertices:
        along |= {tuple(sorted(x)) for x in zip(idx[:-1], idx[1:], strict=True)}
    assert along == _boundary_edges(m.triangles)


def test_panel_mesh_collapses_edges_far_shorter_than_the_mesh():
    # a 1 mm edge at a 2 cm mesh: one vertex, no fan of millimetre triangles round it
    panel = _tiny_edge_panel(0.1)
    h = 0.02
    m = mesh_panel(panel, h)
    tiny = m.edge_vertices[3]
    assert len(tiny) == 2 and tiny[0] == tiny[1]  # both corners are one vertex
    assert np.allclose(m.points[tiny[0]], [0.2005, 0.5])  # at the edge's middle
    assert m.edge_vertices[2][-1] == tiny[0] and m.edge_vertices[4][0] == tiny[0]
    assert min_angle_deg(m.points, m.triangles) >= 25.0
    seg = np.linalg.norm(np.diff(m.points[m.edge_vertices[2]], axis=0), axis=1)
    assert seg.min() > 0.25 * h  # its neighbours are not graded towards it
    along = set()
    for idx in m.edge_vertices:
        along |= {tuple(sorted(x)) for x in zip(idx[:-1], idx[1:], strict=True) if x[0] != x[1]}
    assert along == _boundary_edges(m.triangles)
    assert len(mesh_panel(panel, 0.004).edge_vertices[3]) == 2  # resolved on a fine mesh
    assert (
        mesh_panel(panel, 0.004).edge_vertices[3][0] != mesh_panel(panel, 0.004).edge_vertices[3][1]
    )


def test_seam_sides_build_springs():
    from sandbox.sim.builder import ModelBuilder
    from sandbox.sim.materials import material_from_spec

    p = load_pattern(SKIRT)
    meshes = mesh_pattern(p, 0.05)
    b = ModelBuilder()
    mat = material_from_spec(p.fabric, where="test")
    index = {}
    for name, m in meshes.items():  # front at z = +0.1, back turned to face -z at z = -0.1
        rot = np.eye(3) if name == "front" else rotation_matrix_xyz_deg([0, 180, 0])
        z = 0.1 if name == "front" else -0.1
        index[name] = b.add_cloth(name=name, pattern_uv=m.points, triangles=m.triangles,
                                  material=mat, rotation=rot, translation=(0, 0, z),
                                  grain_rad=m.grain_rad)  # fmt: skip
    sides = pattern_seam_sides(p, meshes, index)
    assert len(sides) == 2
    for s in sides:
        assert s["side_a"][0][0] == index["front"] and s["side_b"][0][0] == index["back"]
        b.add_seam(**s)
    model = b.finalize()
    assert model.seam_count > 0
    pairs = model.seam_pairs_np
    x = model.initial_positions_np
    gap = x[pairs[:, 0]] - x[pairs[:, 1]]
    # the sewn points face each other across the 20 cm gap (same side, same height)
    np.testing.assert_allclose(np.abs(gap[:, 2]), 0.2, atol=1e-12)
    assert np.abs(gap[:, :2]).max() < 0.03


def test_seam_side_chains_consecutive_edges():
    d = skirt_dict()
    d["seams"] = [
        {"a": [{"panel": "front", "edge": "waist"}, {"panel": "front", "edge": "side_left"}],
         "b": [{"panel": "back", "edge": "waist"}, {"panel": "back", "edge": "side_right"}]}
    ]  # fmt: skip
    p = load_pattern(d)
    meshes = mesh_pattern(p, 0.05)
    (s,) = pattern_seam_sides(p, meshes, {"front": 0, "back": 1})
    for side in (s["side_a"], s["side_b"]):
        (_, first), (_, second) = side
        assert first[-1] == second[0]  # one continuous line through the shared corner


# --------------------------------------------------------------------------------------
# GarmentCode import


def test_garmentcode_units_placement_and_curves():
    spec = json.loads(GC_SKIRT.read_text())
    p = load_garmentcode(GC_SKIRT, placement="explicit")
    assert p.units_to_m == 0.01 and p.meta["units_in_meter"] == 1000
    assert list(p.panels) == ["back", "front", "band"]  # panel_order
    mm = 1e-3
    for name, panel in p.panels.items():
        g = spec["pattern"]["panels"][name]
        gv = np.array(g["vertices"], float) * mm
        # world = R [x, y, 0] + t, GarmentCode's rule, in metres
        world_gc = np.c_[gv, np.zeros(len(gv))] @ rotation_matrix_xyz_deg(g["rotation"]).T
        world_gc += np.array(g["translation"]) * mm
        pm = panel.placement_m
        ours = (
            np.c_[panel.vertices_m, np.zeros(len(gv))]
            @ rotation_matrix_xyz_deg(pm["rotation_deg"]).T
            + pm["translation_m"]
        )
        np.testing.assert_allclose(ours, world_gc, atol=1e-12)
        # every panel now runs counter-clockwise and its normal points away from the body
        m = mesh_panel(panel, 0.02)
        assert min_angle_deg(m.points, m.triangles) >= 25.0
    assert p.panels["back"].meta["garmentcode_mirrored"]
    assert not p.panels["front"].meta["garmentcode_mirrored"]
    r_back = rotation_matrix_xyz_deg(p.panels["back"].placement_m["rotation_deg"])
    np.testing.assert_allclose(r_back @ [0, 0, 1], [0, 0, -1], atol=1e-12)  # back faces -z

    front = p.panels["front"]
    # circle [r = 2000 mm, small arc, right]: bulges to the right of 1 -> 2, i.e. downwards
    hem = front.edges[1]
    assert hem.kind == "arc"
    r, c = 2.0, 0.7
    assert hem.sagitta_m == pytest.approx(-(r - math.sqrt(r * r - c * c / 4)), rel=1e-12)
    assert hem.length_m == pytest.approx(2 * r * math.asin(c / (2 * r)), rel=1e-12)
    # legacy [t, o] and dict quadratic: start + t d + o perp(d), perp(x, y) = (-y, x)
    p0, p1 = np.array([650, -600]) * mm, np.array([600, 0]) * mm
    d = p1 - p0
    np.testing.assert_allclose(
        front.edges[2].controls_m[0], p0 + 0.4 * d - 0.05 * np.array([-d[1], d[0]]), atol=1e-12
    )
    p0, p1 = np.array([600, 0]) * mm, np.array([0, 0]) * mm
    np.testing.assert_allclose(front.edges[3].controls_m[0], [0.3, -0.018], atol=1e-12)
    # stitches: GarmentCode sews end to start ("reverse"); right_wrong keeps the direction
    assert [s.direction for s in p.seams] == ["reverse", "reverse", "same"]
    assert p.seams[0].side_a == [("front", 0)] and p.seams[0].side_b == [("back", 3)]


def test_garmentcode_mirrored_panel_keeps_world_shape_of_curves():
    spec = json.loads(GC_SKIRT.read_text())
    p = load_garmentcode(GC_SKIRT, placement="explicit")
    back, g = p.panels["back"], spec["pattern"]["panels"]["back"]
    # the cubic edge 1 -> 2 sampled in our (mirrored) frame and placed in the world equals
    # GarmentCode's cubic placed with its own frame
    mm = 1e-3
    gv = np.array(g["vertices"], float) * mm
    a, b = gv[1], gv[2]
    dd = b - a
    ctrl = [
        a + t * dd + o * np.array([-dd[1], dd[0]]) for t, o in g["edges"][1]["curvature"]["params"]
    ]
    ref = curves.bezier_point(np.vstack([a, ctrl, b]), np.linspace(0, 1, 5))
    ref_world = ref[:, 0:1] * [1, 0, 0] + ref[:, 1:2] * [0, 1, 0] + np.array(g["translation"]) * mm
    e = back.edges[1]
    ours = curves.bezier_point(np.vstack([e.p0_m, e.controls_m, e.p1_m]), np.linspace(0, 1, 5))
    pm = back.placement_m
    ours_world = np.c_[ours, np.zeros(5)] @ rotation_matrix_xyz_deg(pm["rotation_deg"]).T
    np.testing.assert_allclose(ours_world + pm["translation_m"], ref_world, atol=1e-12)


def _gc_square(curvature=(0.5, -0.1), **props):
    edge = {"endpoints": [1, 2], "curvature": list(curvature)}
    return {
        "pattern": {
            "panels": {
                "sq": {
                    "translation": [1.0, 2.0, 3.0],
                    "rotation": [0, 90, 0],
                    "vertices": [[0, 0], [10, 0], [10, 10], [0, 10]],
                    "edges": [
                        {"endpoints": [0, 1],
                         "curvature": {"type": "circle", "params": [6.0, 1, 1]}},
                        edge,
                        {"endpoints": [2, 3]},
                        {"endpoints": [3, 0]},
                    ],
                }
            },
            "stitches": [],
        },
        "properties": {"units_in_meter": 100, **props},
    }  # fmt: skip


def test_garmentcode_absolute_curvature_large_arc_and_centring():
    d = garmentcode_to_dict(_gc_square([11.0, 5.0], curvature_coords="absolute"))
    p = load_pattern(d)
    e0, e1 = p.panels["sq"].edges[:2]
    # large arc of radius 6 on a chord of 10, bulging to the right (downwards, outside)
    r, c = 6.0, 10.0
    assert e0.sagitta_m * 100 == pytest.approx(-(r + math.sqrt(r * r - c * c / 4)), rel=1e-12)
    np.testing.assert_allclose(e1.controls_m[0], [0.11, 0.05])  # absolute [11, 5] cm
    d = garmentcode_to_dict(_gc_square(normalize_panel_translation=True))
    pl = d["panels"]["sq"]
    np.testing.assert_allclose(np.mean(pl["vertices"], axis=0), [0, 0], atol=1e-12)
    np.testing.assert_allclose(pl["placement"]["translation"], [6.0, 7.0, 3.0])
    np.testing.assert_allclose(pl["placement"]["rotation_deg"], [0, 90, 0], atol=1e-12)
    # relative [0.5, -0.1]: start + 0.5 d - 0.1 perp(d), perp(x, y) = (-y, x)
    d = garmentcode_to_dict(_gc_square())
    np.testing.assert_allclose(d["panels"]["sq"]["edges"][1]["curve"]["control"], [11, 5])


def test_garmentcode_cli_and_errors(tmp_path, capsys):
    out = tmp_path / "skirt.json"
    assert main([str(GC_SKIRT), str(out), "--placement", "explicit"]) == 0
    printed = capsys.readouterr().out
    assert "3 panels, 3 seams" in printed and "units_in_meter = 1000" in printed
    q = load_pattern(out)
    assert q.panels["front"].placement["translation"] == [-30.0, 100.0, 15.0]
    assert main([str(GC_SKIRT), str(out)]) == 0
    assert "placed on the body's landmarks" in capsys.readouterr().out
    q = load_pattern(out)
    assert q.panels["front"].placement["landmark"] == "waist_front"
    assert q.panels["front"].meta["garmentcode_placement"]["translation"] == [-30.0, 100.0, 15.0]
    with pytest.raises(SandboxError, match=r"gc.json: placement 'flat': use one of body, explicit"):
        garmentcode_to_dict(json.loads(GC_SKIRT.read_text()), where="gc.json", placement="flat")
    bad = copy.deepcopy(json.loads(GC_SKIRT.read_text()))
    bad["pattern"]["panels"]["front"]["edges"][1]["curvature"] = {"type": "spiral", "params": []}
    with pytest.raises(SandboxError, match=r"panel 'front': edge #1: unknown curvature type"):
        garmentcode_to_dict(bad, where="gc.json")
    bad_file = tmp_path / "bad_specification.json"
    bad_file.write_text(json.dumps(bad))
    assert main([str(bad_file), str(tmp_path / "x.json")]) == 2
    assert "unknown curvature type 'spiral'" in capsys.readouterr().err


# --------------------------------------------------------------------------------------
# Any broken input is a SandboxError, never a traceback


def _paths(t, pre=()):
    items = t.items() if isinstance(t, dict) else enumerate(t) if isinstance(t, list) else ()
    for k, v in items:
        yield pre + (k,)
        yield from _paths(v, pre + (k,))


def _mutations(base):
    for path in list(_paths(base)):
        original = base
        for k in path:
            original = original[k]
        for value in ("<delete>", None, "x", -1, [1], {}, True, float("nan")):
            d = copy.deepcopy(base)
            t = d
            for k in path[:-1]:
                t = t[k]
            if value == "<delete>":
                del t[path[-1]]
            else:
                t[path[-1]] = value
            yield path, original, value, d


# keys a file may leave out (GarmentCode: ``null`` stands for "absent" where marked below)
_OPTIONAL = {
    "units",
    "name",
    "curve",
    "grain",
    "placement",
    "body",
    "offset",
    "wrap",
    "clearance",
    "seams",
    "direction",
    "stiffness_N_m",
    "translation",
    "rotation",
    "curvature",
    "stitches",
    "properties",
    "units_in_meter",
}
_NULL_IS_ABSENT = {"curvature", "stitches", "properties"}
_EMPTY_OBJECT_OK = {"placement", "properties"}


def _verdict(path, original, value, seamed=("l",)):
    """True: the edited file is still valid; False: it must be refused; None: a number moved
    to -1, valid or not by the geometry it makes (a vertex crossing an edge, ...).
    ``seamed``: the edge names a seam refers to (renaming one breaks the seam)."""
    key = path[-1]
    if key == "name" and value in ("<delete>", "x"):
        return original not in seamed
    if value == "<delete>":
        return key in _OPTIONAL or (isinstance(key, int) and path[-2] in ("seams", "stitches"))
    if value is None:
        return key in _NULL_IS_ABSENT
    if value == {}:
        return key in _EMPTY_OBJECT_OK
    if value is True:
        return original is True
    if value == -1 and isinstance(original, (int, float)) and not isinstance(original, bool):
        return None
    return False


def test_broken_inputs_raise_sandbox_errors_only():
    """Every edit of a small pattern (and of a GarmentCode file) that breaks it is refused
    with a one-line SandboxError naming the file; the edits that keep it valid load."""
    small = {
        "format": "sandbox-pattern/1",
        "units": "cm",
        "panels": {
            "p": {
                "vertices": [[0, 0], [20, 0], [20, 30], [0, 30]],
                "edges": [
                    {"name": "hem", "from": 0, "to": 1, "curve": {"type": "arc", "sagitta": -1}},
                    {"name": "r", "from": 1, "to": 2,
                     "curve": {"type": "cubic", "controls": [[21, 10], [21, 20]]}},
                    {"name": "top", "from": 2, "to": 3,
                     "curve": {"type": "quadratic", "control": [10, 29]}},
                    {"name": "l", "from": 3, "to": 0},
                ],
                "grain": [0, 1],
                "placement": {"body": "torso", "side": "front", "anchor": [10, 30],
                              "landmark": "waist_front", "offset": [0, 0, 1], "wrap": True,
                              "clearance": 2},
            }
        },
        "seams": [{"a": [{"panel": "p", "edge": "l"}], "b": [{"panel": "p", "edge": 1}],
                   "direction": "same", "stiffness_N_m": 10}],
    }  # fmt: skip
    load_pattern(small)
    gc = _gc_square()
    gc["pattern"]["stitches"] = [[{"panel": "sq", "edge": 1}, {"panel": "sq", "edge": 3}]]
    load_pattern(garmentcode_to_dict(gc))
    cases = [(lambda d: load_pattern(d, where="small.json"), m) for m in _mutations(small)]
    cases += [
        (lambda d: load_pattern(garmentcode_to_dict(d, where="gc.json"), where="gc.json"), m)
        for m in _mutations(gc)
    ]
    refused = 0
    for load, (path, original, value, d) in cases:
        case = f"{list(path)} = {value!r}"
        verdict = _verdict(path, original, value)
        try:
            load(d)
        except SandboxError as exc:
            msg = str(exc)
            assert verdict is not True, f"{case}: a valid edit refused: {msg}"
            assert msg.startswith(("small.json: ", "gc.json: ")), f"{case}: {msg!r}"
            assert "\n" not in msg, f"{case}: not one line: {msg!r}"
            refused += 1
        except Exception as exc:  # pragma: no cover - the failure message names the case
            pytest.fail(f"{case}: {type(exc).__name__}: {exc}")
        else:
            assert verdict is not False, f"{case}: broken input accepted silently"
    assert refused > 0.8 * len(cases)
    gc["pattern"]["stitches"] = {}
    with pytest.raises(SandboxError, match=r"^gc.json: pattern.stitches must be a list$"):
        garmentcode_to_dict(gc, where="gc.json")


def test_check_cli(tmp_path, capsys):
    assert check_main([str(SKIRT), "--edge-cm", "4"]) == 0
    out = capsys.readouterr().out
    assert "panel front:" in out and "min angle" in out
    assert "seam 0: front.side_left 61.3 cm <-> back.side_left 61.3 cm (auto" in out
    p = load_pattern(SKIRT)
    (a, b), _ = p.seam_lengths_m()
    assert a == pytest.approx(b) == pytest.approx(p.panels["front"].edges[1].length_m)
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(_bad(_set(["units"], "inch"))))
    assert check_main([str(bad)]) == 2
    assert "unknown units 'inch'" in capsys.readouterr().err


def test_garmentcode_seams_join_matching_points():
    """Imported stitches, placed as GarmentCode places them, sew points that face each other."""
    from sandbox.sim.builder import ModelBuilder
    from sandbox.sim.materials import material_from_spec

    p = load_garmentcode(GC_SKIRT, placement="explicit")
    p.seams = p.seams[:2]  # the two side seams (the third is a deliberate test flag)
    meshes = mesh_pattern(p, 0.04)
    b = ModelBuilder()
    mat = material_from_spec(p.fabric, where="test")
    index = {}
    for name, m in meshes.items():
        pm = p.panels[name].placement_m
        rot = rotation_matrix_xyz_deg(pm["rotation_deg"])
        index[name] = b.add_cloth(name=name, pattern_uv=m.points, triangles=m.triangles,
                                  material=mat, rotation=rot, translation=pm["translation_m"],
                                  grain_rad=m.grain_rad)  # fmt: skip
    for s in pattern_seam_sides(p, meshes, index):
        assert s["direction"] == "reverse"
        b.add_seam(**s)
    model = b.finalize()
    x = model.initial_positions_np
    gap = x[model.seam_pairs_np[:, 0]] - x[model.seam_pairs_np[:, 1]]
    np.testing.assert_allclose(np.abs(gap[:, 2]), 0.3, atol=1e-9)  # front z = 0.15, back -0.15
    # same side, same height: within one mesh edge (the wrong direction would be ~60 cm off)
    xy = np.linalg.norm(gap[:, :2], axis=1)
    assert np.median(xy) < 0.01 and xy.max() < 0.045
