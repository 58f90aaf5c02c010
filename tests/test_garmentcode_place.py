"""GarmentCode imports placed on the body's landmarks (sandbox.pattern.garmentcode_place)."""

from pathlib import Path

import numpy as np
import pytest

from sandbox.pattern.garmentcode import load_garmentcode
from sandbox.pattern.garmentcode_body import load_garmentcode_levels
from sandbox.pattern.garmentcode_place import MEAN_ALL
from sandbox.pattern.spec import rotation_matrix_xyz_deg

GC = Path(__file__).parent / "data" / "garmentcode"


def _both(name: str):
    spec = GC / f"{name}_specification.json"
    return load_garmentcode(spec), load_garmentcode(spec, placement="explicit")


def _world(panel) -> np.ndarray:
    """GarmentCode's 3D layout [m] of a panel's corners, from an explicit placement."""
    pm = panel.placement_m if "translation" in panel.placement else None
    if pm is None:  # body placement: GarmentCode's, kept in the meta (cm)
        g = panel.meta["garmentcode_placement"]
        r, t = rotation_matrix_xyz_deg(g["rotation_deg"]), np.asarray(g["translation"]) * 0.01
    else:
        r, t = rotation_matrix_xyz_deg(pm["rotation_deg"]), pm["translation_m"]
    v = panel.vertices_m
    return np.c_[v, np.zeros(len(v))] @ r.T + t


def test_mean_all_levels_are_garmentcodes():
    """GarmentCode's waist level is height - head_l - waist_line (its body_params.py); the
    flared skirt's waistband tops out exactly there."""
    assert load_garmentcode_levels(GC / "bodies" / "mean_all.yaml") == MEAN_ALL
    assert MEAN_ALL.waist_cm == pytest.approx(171.99 - 26.3262 - 36.8913)
    _, explicit = _both("flare_skirt")
    top = max(_world(p)[:, 1].max() for n, p in explicit.panels.items() if n.startswith("wb"))
    assert top * 100 == pytest.approx(MEAN_ALL.waist_cm, abs=0.1)


def test_shirt_panels_go_on_torso_and_arms():
    body, explicit = _both("shirt_mean")
    for name, panel in body.panels.items():
        pl = panel.placement
        side = "front" if name.endswith("_f") or "ftorso" in name else "back"
        assert pl["side"] == side, name
        if "sleeve" in name:
            arm = "left" if name.startswith("left") else "right"
            assert pl["body"] == f"arm_{arm}" and pl["landmark"] == f"shoulder_point_{arm}"
        else:
            assert pl["body"] == "torso" and pl["landmark"] == "side_neck_point_left"
            # the bodice's top at the side neck point, its centre line on the body's
            assert pl["anchor"][1] == pytest.approx(panel.vertices_m[:, 1].max() * 100)
            assert pl["anchor"][0] == pytest.approx(0.0, abs=1e-6)
        # the same cloth: edge lengths unchanged, the same 3D layout recorded
        for e, f in zip(panel.edges, explicit.panels[name].edges, strict=True):
            assert e.length_m == pytest.approx(f.length_m, rel=1e-6)
        np.testing.assert_allclose(_world(panel), _world(explicit.panels[name]), atol=1e-5)


def test_sleeves_are_turned_along_the_arm():
    """A sleeve's y axis runs up GarmentCode's arm (45 deg below the horizontal) and its
    grain turns with it."""
    body, explicit = _both("shirt_mean")
    sleeve = body.panels["left_sleeve_f"]
    g = sleeve.meta["garmentcode_placement"]
    r = rotation_matrix_xyz_deg(g["rotation_deg"])
    y_world = r @ [0.0, 1.0, 0.0]
    a = np.radians(MEAN_ALL.arm_pose_deg)
    np.testing.assert_allclose(y_world, [-np.cos(a), np.sin(a), 0.0], atol=1e-6)
    grain_world = r[:, :2] @ sleeve.grain
    old = explicit.panels["left_sleeve_f"]
    r0 = rotation_matrix_xyz_deg(old.placement_m["rotation_deg"])
    np.testing.assert_allclose(grain_world, r0[:, :2] @ old.grain, atol=1e-6)
    # the anchor: the sleeve's top (at the shoulder point), its middle across
    assert sleeve.placement["anchor"][1] == pytest.approx(sleeve.vertices_m[:, 1].max() * 100)


def test_skirts_hang_from_the_waist_and_trousers_keep_their_place():
    body, _ = _both("flare_skirt")
    assert {p.placement["landmark"] for p in body.panels.values()} == {"waist_front",
                                                                       "waist_back"}  # fmt: skip
    body, _ = _both("js_mean_all")
    kept = body.meta["garmentcode_placement_kept"]
    assert sorted(kept) == ["pant_b_l", "pant_b_r", "pant_f_l", "pant_f_r"]
    assert all("translation" in body.panels[n].placement for n in kept)
    # a hood, laid out above the bodice, keeps its height above it
    body, explicit = _both("hoody_mean")
    hood, torso = body.panels["left_hood"].placement, body.panels["left_ftorso"].placement
    assert hood["side"] == "left" and torso["landmark"] == hood["landmark"]
    rise = _world(explicit.panels["left_hood"])[:, 1].min() - _world(
        explicit.panels["left_ftorso"])[:, 1].max()  # fmt: skip
    # hood's lowest point above the bodice's top, in both placements' frames (cm)
    hood_low = body.panels["left_hood"].vertices_m[:, 1].min() * 100 - hood["anchor"][1]
    torso_top = body.panels["left_ftorso"].vertices_m[:, 1].max() * 100 - torso["anchor"][1]
    assert hood_low - torso_top == pytest.approx(rise * 100, abs=0.01)


def test_seam_sides_are_sampled_alike():
    """GarmentCode's shirt has 7.5 mm edges beside its side seams: each side is graded
    towards its own, yet both sides of every seam of equal edges get the same samples, at
    the same fractions of their lengths (the springs join coincident points), and the mesh
    keeps its quality."""
    from sandbox.pattern.mesh2d import min_angle_deg
    from sandbox.pattern.panel_mesh import _fractions, mesh_pattern

    p, _ = _both("shirt_mean")
    for h in (0.03, 0.015):
        meshes = mesh_pattern(p, h)
        matched = 0
        for seam in p.seams:
            (pa, ka), (pb, kb) = seam.side_a[0], seam.side_b[0]
            qa = meshes[pa].points[meshes[pa].edge_vertices[ka]]
            qb = meshes[pb].points[meshes[pb].edge_vertices[kb]]
            fa, fb = _fractions(qa), _fractions(qb)[::-1]
            assert len(fa) == len(fb), (pa, ka, pb, kb)
            np.testing.assert_allclose(fa, 1.0 - fb, atol=2e-3)
            matched += 1
        assert matched == len(p.seams) == 18
        assert min(min_angle_deg(m.points, m.triangles) for m in meshes.values()) >= 25.0


def test_the_jumpsuits_millimetre_edges_are_not_meshed():
    """GarmentCode's jumpsuit has 0.9-1.8 mm edges where its stitches split the waist: they
    collapse to one vertex each, so no mesh edge is far shorter than the target, no vertex is
    held up by the mass floor, and every seam still sews both its sides."""
    from sandbox.pattern.panel_mesh import mesh_pattern

    p, _ = _both("js_mean_all")
    for h in (0.03, 0.015):
        meshes = mesh_pattern(p, h)
        shortest = min(
            np.linalg.norm(m.points[t[:, [1, 2, 0]]] - m.points[t], axis=2).min()
            for m in meshes.values()
            for t in [m.triangles]
        )
        assert shortest > 0.2 * h
        for seam in p.seams:
            for side in (seam.side_a, seam.side_b):
                assert all(len(meshes[pn].edge_vertices[k]) >= 2 for pn, k in side)
    assert sum(len(m.points) for m in mesh_pattern(p, 0.03).values()) < 3100  # 4,041 graded


def test_a_lapel_is_cut_to_turn_over():
    """Every stitch of the standing lapel's front collar joins its right side to the wrong
    side of its neighbours: it is meant to end turned over, and the fold check skips it."""
    from sandbox.garment.metrics import fold_metrics

    body, _ = _both("standing_lapel_fix")
    turns = sorted(n for n, p in body.panels.items() if p.meta.get("turns_over"))
    assert turns == ["left_collar_front", "right_collar_front"]
    # two triangles, the second turned over: counted unless it is meant to turn
    x0 = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0], [3, 0, 0], [2, 1, 0]], float)
    x1 = x0.copy()
    x1[5] = [2, -1, 0]
    tris = np.array([[0, 1, 2], [3, 4, 5]])
    assert fold_metrics(x0, x1, tris)["folded_area_pct"] == pytest.approx(50.0)
    keep = np.array([False, True])
    assert fold_metrics(x0, x1, tris, meant_to_turn=keep)["folded_area_pct"] == 0.0


def test_an_import_records_the_arm_pose_it_was_drafted_for():
    """GarmentCode's arm pose is below the horizontal; the pattern records the mannequin's
    angle from the vertical, and a drape without a given pose uses it."""
    body, _ = _both("shirt_mean")
    assert body.meta["arm_angle_deg"] == pytest.approx(90.0 - MEAN_ALL.arm_pose_deg)
    assert body.meta["head_length_cm"] == pytest.approx(MEAN_ALL.head_cm)  # a hood rests on it


def test_a_hood_wraps_the_head_and_leaves_the_bodice_its_half_turn():
    """The hood's panels (left and right, above the neck) do not share the turn round the
    torso with the bodice's front and back below them: every panel starts at its clearance
    (2 cm) from the body, the hood round the head."""
    import open3d as o3d

    from sandbox.garment import make_mannequin
    from sandbox.pattern.panel_mesh import mesh_pattern
    from sandbox.pattern.placement.place import place_pattern

    pattern, _ = _both("hoody_mean")
    man = make_mannequin(18, arm_angle_deg=pattern.meta["arm_angle_deg"],
                         head_length_cm=pattern.meta["head_length_cm"])  # fmt: skip
    placed = place_pattern(pattern, mesh_pattern(pattern, 0.03), man)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(man.vertices.astype(np.float32)),
                        o3d.core.Tensor(man.triangles.astype(np.uint32)))  # fmt: skip
    head = len(man.triangles) - 1280  # the head's triangles come last
    for name, x in placed.items():
        q = o3d.core.Tensor(x.astype(np.float32))
        d = scene.compute_distance(q).numpy()
        assert d.min() > 0.019 and np.median(d) < 0.08, (name, d.min(), np.median(d))
        if "hood" in name:
            nearest = scene.compute_closest_points(q)["primitive_ids"].numpy()
            assert (nearest >= head).mean() > 0.8, name


@pytest.mark.slow
@pytest.mark.parametrize("spec", ["hoody_mean", "js_mean_all"])
def test_garmentcode_examples_meet_the_acceptance_on_their_body(spec, tmp_path):
    """GarmentCode's examples, imported and draped at 3 cm on the body they were
    made for (mean_all: size 18 resized, arms at 44.5 deg, its head), meet the drape
    acceptance (docs/garmentcode.md; all eight: benchmarks/bench_garmentcode.py). The
    hoodie's hood rests on the head; the jumpsuit's millimetre edges are one vertex each
    and it comes to rest with its seams closed."""
    from sandbox.garment import drape, make_mannequin
    from sandbox.pattern.garmentcode_body import load_garmentcode_body
    from sandbox.pattern.spec import save_pattern

    body = load_garmentcode_body(GC / "bodies" / "mean_all.yaml")
    mannequin = make_mannequin(body.size, body.measurements, arm_angle_deg=body.arm_angle_deg,
                               head_length_cm=body.head_length_cm)  # fmt: skip
    path = save_pattern(load_garmentcode(GC / f"{spec}_specification.json"), tmp_path / "p.json")
    res = drape(path, mannequin=mannequin, out_dir=tmp_path / "out", edge_length_m=0.03,
                render=False, meshes=False, progress=False)  # fmt: skip
    assert res.metrics["acceptance_failures"] == []


def test_cover_passes_are_settings_and_skip_a_drape_that_is_covered():
    """``RepairConfig.cover_passes`` is a whole number; a drape whose body shows through by
    no more than the tolerance is returned as it is, without a pass."""
    from types import SimpleNamespace

    from sandbox.errors import SandboxError
    from sandbox.garment.config import RepairConfig
    from sandbox.garment.repair import settle_covered

    with pytest.raises(SandboxError, match="RepairConfig.cover_passes must be a whole number"):
        RepairConfig(cover_passes=-1)
    body = SimpleNamespace(closed=True)
    scene = SimpleNamespace(spec=SimpleNamespace(stop=None),
                            model=SimpleNamespace(colliders=[body]))  # fmt: skip
    result = SimpleNamespace(metrics={"body_through_cloth_max_m": 0.9e-3})
    assert settle_covered(scene, result, RepairConfig(), 1e-3) == (result, [])


def test_a_bad_body_meta_is_named(tmp_path):
    """A pattern's ``meta.head_length_cm`` (or ``arm_angle_deg``) that is not a number is
    refused naming the file and the key, before anything is built."""
    from sandbox.errors import SandboxError
    from sandbox.garment import drape
    from sandbox.pattern.spec import save_pattern

    pattern, _ = _both("hoody_mean")
    pattern.meta["head_length_cm"] = "tall"
    path = save_pattern(pattern, tmp_path / "p.json")
    with pytest.raises(SandboxError, match=r"meta\.head_length_cm: 'tall' is not a number"):
        drape(path, out_dir=tmp_path / "out", edge_length_m=0.03, render=False, meshes=False)
