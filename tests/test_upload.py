"""sandbox.sim.upload: many numpy arrays into Taichi fields in one launch."""

import numpy as np
import pytest
import taichi as ti

from sandbox import runtime
from sandbox.sim.upload import upload


def test_fields_of_every_kind_get_their_arrays_exactly():
    runtime.ensure_init()
    a = ti.field(float, shape=5)
    b = ti.Vector.field(3, ti.i32, shape=4)
    c = ti.Matrix.field(2, 2, float, shape=3)
    d = ti.field(ti.i32, shape=6)
    va = np.linspace(0.5, 2.5, 5)
    vb = np.arange(12).reshape(4, 3)
    vc = np.arange(12.0).reshape(3, 2, 2) / 7.0
    upload([(a, va), (b, vb), (c, vc), (d, np.array([4, 5])), (a, np.zeros(0))])
    np.testing.assert_array_equal(a.to_numpy(), va)
    np.testing.assert_array_equal(b.to_numpy(), vb)
    np.testing.assert_allclose(c.to_numpy(), vc, rtol=1e-15)
    np.testing.assert_array_equal(d.to_numpy()[:2], [4, 5])  # a shorter array fills the start
    assert not d.to_numpy()[2:].any()


def test_an_array_that_does_not_fit_its_field_is_refused():
    runtime.ensure_init()
    b = ti.Vector.field(3, float, shape=2)
    with pytest.raises(ValueError, match="does not fit"):
        upload([(b, np.zeros((2, 2)))])
    with pytest.raises(ValueError, match="does not fit"):
        upload([(b, np.zeros((3, 3)))])
