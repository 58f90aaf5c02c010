"""The garment drape pipeline (sandbox/garment) and its CLI."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from sandbox import runtime
from sandbox.cli import main
from sandbox.garment import DrapeConfig, build_drape, drape
from sandbox.garment.config import IMPLICIT_GARMENT_EDGE_M, implicit_mesh_warning
from sandbox.garment.metrics import ease_cm
from sandbox.mannequin import build_mannequin
from sandbox.mannequin.tape import girth_at
from sandbox.pattern.spec import load_pattern

DATA = Path(__file__).parent / "data"


@pytest.fixture(scope="module")
def mannequin():
    return build_mannequin(size=12)


@pytest.fixture(scope="module")
def skirt_run(mannequin, tmp_path_factory):
    """The 2-panel tube skirt, 3 cm mesh, jersey, draped to the stop rule."""
    out = tmp_path_factory.mktemp("skirt")
    res = drape(DATA / "drape_skirt.json", mannequin=mannequin, out_dir=out, edge_length_m=0.03,
                progress=False, config=DrapeConfig(time_limit_s=4.0))  # fmt: skip
    return res, out


@pytest.mark.slow
def test_skirt_drapes_closed_outside_and_with_ease(skirt_run):
    res, _ = skirt_run
    m = res.metrics
    assert m["nan_positions"] == 0 and np.all(np.isfinite(res.run.positions))
    assert m["seam_count"] > 0
    assert m["seam_gap_max_m"] < 5e-3
    assert m["vertices_inside_body"] == 0
    assert m["penetration_max_m"] == 0.0
    assert m["converged"], m["stop_reason"]
    assert m["ease_hip_cm"] > 0
    assert m["ease_waist_cm"] is not None
    assert m["ease_bust_cm"] is None  # a skirt does not reach the bust
    # the skirt hangs on the hips: it did not slide down the legs
    x = res.run.positions
    hip_y = res.scene.garment.mannequin.landmarks["hip_front"][1]
    assert x[:, 1].max() > hip_y + 0.1


@pytest.mark.slow
def test_drape_outputs(skirt_run):
    res, out = skirt_run
    for name in ("garment.obj", "garment.ply", "body.obj", "render.png", "render_back.png",
                 "metrics.json"):  # fmt: skip
        assert (out / name).is_file(), name
    m = json.loads((out / "metrics.json").read_text())
    for key in ("steps", "dt_s", "wall_time_s", "converged", "seam_gap_max_m",
                "penetration_max_m", "vertices_inside_body", "intersecting_triangle_pairs",
                "ease_bust_cm", "ease_waist_cm", "ease_hip_cm", "sew_sim_time_s"):  # fmt: skip
        assert key in m, key
    assert m["stop_max_displacement_m"] == 1.5e-3 and m["stop_mean_displacement_m"] == 1e-4
    assert m["vertex_count"] == res.scene.model.particle_count
    text = (out / "garment.obj").read_text()
    assert text.count("\nvt ") == res.scene.model.particle_count


@pytest.mark.slow
def test_sewing_hands_back_the_scene_as_it_found_it(skirt_run):
    """The sewing phase's speed limit is lifted and the body's friction is the scene's."""
    res, _ = skirt_run
    m, scene = res.metrics, res.scene
    assert isinstance(m["sew_stalled"], bool) and m["sew_frames"] > 0
    assert m["sew_at_rest"] is False  # the explicit solver keeps its velocities
    assert scene.solver.speed_limit[None] == 0.0
    body = scene.solver.friction().body  # (μ_s, μ_k) of each body collider
    assert body and all(mu == pytest.approx((0.4, 0.3)) for mu in body)


def test_ease_of_a_cylinder(mannequin):
    """A closed tube of radius R around the hip: ease = 2πR − body girth."""
    y = float(mannequin.landmarks["hip_front"][1])
    r, n = 0.25, 96
    ang = np.linspace(0, 2 * np.pi, n, endpoint=False)
    cz = float(np.mean([mannequin.landmarks["hip_front"][2], mannequin.landmarks["hip_back"][2]]))
    rows = [np.stack([r * np.sin(ang), np.full(n, yy), cz + r * np.cos(ang)], 1)
            for yy in (y - 0.1, y + 0.1)]  # fmt: skip
    x = np.vstack(rows)
    i = np.arange(n)
    j = (i + 1) % n
    tris = np.concatenate([np.stack([i, j, i + n], 1), np.stack([j, j + n, i + n], 1)])
    e = ease_cm(x, tris, mannequin)
    polygon = 2 * n * r * math.sin(math.pi / n)
    body = girth_at(mannequin.vertices, mannequin.triangles, y, axis_xz=(0.0, cz))
    assert e["ease_hip_cm"] == pytest.approx(100 * (polygon - body), abs=0.3)
    assert e["ease_bust_cm"] is None and e["ease_waist_cm"] is None


@pytest.mark.slow
def test_build_drape_top(mannequin):
    pattern = load_pattern(DATA / "drape_top.json")
    scene = build_drape(
        pattern, mannequin, edge_length_m=0.04, config=DrapeConfig(self_collision=False)
    )
    model = scene.model
    assert [p.name for p in model.pieces] == ["front", "back"]
    assert model.seam_count > 0
    assert len(model.colliders) == 1 and model.colliders[0].closed
    assert 0 < scene.dt_s <= 0.9 * scene.dt_limit_s + 1e-12
    assert scene.spec.stop.max_displacement_m == 1.5e-3
    # seams are as stiff as the cloth at 1 cm, so they hold the garment's weight; a spring
    # of a coarser mesh stands for a longer piece of seam (4 cm here: 4x)
    mat = model.pieces[0].material
    k = max(mat.stretch_u_N_m, mat.stretch_v_N_m)
    assert np.allclose(model.seam_stiffness_np, 4.0 * k)


def test_cli_list_and_errors(capsys, tmp_path):
    assert main(["drape", "--list"]) == 0
    names = capsys.readouterr().out.split()
    from sandbox.drafting import garment_names

    assert names == list(garment_names())
    assert main(["drape", "no-such-garment", "--out", str(tmp_path)]) == 2
    assert "unknown garment" in capsys.readouterr().err
    assert main(["drape", str(tmp_path / "missing.json"), "--out", str(tmp_path)]) == 2
    assert "no such pattern file" in capsys.readouterr().err
    assert main(["drape", str(DATA / "drape_skirt.json"), "--out", str(tmp_path),
                 "--edge-cm", "0"]) == 2  # fmt: skip


@pytest.mark.slow
def test_implicit_drape_sews_and_drapes_the_tube_skirt(mannequin, tmp_path):
    """The implicit integrator runs the whole drape (sewing, self-collision, body contact)."""
    res = drape(DATA / "drape_skirt.json", mannequin=mannequin, out_dir=tmp_path,
                edge_length_m=0.05, progress=False, render=False,
                config=DrapeConfig(time_limit_s=1.0, integrator="implicit_euler"))  # fmt: skip
    m = res.metrics
    assert m["dt_s"] == pytest.approx(1 / 60)
    assert m["nan_positions"] == 0 and m["vertices_inside_body"] == 0
    assert m["sew_frames"] > 0 and m["sew_gap_m"] < 0.01
    assert res.scene.solver.stats()["factorisations"] > 0  # the direct linear solver ran
    assert m["integrator_warning"] is None  # 5 cm: coarser than the measured limit


def test_cli_implicit_drape_meshes_at_3_cm_unless_told(monkeypatch, tmp_path):
    """`drape --integrator implicit_euler` without --edge-cm meshes at 3 cm (1 cm would
    take hours); an explicit --edge-cm wins; symplectic Euler keeps 1 cm."""
    import sandbox.garment as garment_package
    from sandbox.errors import SandboxError

    edges = []

    def fake_drape(garment, **kw):
        edges.append((kw["config"].integrator, kw["edge_length_m"]))
        raise SandboxError("stop here")

    monkeypatch.setattr(garment_package, "drape", fake_drape)
    # the CLI starts Taichi in float32 before it drapes: that would reset this module's
    # float64 runtime and the fields of its fixtures
    monkeypatch.setattr(runtime, "init", lambda *a, **k: None)
    base = ["drape", "a-line-skirt", "--out", str(tmp_path), "--quiet"]
    assert main([*base, "--integrator", "implicit_euler"]) == 2
    assert main([*base, "--integrator", "implicit_euler", "--edge-cm", "2"]) == 2
    assert main(base) == 2
    assert edges == [("implicit_euler", pytest.approx(0.03)),
                     ("implicit_euler", pytest.approx(0.02)),
                     ("symplectic_euler", pytest.approx(0.01))]  # fmt: skip


def test_implicit_drape_on_a_fine_mesh_warns():
    """implicit_euler finer than 3 cm gets a warning that names the limit and the way out."""
    note = implicit_mesh_warning("implicit_euler", 0.01)
    assert "1 cm" in note and "3 cm" in note and "symplectic_euler" in note
    assert implicit_mesh_warning("implicit_euler", IMPLICIT_GARMENT_EDGE_M) is None
    assert implicit_mesh_warning("symplectic_euler", 0.01) is None


@pytest.mark.slow
def test_the_seam_exclusion_narrows_to_the_partners(skirt_run):
    """Self-collision leaves out a vertex's seam partners (and their partners, for junctions
    of three panels) with their mesh neighbours (the default, so seams can close), or only
    the partners when asked; vertex-triangle and edge-edge tests share the list."""
    model = skirt_run[0].scene.model
    collider, pairs = model.self_collider, model.seam_pairs_np

    def excluded(v):
        start, flat = collider.partner_start.to_numpy(), collider.partner.to_numpy()
        return set(flat[start[v] : start[v + 1]].tolist())

    def sewn(v):
        return set(pairs[pairs[:, 0] == v, 1].tolist()) | set(pairs[pairs[:, 1] == v, 0].tolist())

    a = int(pairs[0, 0])
    partners = sewn(a).union(*(sewn(b) for b in sewn(a))) - {a}
    assert sewn(a) <= partners
    try:
        collider.set_seam_partners(pairs, neighbours=True)
        wide = excluded(a)
        collider.set_seam_partners(pairs, neighbours=False)
        assert excluded(a) == partners
        assert partners < wide and len(wide) >= len(partners) + 3
    finally:
        collider.set_seam_partners(pairs)


@pytest.mark.slow
def test_implicit_sewing_ends_each_frame_at_rest_so_the_circle_skirt_closes(mannequin):
    """The 3 cm circle skirt is placed with 10-13 cm seam gaps. Backward Euler kept the
    seams' pull as momentum: 3 m/s in the second frame, the hem swung up between the legs
    and the sewing stalled 22.7 mm open after 13 frames. Ending every sewing frame at rest
    (SewingConfig.at_rest_implicit) closes every seam below 2 mm within a few frames."""
    from sandbox.garment import SewingConfig, resolve_pattern
    from sandbox.garment.sewing import sew

    assert SewingConfig().at_rest_implicit
    scene = build_drape(resolve_pattern("circle-skirt", mannequin), mannequin,
                        edge_length_m=0.03,
                        config=DrapeConfig(integrator="implicit_euler"))  # fmt: skip
    x0 = scene.state.positions()
    pairs, rest = scene.model.seam_pairs_np, scene.model.seam_rest_np
    assert np.min(np.linalg.norm(x0[pairs[:, 0]] - x0[pairs[:, 1]], axis=1) - rest) > 0.05
    out = sew(scene)
    assert out["sew_at_rest"] and not out["sew_stalled"] and out["sew_gap_m"] < 2e-3
    assert out["sew_frames"] <= 12  # 3 sewing frames and the 6 of the ramp when traced
    assert np.all(scene.state.velocities() == 0.0)
    x = scene.state.positions()
    assert np.all(np.isfinite(x))
    # the hem did not swing up between the legs: its highest point rose 4.8 cm while the
    # gores closed (22.8 cm with the momentum kept)
    hem = x0[:, 1] < x0[:, 1].min() + 0.01
    assert x[hem, 1].max() < x0[hem, 1].max() + 0.08


def test_drape_settings_from_a_toml_file(tmp_path):
    """A drape's settings file sets DrapeConfig's fields and its sub-tables; a bad key or
    value is refused with one line naming the file and the setting."""
    from sandbox.errors import SandboxError
    from sandbox.garment.config import load_drape_config

    path = tmp_path / "drape.toml"
    path.write_text('time_limit_s = 4.0\nintegrator = "implicit_euler"\n'
                    "[sewing]\nspeed_limit_m_s = 2.0\nself_collision = false\n")  # fmt: skip
    config = load_drape_config(path)
    assert config.time_limit_s == 4.0 and config.implicit
    assert config.sewing.speed_limit_m_s == 2.0 and not config.sewing.self_collision
    assert config.sewing.gap_m == DrapeConfig().sewing.gap_m  # the rest keep their defaults
    for text, words in (
        ("time_limt_s = 4.0", ["time_limt_s", "unknown"]),
        ("[sewing]\ngap = 1.0", ["sewing", "gap"]),
        ("time_limit_s = -1.0", ["time_limit_s", "positive"]),
        ("self_collision = 1", ["self_collision"]),
        ('integrator = "rk4"', ["rk4"]),
        ("time_limit_s = ", ["not a TOML file"]),
    ):
        path.write_text(text)
        with pytest.raises(SandboxError) as err:
            load_drape_config(path)
        message = str(err.value)
        assert str(path) in message and "\n" not in message
        assert all(w in message for w in words), message
    with pytest.raises(SandboxError, match="no such drape settings file"):
        load_drape_config(tmp_path / "missing.toml")


def test_cli_flags_win_over_the_settings_file(tmp_path):
    import argparse

    from sandbox.cli import drape_config_from_args
    from sandbox.garment.config import drape_config_from_dict

    base = drape_config_from_dict({"time_limit_s": 3.0, "integrator": "implicit_euler"})
    flags = argparse.Namespace(integrator=None, method=None, no_self_collision=False, fast_sew=True,
                               time_limit=5.0, strain_damping=None)  # fmt: skip
    config = drape_config_from_args(flags, base)
    assert config.time_limit_s == 5.0 and config.implicit and not config.sewing.self_collision
    assert config.self_collision  # --fast-sew: only the sewing runs without self-collision
