"""Untangling crossing cloth (sandbox.collision.untangle): a spike through a sheet is
smoothed away, sewn pairs are not crossings, a clean mesh is left alone."""

import numpy as np

from sandbox.collision.metrics import count_intersecting_pairs
from sandbox.collision.untangle import untangle_positions
from sandbox.pattern.mesh2d import mesh_grid


def _two_sheets(spike_m: float):
    """Sheet A (8 x 8 cm, y = 0) and sheet B (4 x 4 cm, y = 5 mm above A's middle) with
    B's middle vertex pulled down to y = -spike_m (through A when spike_m > 0)."""
    pa, ta = mesh_grid(0.08, 0.08, 0.01)
    pb, tb = mesh_grid(0.04, 0.04, 0.01)
    pb = pb + 0.02
    xa = np.c_[pa[:, 0], np.zeros(len(pa)), pa[:, 1]]
    xb = np.c_[pb[:, 0], np.full(len(pb), 0.005), pb[:, 1]]
    mid = int(np.argmin(np.linalg.norm(pb - 0.04, axis=1)))
    xb[mid, 1] = -spike_m
    x = np.vstack([xa, xb])
    tri = np.vstack([ta, tb + len(pa)])
    uv = np.vstack([pa, pb])
    return x, tri, uv, len(pa) + mid


def test_a_spike_through_a_sheet_is_smoothed_away():
    x, tri, uv, spike = _two_sheets(0.004)
    assert count_intersecting_pairs(x, tri) > 0
    new, before, after, moved = untangle_positions(x, tri, uv)
    assert before > 0 and after == 0
    assert count_intersecting_pairs(new, tri) == 0
    assert moved[spike]
    assert new[spike, 1] > 0.0  # back above sheet A
    # sheet A was flat and stays so; nothing far from the spike moved
    n_a = len(x) - 25
    assert np.allclose(new[:n_a, 1], 0.0, atol=1e-12)
    far = np.linalg.norm(x[:, [0, 2]] - x[spike, [0, 2]], axis=1) > 0.035
    assert np.allclose(new[far], x[far])


def test_clean_cloth_is_left_alone_and_sewn_pairs_are_not_crossings():
    x, tri, uv, _ = _two_sheets(-0.005)  # spike up: no crossing
    new, before, after, moved = untangle_positions(x, tri, uv)
    assert (before, after, int(moved.sum())) == (0, 0, 0)
    assert np.array_equal(new, x)
    # the spike through A, sewn to A's vertex under it: their triangles do not count
    x, tri, uv, spike = _two_sheets(0.004)
    under = int(np.argmin(np.linalg.norm(x[:81] - x[spike] * [1, 0, 1], axis=1)))
    sewn = np.array([[under, spike]])
    crossing = count_intersecting_pairs(x, tri)
    left = count_intersecting_pairs(x, tri, exclude_vertex_pairs=sewn)
    assert left < crossing
    _, before, _, _ = untangle_positions(x, tri, uv, seam_pairs=sewn)
    assert before == left


def test_the_push_out_is_applied_to_the_moved_vertices_only():
    x, tri, uv, spike = _two_sheets(0.004)
    calls = []

    def push_out(y, mask):
        calls.append(int(mask.sum()))
        y = y.copy()
        y[mask, 1] = np.maximum(y[mask, 1], -1e-3)  # a floor 1 mm below sheet A
        return y

    new, _, after, moved = untangle_positions(x, tri, uv, push_out)
    assert after == 0 and calls and max(calls) == int(moved.sum())
    assert new[:, 1].min() >= -1e-3


class _State:
    def __init__(self, x, v):
        self.x, self.v = x.copy(), v.copy()

    def positions(self):
        return self.x.copy()

    def velocities(self):
        return self.v.copy()

    def set(self, x, v=None):
        self.x, self.v = np.array(x), np.array(v)


def test_the_drape_untangles_its_state_in_place_and_stops_the_moved_vertices():
    """``untangle_state`` (the drape's pass after sewing): positions fixed in the scene's
    state, the moved vertices' velocities zeroed, the others' kept, a record returned."""
    from types import SimpleNamespace

    from sandbox.garment.repair import untangle_state

    x, tri, uv, spike = _two_sheets(0.004)
    v = np.full_like(x, 0.1)
    model = SimpleNamespace(tri_indices_np=tri, rest_uv_np=uv, seam_pairs_np=None)
    scene = SimpleNamespace(model=model, state=_State(x, v), garment=None)
    rec = untangle_state(scene, "after sewing")
    assert rec["when"] == "after sewing" and rec["pairs_before"] > 0 and rec["pairs_after"] == 0
    assert count_intersecting_pairs(scene.state.x, tri) == 0
    moved = np.any(scene.state.x != x, axis=1)
    assert rec["vertices_moved"] >= moved.sum() > 0
    assert 0.004 < rec["largest_move_m"] < 0.015  # the spike is 9 mm deep
    assert np.all(scene.state.v[moved] == 0.0)
    assert np.all(scene.state.v[~np.any(scene.state.v == 0.0, axis=1)] == 0.1)
    # nothing to do: the state is left as it is
    again = untangle_state(scene, "after the drape")
    assert again["pairs_before"] == again["pairs_after"] == again["vertices_moved"] == 0


def test_a_drape_ending_tangled_is_untangled_and_settled_with_the_seam_zone_narrowed(
    monkeypatch,
):
    """``run_drape``'s repair: a drape that ends with crossing pairs is untangled and
    settled again with the self-collision's seam exclusion narrowed to the partners
    (``RepairConfig.narrow_seam_exclusion``); one that ends without any is left alone."""
    import dataclasses
    from types import SimpleNamespace

    import sandbox.garment.pipeline as drape_mod
    import sandbox.garment.repair as repair_mod
    import sandbox.scene.run as run_mod
    from sandbox.garment import DrapeConfig

    @dataclasses.dataclass
    class Stop:
        min_time_s: float = 0.5
        time_limit_s: float = 8.0
        wall_limit_s: float = 1800.0

    @dataclasses.dataclass
    class Spec:
        stop: Stop

    calls = []

    class Collider:
        narrowed = False

        def set_seam_partners(self, pairs, neighbours=True):
            calls.append(("partners", neighbours))
            self.narrowed = not neighbours

    def scene(pairs_at_end):
        collider = Collider()
        runs = iter(pairs_at_end)

        def fake_run(sc, progress=None):
            calls.append(("run", collider.narrowed, sc.spec.stop.min_time_s))
            m = {
                "intersecting_triangle_pairs": next(runs),
                "sim_time_s": 1.0,
                "wall_time_s": 10.0,
                "steps": 1,
                "frames": 30,
                "compile_time_s": 0.0,
            }
            return SimpleNamespace(metrics=m)

        monkeypatch.setattr(run_mod, "run_scene", fake_run)
        model = SimpleNamespace(seam_count=4, seam_pairs_np=np.array([[0, 1], [2, 3]]),
                                strain_damping_s={None: 0.0})  # fmt: skip
        return SimpleNamespace(spec=Spec(Stop()), model=model,
                               solver=SimpleNamespace(self_collider=collider),
                               garment=SimpleNamespace(config=DrapeConfig()))  # fmt: skip

    monkeypatch.setattr(drape_mod, "sew", lambda sc, config: {"sew_wall_time_s": 1.0})

    def fake_untangle(sc, when="", config=None):
        return {"when": when, "pairs_before": 2, "pairs_after": 0}

    monkeypatch.setattr(drape_mod, "untangle_state", fake_untangle)
    monkeypatch.setattr(repair_mod, "untangle_state", fake_untangle)
    res = drape_mod.run_drape(scene([2, 0]))
    assert calls == [("run", False, 0.5), ("partners", False), ("run", True, 0.2)]
    assert res.metrics["intersecting_triangle_pairs"] == 0
    assert res.metrics["untangle"][1]["narrowed_seam_exclusion"]
    assert res.metrics["sim_time_s"] == 2.0 and res.metrics["total_wall_time_s"] == 21.0
    calls.clear()
    drape_mod.run_drape(scene([0]))
    assert calls == [("run", False, 0.5)]  # nothing crossed: nothing narrowed
