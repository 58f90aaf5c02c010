"""python -m sandbox render: lit, smooth-shaded views and a turntable of a saved result."""

import numpy as np
import pytest
import trimesh

from sandbox.errors import SandboxError
from sandbox.render import write_mesh
from sandbox.render.studio import main


@pytest.fixture
def result(tmp_path):
    body = trimesh.creation.capsule(height=1.2, radius=0.15, count=[24, 24])
    body.apply_translation([0, 0.9, 0])
    write_mesh(tmp_path / "body.obj", body.vertices, body.faces)
    tube = trimesh.creation.cylinder(radius=0.2, height=0.5, sections=32)
    keep = np.abs(tube.face_normals[:, 1]) < 0.5  # the side only: an open skirt-like tube
    tube = trimesh.Trimesh(tube.vertices, tube.faces[keep], process=False)
    tube.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    tube.apply_translation([0, 0.8, 0])
    write_mesh(tmp_path / "garment.obj", tube.vertices, tube.faces)
    return tmp_path


def test_views_and_turntable_show_garment_and_body(result):
    import imageio.v3 as iio

    out = result / "renders"
    assert main([str(result), "--size", "160", "160", "--turntable", "4", "--mp4",
                 "--out", str(out)]) == 0  # fmt: skip
    front = iio.imread(out / "studio_front.png")
    side = iio.imread(out / "studio_side.png")
    assert front.shape == (160, 160, 3)
    not_bg = np.abs(front.astype(int) - 255).sum(-1) > 30
    blue = (front[..., 2].astype(int) - front[..., 0] > 60) & not_bg
    skin = (front[..., 0].astype(int) - front[..., 2] > 20) & not_bg
    assert not_bg.mean() > 0.05 and blue.sum() > 100 and skin.sum() > 100
    assert np.abs(front.astype(int) - side.astype(int)).mean() > 1.0  # another view
    # smooth shading: the garment's blues take many values, not one flat colour
    assert len(np.unique(front[blue][:, 2])) > 10
    assert len(iio.imread(out / "turntable.gif")) == 4
    assert (out / "turntable.mp4").stat().st_size > 1000


def test_missing_inputs_are_named(tmp_path, capsys):
    assert main([str(tmp_path / "nothere")]) == 2
    assert "no such result directory" in capsys.readouterr().err
    assert main([str(tmp_path)]) == 2
    assert "no garment mesh" in capsys.readouterr().err
    from sandbox.render.studio import Studio

    with pytest.raises(SandboxError, match="unknown view"):
        Studio((np.eye(3), np.array([[0, 1, 2]])), size=(32, 32), backend="numpy").view("top")
