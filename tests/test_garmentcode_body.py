"""GarmentCode body files mapped onto the seven measurements (docs/garmentcode.md)."""

from pathlib import Path

import pytest

from sandbox import runtime
from sandbox.cli import main
from sandbox.errors import SandboxError
from sandbox.pattern.garmentcode_body import load_garmentcode_body

BODIES = Path(__file__).parent / "data" / "garmentcode" / "bodies"


def test_the_default_body_maps_onto_size_18_with_its_girths():
    body = load_garmentcode_body(BODIES / "mean_all.yaml")
    m = body.measurements
    assert (m["bust_girth"], m["waist_girth"], m["hip_girth"]) == (99.8407, 84.3338, 103.478)
    assert body.size == 18  # Aldrich 18: bust 100, waist 80 (closest by the three girths)
    assert m["back_length"] == 37.0  # nape to waist 36.89 cm, clamped onto 37-46 cm
    assert any("waist_line 36.8913 cm clamped" in n for n in body.notes)
    assert any(n.startswith("shoulder_length 13 cm: from size 18") for n in body.notes)
    assert any("arm_length" in n and "no counterpart" in n for n in body.notes)
    # GarmentCode's arm pose is below the horizontal; ours from the vertical
    assert body.arm_angle_deg == pytest.approx(90.0 - 45.483)
    assert any(n.startswith("arms at 44.517 deg from the vertical") for n in body.notes)
    assert not any("arm_pose_angle" in n and "no counterpart" in n for n in body.notes)
    # its head: the crown head_l above the nape
    assert body.head_length_cm == pytest.approx(26.3262)
    assert any(n.startswith("a head, its crown 26.3262 cm above the nape") for n in body.notes)
    assert not any("head_l" in n and "no counterpart" in n for n in body.notes)


def test_a_posed_mannequin_keeps_its_measurements_and_its_pose():
    """The arms open to the angle asked; the torso, its seven measurements and the
    triangles stay; a resize keeps the pose; an angle out of range is refused."""
    from sandbox.garment import make_mannequin

    a = make_mannequin(18)
    b = make_mannequin(18, arm_angle_deg=44.5)
    assert b.arm_angle_deg == pytest.approx(44.5) and a.arm_angle_deg == pytest.approx(16.0)
    assert (a.triangles == b.triangles).all()
    for k, v in a.measure().items():
        assert b.measure()[k] == pytest.approx(v, abs=1e-6), k
    hand = b.vertices[:, 0].max() - a.vertices[:, 0].max()
    assert 0.03 < hand < 0.1  # the left hand 3-10 cm further out
    c = b.resize(b.measurements_requested.replace(bust_girth=104.0))
    assert c.arm_angle_deg == pytest.approx(44.5)
    with pytest.raises(SandboxError, match="arm angle 80 deg: the mannequin's arms can be posed"):
        make_mannequin(12, arm_angle_deg=80)


@pytest.mark.parametrize("name", sorted(p.name for p in BODIES.glob("*.yaml")))
def test_every_vendored_body_maps_inside_the_supported_ranges(name):
    from sandbox.mannequin.measurements import SUPPORTED_RANGE_CM

    m = load_garmentcode_body(BODIES / name).measurements
    assert all(lo <= m[k] <= hi for k, (lo, hi) in SUPPORTED_RANGE_CM.items())


@pytest.mark.parametrize(
    "text, needle",
    [
        ("body: [1, 2]", "a 'body:' mapping"),
        ("body: {bust: 90, waist: 70, hips: 95}", "body.waist_line: missing"),
        ("body: {bust: x, waist: 70, hips: 95, waist_line: 40}", "body.bust: must be a finite"),
        ("body: {bust: 190, waist: 70, hips: 95, waist_line: 40}",
         "body.bust: 190 cm is outside the mannequin's supported bust girth of 72-130 cm"),
        ("body: {bust: 90\n  waist: [", "not valid YAML"),
    ],
)  # fmt: skip
def test_bad_body_files_are_named(tmp_path, text, needle):
    f = tmp_path / "b.yaml"
    f.write_text(text)
    with pytest.raises(SandboxError, match="b.yaml") as err:
        load_garmentcode_body(f)
    assert needle in str(err.value)


def test_drape_refuses_a_body_file_with_a_size_before_taichi_starts(tmp_path, capsys,
                                                                     monkeypatch):  # fmt: skip
    def trap(*a, **k):
        raise AssertionError("Taichi started")

    monkeypatch.setattr(runtime, "init", trap)
    rc = main(["drape", "pencil-skirt", "--garmentcode-body", str(BODIES / "mean_all.yaml"),
               "--size", "12", "--out", str(tmp_path / "o")])  # fmt: skip
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "drop --size" in err and "\n" not in err
    rc = main(["drape", "pencil-skirt", "--garmentcode-body", str(tmp_path / "none.yaml"),
               "--out", str(tmp_path / "o")])  # fmt: skip
    assert rc == 2 and "no such body file" in capsys.readouterr().err
