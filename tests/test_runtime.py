"""sandbox.runtime: Taichi's field trees are recycled between independent scenes."""

import numpy as np
import pytest
import taichi as ti

from sandbox import runtime
from sandbox.scene.build import build_scene
from sandbox.scene.spec import scene_from_dict


def _scene():
    return build_scene(scene_from_dict({
        "scene": {"name": "trees"},
        "cloth": [{"name": "c", "size_m": [0.1, 0.1], "edge_length_m": 0.05,
                   "mesher": "grid", "material": "denim", "pins": [{"side": "top"}]}],
    }, source="test_runtime"))  # fmt: skip


@pytest.mark.slow
def test_many_field_trees_in_one_process_are_recycled():
    # 700 trees is past Taichi's limit of 512 (which crashed the report and the suite)
    made = 0
    for k in range(700):
        if runtime.recycle():
            made += 1
        f = ti.field(float, shape=2)
        f[0] = float(k)  # a write materialises the field as a tree of its own
        assert runtime.snode_trees() <= runtime.RECYCLE_AT + 1
    assert made >= 1
    sc = _scene()  # a scene after a recycle builds and runs
    sc.solver.advance(sc.state, sc.control, sc.dt_s, 3)
    assert np.isfinite(sc.state.positions()).all()
    assert ti.lang.impl.get_runtime().default_fp == ti.f64  # the precision was kept


def test_recycle_below_the_threshold_keeps_everything():
    sc = _scene()
    assert runtime.recycle(threshold=runtime.MAX_SNODE_TREES) is False
    sc.solver.advance(sc.state, sc.control, sc.dt_s, 2)  # still valid
    assert np.isfinite(sc.state.positions()).all()


def test_every_command_simulates_in_float64_unless_asked_for_float32():
    # float32 left stiff 1 cm garments shaking in place (sandbox.precision.DEFAULT_FLOAT64)
    from sandbox.app.cli import build_parser as gui_parser
    from sandbox.cli import build_parser

    p = build_parser()
    for argv in (["drape", "t-shirt"], ["gallery"], ["demo"],
                 ["validate", "cantilever"], ["run", "s.toml", "--out", "o"]):  # fmt: skip
        assert p.parse_args(argv).float64 is True, argv
        assert p.parse_args([*argv, "--float32"]).float64 is False, argv
    assert gui_parser().parse_args([]).float64 is True
    assert gui_parser().parse_args(["--float32"]).float64 is False
    assert runtime.DEFAULT_FLOAT64 is True


def test_a_compilation_error_still_names_the_file_line_and_source():
    """The front end's shortcuts (source read once per function, short positions) keep what
    a compilation error tells: the file, the line, the function and the source line."""
    from taichi.lang import kernel_impl

    runtime.ensure_init()
    assert getattr(kernel_impl._get_tree_and_ctx, "_sandbox_cached", False)

    @ti.func
    def twice(a):
        return 2.0 * a

    @ti.kernel
    def good() -> float:
        return twice(1.5) + twice(0.25)  # the same function inlined twice

    assert good() == pytest.approx(3.5)

    @ti.kernel
    def bad() -> float:
        return twice(undefined_name)  # noqa: F821

    with pytest.raises(Exception) as err:
        bad()
    text = str(err.value)
    assert "test_runtime.py" in text and "undefined_name" in text and "bad" in text
