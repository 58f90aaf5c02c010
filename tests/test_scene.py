"""Scene files: checks before any kernel, only what the scene needs, outputs, bad input."""

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from sandbox.errors import SandboxError
from sandbox.scene.build import build_scene
from sandbox.scene.run import SimulationDiverged, run_scene
from sandbox.scene.spec import load_scene, scene_from_dict
from sandbox.sim.builder import ModelBuilder
from sandbox.sim.materials import get_material
from tests.helpers import sheet_scene, sheet_spec


def write_toml(path, text):
    path.write_text(text, encoding="utf-8")
    return path


GOOD = """
[scene]
name = "tiny"
[simulation]
dt_s = 5e-4
[stop]
time_limit_s = 0.2
[[cloth]]
name = "sheet"
size_m = [0.1, 0.1]
edge_length_m = 0.02
material = "jersey"
pins = [{ corners = "top" }]
"""


@pytest.mark.parametrize(
    "edit, needle",
    [
        (("[scene]", "[scene]\ncolour = 'red'"), "unknown key 'colour'"),
        (
            ('material = "jersey"', "material = { preset = 'jersey', shear_N_m = -3.0 }"),
            "'shear_N_m' must be >= 0",
        ),  # fmt: skip
        (
            ('material = "jersey"', "material = { preset = 'jersey', stretch_u_N_m = nan }"),
            "'stretch_u_N_m' must be finite",
        ),  # fmt: skip
        (
            ('pins = [{ corners = "top" }]', "pins = [{ vertices = [0, 100000] }]"),
            "index 100000 is out of range",
        ),  # fmt: skip
        (('material = "jersey"', 'material = "chainmail"'), "unknown"),
        (("dt_s = 5e-4", "dt_s = -1.0"), "dt_s: must be > 0"),
        (
            ("dt_s = 5e-4", 'integrator = "implicit_euler"\nstrain_damping_s = 1e-6'),
            "strain_damping_s is for symplectic_euler only",
        ),  # fmt: skip
        (("dt_s = 5e-4", "strain_damping_s = -1e-6"), "strain_damping_s: must be >= 0"),
        (
            ("size_m = [0.1, 0.1]", 'shape = "polygon"\noutline_m = [[0, 0], [0.1, 0], [0.2, 0]]'),
            "zero area",
        ),  # fmt: skip
    ],
)
def test_bad_scene_files_name_the_file_entry_and_problem(tmp_path, edit, needle):
    path = write_toml(tmp_path / "bad.toml", GOOD.replace(*edit))
    with pytest.raises(SandboxError) as err:
        build_scene(load_scene(path))
    msg = str(err.value)
    assert str(path) in msg and needle in msg, msg


def test_bad_scene_stops_before_any_kernel_and_writes_nothing(tmp_path):
    bad = write_toml(tmp_path / "bad.toml", GOOD.replace("[scene]", "[scene]\nfoo = 1"))
    out = tmp_path / "out"
    proc = subprocess.run(
        [sys.executable, "-m", "sandbox", "run", str(bad), "--out", str(out)],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    assert "bad.toml" in proc.stderr and "unknown key 'foo'" in proc.stderr
    assert not out.exists()


def test_zero_area_triangle_is_named():
    builder = ModelBuilder()
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [2.0, 0.0]])
    with pytest.raises(SandboxError, match="triangle 1 has zero rest area"):
        builder.add_cloth(
            name="p",
            pattern_uv=uv,
            triangles=[[0, 1, 2], [0, 1, 3]],
            material=get_material("cotton"),
            where="scene.toml: cloth[0]",
        )
        builder.finalize()


def test_builder_allocates_only_what_the_scene_needs():
    flat = build_scene(sheet_spec(simulation={"bending": False}))
    assert flat.model.hinge_count == 0
    assert flat.model.hinge_indices is None and flat.solver.hinge_force is None
    assert flat.model.colliders == []  # nothing to collide with: no collision structures
    bent = build_scene(sheet_spec())
    assert bent.model.hinge_count > 0 and bent.model.hinge_indices is not None


def test_pins_do_not_move_and_the_sheet_hangs_below_them():
    scene = build_scene(sheet_spec(stop={"time_limit_s": 0.5}))
    x0 = scene.state.positions()
    result = run_scene(scene, progress=False)
    pinned = scene.model.pinned_np
    assert pinned.sum() >= 2
    np.testing.assert_allclose(result.positions[pinned], x0[pinned], atol=1e-7)
    assert result.positions[~pinned, 1].max() <= x0[pinned, 1].max() + 1e-6


def test_diverged_run_names_the_step_and_writes_no_mesh(tmp_path):
    data = sheet_scene(simulation={"dt_s": 0.02, "damping_per_s": 0.0},
                       cloth={"material": "cotton"})  # fmt: skip
    path = tmp_path / "blowup.toml"
    import tomli_w

    path.write_bytes(tomli_w.dumps(data).encode())
    out = tmp_path / "out"
    proc = subprocess.run(
        [sys.executable, "-m", "sandbox", "run", str(path), "--out", str(out), "-q"],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert proc.returncode == 2, proc.stderr
    assert "diverged at step" in proc.stderr and "vertex" in proc.stderr
    assert not (out / "mesh.obj").exists() and not (out / "mesh.ply").exists()


def test_strain_damping_reaches_the_model_and_shortens_the_automatic_step():
    """``strain_damping_s`` sets the model's β; the automatic step shrinks by √(1+ζ²) − ζ."""
    plain = build_scene(sheet_spec(cloth={"material": "cotton"}))
    damped = build_scene(sheet_spec(simulation={"strain_damping_s": 1e-5},
                                    cloth={"material": "cotton"}))  # fmt: skip
    assert damped.model.strain_damping_s[None] == pytest.approx(1e-5)
    assert plain.model.strain_damping_s[None] == 0.0
    zeta = 1e-5 / damped.dt_limit_s
    factor = math.sqrt(1 + zeta * zeta) - zeta
    assert 0.5 < factor < 0.99
    # dt is then rounded down to a whole number of steps per frame
    assert factor * 0.9 * plain.dt_limit_s * 0.9 < damped.dt_s <= factor * 0.9 * plain.dt_limit_s


def test_diverged_run_raises_in_the_api():
    scene = build_scene(sheet_spec(simulation={"dt_s": 0.02, "damping_per_s": 0.0},
                                   cloth={"material": "cotton"}))  # fmt: skip
    with pytest.raises(SimulationDiverged, match=r"step \d+"):
        run_scene(scene, progress=False)


@pytest.mark.slow
def test_cli_run_writes_mesh_with_uvs_image_and_metrics(tmp_path):
    path = write_toml(tmp_path / "tiny.toml", GOOD)
    out = tmp_path / "out"
    proc = subprocess.run(
        [sys.executable, "-m", "sandbox", "run", str(path), "--out", str(out)],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    metrics = json.loads((out / "metrics.json").read_text())
    for key in (
        "vertex_count",
        "triangle_count",
        "steps",
        "sim_time_s",
        "wall_time_s",
        "compile_time_s",
        "converged",
        "max_displacement_m",
        "mean_displacement_m",
    ):
        assert key in metrics, key  # fmt: skip
    assert metrics["steps"] > 0 and metrics["vertex_count"] > 10
    assert metrics["intersecting_triangle_pairs"] == 0  # a small hanging sheet
    assert metrics["penetration_max_m"] is None  # nothing to be inside of
    obj = (out / "mesh.obj").read_text()
    assert obj.count("\nvt ") + obj.startswith("vt ") == metrics["vertex_count"]
    assert (out / "mesh.ply").stat().st_size > 0
    import imageio.v3 as iio

    img = iio.imread(out / "render.png")
    assert img.ndim == 3 and (img[..., :3] < 250).any()  # something was drawn
    assert not list(out.glob(".*"))  # no temporary files left behind


def test_scene_file_roundtrip_of_every_documented_key(tmp_path):
    text = (
        GOOD
        + """
grain_deg = 15.0
origin_m = [0.0, 1.0, 0.0]
rotation_deg = [0.0, 30.0, 0.0]
velocity_m_s = [0.0, 0.0, 0.1]
mesher = "irregular"
"""
    )
    spec = load_scene(write_toml(tmp_path / "all.toml", text))
    c = spec.cloths[0]
    assert c.grain_deg == 15.0 and c.rotation_deg == (0.0, 30.0, 0.0)
    assert spec.simulation.dt_s == 5e-4 and math.isclose(spec.stop.time_limit_s, 0.2)
    assert scene_from_dict(sheet_scene(), source="x").cloths[0].material.name == "jersey"
