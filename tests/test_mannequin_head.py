"""The mannequin's optional head (sandbox.mannequin.head): what a hood rests on."""

import numpy as np
import pytest
import trimesh

from sandbox.errors import SandboxError
from sandbox.garment import make_mannequin


def test_a_head_sits_on_the_neck_and_changes_nothing_else():
    """A closed surface of its own, crown the length asked above the nape, its base inside
    the neck; the body's vertices, triangles and seven measurements are those without it,
    and a resize keeps it."""
    a = make_mannequin(12)
    b = make_mannequin(12, head_length_cm=26.0)
    n, t = len(a.vertices), len(a.triangles)
    assert b.head_length_cm == 26.0 and a.head_length_cm is None
    assert np.array_equal(a.vertices, b.vertices[:n])
    assert np.array_equal(a.triangles, b.triangles[:t])
    for k, v in a.measure().items():
        assert b.measure()[k] == pytest.approx(v, abs=1e-9), k
    head = trimesh.Trimesh(b.vertices[n:], b.triangles[t:] - n, process=False)
    assert head.is_watertight and head.volume > 0  # closed, outward
    nape = a.landmarks["back_neck_point"][1]
    assert head.bounds[1, 1] == pytest.approx(nape + 0.26, abs=1e-3)  # the crown
    neck_top = a.vertices[:, 1].max()
    assert nape < head.bounds[0, 1] < neck_top  # its base sunk into the neck
    assert 0.13 < np.ptp(head.vertices[:, 0]) < 0.17  # a head's breadth
    c = b.resize(b.measurements_requested.replace(bust_girth=92.0))
    assert c.head_length_cm == 26.0 and len(c.vertices) == len(b.vertices)


def test_a_head_out_of_range_is_refused():
    with pytest.raises(SandboxError, match="head length 60 cm: the mannequin's head can be"):
        make_mannequin(12, head_length_cm=60)
