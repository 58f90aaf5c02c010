"""Cloth against itself (Bridson, Fedkiw and Anderson 2002): the cloth never crosses itself."""

import numpy as np
import pytest
import taichi as ti
import trimesh

from sandbox.collision.metrics import count_intersecting_pairs
from sandbox.collision.primitives import (
    coplanar_times,
    point_triangle_closest,
    segment_segment_closest,
)
from sandbox.collision.self_contact import SelfCollider
from sandbox.pattern.mesh2d import mesh_grid
from sandbox.scene.build import build_scene
from sandbox.scene.run import run_scene
from sandbox.scene.spec import scene_from_dict
from sandbox.sim.builder import ModelBuilder
from sandbox.sim.materials import material_from_spec
from sandbox.sim.solver import SymplecticEulerSolver
from tests.helpers import sheet_spec

RNG = np.random.default_rng(7)


# ---------------------------------------------------------------- primitives
@ti.kernel
def _closest_kernel(p: ti.types.ndarray(), tri: ti.types.ndarray(), out: ti.types.ndarray()):
    for i in range(p.shape[0]):
        x = ti.Vector([p[i, 0], p[i, 1], p[i, 2]], ti.f64)
        a = ti.Vector([tri[i, 0, 0], tri[i, 0, 1], tri[i, 0, 2]], ti.f64)
        b = ti.Vector([tri[i, 1, 0], tri[i, 1, 1], tri[i, 1, 2]], ti.f64)
        c = ti.Vector([tri[i, 2, 0], tri[i, 2, 1], tri[i, 2, 2]], ti.f64)
        w = point_triangle_closest(x, a, b, c)
        q = w[0] * a + w[1] * b + w[2] * c
        for k in ti.static(range(3)):
            out[i, k] = q[k]


def test_point_triangle_closest_matches_trimesh():
    n = 400
    tri = RNG.normal(size=(n, 3, 3))
    tri[: n // 4, 2] = tri[: n // 4, 0] + 1e-3 * RNG.normal(size=(n // 4, 3))  # slivers
    p = RNG.normal(size=(n, 3)) * 1.5
    out = np.zeros((n, 3))
    _closest_kernel(p, tri, out)
    ref = trimesh.triangles.closest_point(tri, p)
    dist = np.linalg.norm(ref - p, axis=1)
    assert np.allclose(np.linalg.norm(out - p, axis=1), dist, atol=1e-9)


@ti.kernel
def _segments_kernel(s: ti.types.ndarray(), out: ti.types.ndarray()):
    for i in range(s.shape[0]):
        p0 = ti.Vector([s[i, 0, 0], s[i, 0, 1], s[i, 0, 2]], ti.f64)
        p1 = ti.Vector([s[i, 1, 0], s[i, 1, 1], s[i, 1, 2]], ti.f64)
        q0 = ti.Vector([s[i, 2, 0], s[i, 2, 1], s[i, 2, 2]], ti.f64)
        q1 = ti.Vector([s[i, 3, 0], s[i, 3, 1], s[i, 3, 2]], ti.f64)
        a, b = segment_segment_closest(p0, p1, q0, q1)
        out[i] = ((p0 + a * (p1 - p0)) - (q0 + b * (q1 - q0))).norm()


def test_segment_distance_matches_brute_force():
    n = 200
    s = RNG.normal(size=(n, 4, 3))
    s[:20, 1] = s[:20, 0]  # a point against a segment
    s[20:40, 3] = s[20:40, 2] + 2.0 * (s[20:40, 1] - s[20:40, 0])  # parallel segments
    out = np.zeros(n)
    _segments_kernel(s, out)
    t = np.linspace(0.0, 1.0, 401)
    for i in range(n):
        a = s[i, 0] + t[:, None] * (s[i, 1] - s[i, 0])
        b = s[i, 2] + t[:, None] * (s[i, 3] - s[i, 2])
        brute = np.linalg.norm(a[:, None] - b[None], axis=2).min()
        assert out[i] <= brute + 1e-12
        assert out[i] >= brute - 1e-2 * max(1.0, brute)


@ti.kernel
def _coplanar_kernel(x: ti.types.ndarray(), u: ti.types.ndarray(), out: ti.types.ndarray()):
    for i in range(x.shape[0]):
        p = ti.Matrix.zero(ti.f64, 4, 3)
        q = ti.Matrix.zero(ti.f64, 4, 3)
        for k, j in ti.static(ti.ndrange(4, 3)):
            p[k, j] = x[i, k, j]
            q[k, j] = u[i, k, j]
        roots, count = coplanar_times(
            ti.Vector([p[0, 0], p[0, 1], p[0, 2]]), ti.Vector([p[1, 0], p[1, 1], p[1, 2]]),
            ti.Vector([p[2, 0], p[2, 1], p[2, 2]]), ti.Vector([p[3, 0], p[3, 1], p[3, 2]]),
            ti.Vector([q[0, 0], q[0, 1], q[0, 2]]), ti.Vector([q[1, 0], q[1, 1], q[1, 2]]),
            ti.Vector([q[2, 0], q[2, 1], q[2, 2]]), ti.Vector([q[3, 0], q[3, 1], q[3, 2]]),
        )  # fmt: skip
        for k in ti.static(range(3)):
            out[i, k] = roots[k] if k < count else 2.0


def test_coplanarity_times_are_the_roots_of_the_cubic():
    n = 300
    x = RNG.normal(size=(n, 4, 3))
    u = 2.0 * RNG.normal(size=(n, 4, 3))
    out = np.zeros((n, 3))
    _coplanar_kernel(x, u, out)

    def volume(i, t):
        y = x[i] + t * u[i]
        return np.dot(np.cross(y[1] - y[0], y[2] - y[0]), y[3] - y[0])

    found = 0
    for i in range(n):
        ts = np.array([0.0, 1 / 3, 2 / 3, 1.0])
        coeff = np.polyfit(ts, [volume(i, t) for t in ts], 3)
        ref = np.sort([r.real for r in np.roots(coeff) if abs(r.imag) < 1e-9 and 0 <= r.real <= 1])
        got = np.sort(out[i][out[i] <= 1.0])
        found += len(ref)
        assert len(got) == len(ref), (i, got, ref)
        assert np.allclose(got, ref, atol=1e-7)
    assert found > 50  # the random set has many crossings


# ---------------------------------------------------------------- the scene switch
@pytest.mark.slow
def test_self_collision_is_built_only_when_the_scene_asks():
    ball = [{"name": "ball", "shape": "sphere", "center_m": [0, -0.3, 0], "radius_m": 0.1}]
    assert build_scene(sheet_spec()).model.self_collider is None  # nothing to collide with
    on = build_scene(_with(collider=ball))
    assert on.model.self_collider is not None
    off = build_scene(_with(collider=ball, collision={"self_collision": False}))
    assert off.model.self_collider is None
    alone = build_scene(_with(collision={"self_collision": True}))
    assert alone.model.self_collider is not None  # asked for without any collider


def _with(collider=None, collision=None):
    from tests.helpers import sheet_scene

    data = sheet_scene(collision=collision or {})
    if collider:
        data["collider"] = collider
    return scene_from_dict(data, source="self_test.toml")


# ---------------------------------------------------------------- two pieces, one step
def two_squares(*, pinned_bottom: bool, speed: float, far_piece_m: float | None = None):
    """A 20 cm square in the xz plane at y = 0 and a 6 cm square 2 cm above, moving down
    (and, with ``far_piece_m``, a third 6 cm square that far away along x)."""
    builder = ModelBuilder()
    mat = material_from_spec("jersey", where="test")
    uv, tris = mesh_grid(0.2, 0.2, 0.02)
    rot = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])  # pattern y -> world +z
    pins = np.full(len(uv), pinned_bottom)
    builder.add_cloth(name="bottom", pattern_uv=uv, triangles=tris, material=mat, rotation=rot,
                      translation=(-0.1, 0.0, -0.1), pinned=pins)  # fmt: skip
    uv2, tris2 = mesh_grid(0.06, 0.06, 0.02)
    builder.add_cloth(name="top", pattern_uv=uv2, triangles=tris2, material=mat, rotation=rot,
                      translation=(-0.03, 0.02, -0.03), velocity=(0.0, -speed, 0.0))  # fmt: skip
    if far_piece_m is not None:
        builder.add_cloth(name="far", pattern_uv=uv2, triangles=tris2, material=mat,
                          rotation=rot, translation=(far_piece_m, 0.0, 0.0))  # fmt: skip
    model = builder.finalize(bending=False)
    model.self_collider = SelfCollider(model, thickness_m=0.003, friction=0.3)
    return model, len(uv)


def momentum(model, v):
    return (model.mass_np[:, None] * v).sum(axis=0)


@pytest.mark.slow
@pytest.mark.parametrize("pinned", [True, False])
def test_fast_piece_does_not_pass_through_a_sheet_in_one_large_step(pinned):
    """10 m/s with dt = 10 ms: the top square would move 10 cm, through the bottom one."""
    model, n_bottom = two_squares(pinned_bottom=pinned, speed=10.0)
    solver = SymplecticEulerSolver(model)
    state = model.state()
    control = model.control(gravity=(0.0, 0.0, 0.0))
    p0 = momentum(model, state.velocities())
    solver.step(state, state, control, 0.01)
    x = state.positions()
    assert np.isfinite(x).all()
    assert count_intersecting_pairs(x, model.tri_indices_np) == 0
    if pinned:  # the bottom sheet does not move: the piece stops on top of it
        assert x[n_bottom:, 1].min() > 0.0
    else:  # impulses between free vertices conserve momentum
        assert np.allclose(momentum(model, state.velocities()), p0, atol=1e-12)


@pytest.mark.slow
def test_a_piece_far_away_coarsens_the_grid_and_contact_still_holds():
    """The candidate grid spans the cloth's bounding box with a fixed cell count: a piece
    2 km away makes its cells coarse, yet the fast piece still stops on the
    sheet."""
    model, n_bottom = two_squares(pinned_bottom=True, speed=10.0, far_piece_m=2000.0)
    sc = model.self_collider
    solver = SymplecticEulerSolver(model)
    state = model.state()
    solver.step(state, state, model.control(gravity=(0.0, 0.0, 0.0)), 0.01)
    x = state.positions()
    assert sc.cell[None] > 0.1  # metres: far coarser than the 2 cm mesh (0.03 m alone)
    assert sc.pair_count[None] > 0
    assert np.isfinite(x).all()
    assert count_intersecting_pairs(x, model.tri_indices_np) == 0
    n_top = (len(x) - n_bottom) // 2  # the moving piece, then the far one (same mesh)
    assert x[n_bottom : n_bottom + n_top, 1].min() > 0.0


@pytest.mark.slow
def test_rigid_impact_zones_resolve_what_the_impulses_leave():
    """The fail-safe alone (no CCD impulse pass): zones leave no crossing, momentum kept."""
    model, n_bottom = two_squares(pinned_bottom=False, speed=10.0)
    sc = model.self_collider
    state = model.state()
    dt = 0.01
    p0 = momentum(model, state.velocities())
    sc._prepare_kernel(state.x, state.v, dt)
    sc._rebuild_kernel(state.x, state.v, dt)
    assert sc._mark_kernel(state.x, state.v, dt) > 0  # the motion crosses
    sc.resolve_zones(state.x, state.v, dt)
    assert sc._mark_kernel(state.x, state.v, dt) == 0
    assert np.allclose(momentum(model, state.velocities()), p0, atol=1e-12)
    x_end = state.positions() + dt * (state.velocities() + sc.corr.to_numpy())
    assert count_intersecting_pairs(x_end, model.tri_indices_np) == 0


@pytest.mark.slow
def test_zones_that_do_not_resolve_are_stopped_for_the_step_instead_of_aborting():
    """With no rounds of rigid zones allowed, the step still ends free of collisions: the
    colliding vertices stand still for it, and the step is counted."""
    import dataclasses

    from sandbox.collision.self_contact_config import SelfContactConfig

    model, n_bottom = two_squares(pinned_bottom=False, speed=10.0)
    config = dataclasses.replace(SelfContactConfig(), zone_rounds=0)
    sc = model.self_collider = SelfCollider(model, thickness_m=0.003, friction=0.3,
                                            config=config)  # fmt: skip
    state = model.state()
    dt = 0.01
    sc._prepare_kernel(state.x, state.v, dt)
    sc._rebuild_kernel(state.x, state.v, dt)
    assert sc._mark_kernel(state.x, state.v, dt) > 0
    sc.resolve_zones(state.x, state.v, dt)
    assert sc._mark_kernel(state.x, state.v, dt) == 0
    counts = sc.collision_counts()
    assert counts["freeze_steps"] == 1
    assert 0 < counts["frozen_vertices_max"] < model.particle_count
    x_end = state.positions() + dt * (state.velocities() + sc.corr.to_numpy())
    assert count_intersecting_pairs(x_end, model.tri_indices_np) == 0


# ---------------------------------------------------------------- the scenes
@pytest.mark.slow
def test_sheet_dropped_on_the_floor_piles_in_folds_without_crossing_itself():
    data = {
        "scene": {"name": "floor_pile"},
        "simulation": {"damping_per_s": 0.5},
        "stop": {"time_limit_s": 1.5, "min_time_s": 1.0},
        "collision": {"thickness_m": 0.003},
        "cloth": [
            {
                "name": "sheet",
                "size_m": [0.3, 0.45],
                "edge_length_m": 0.025,
                "material": "silk",
                "origin_m": [-0.15, 0.01, 0.0],  # standing, 1 cm over the floor, leaning
                "rotation_deg": [15.0, 0.0, 5.0],
            }
        ],
        "collider": [
            {
                "name": "floor",
                "shape": "plane",
                "point_m": [0, 0, 0],
                "normal": [0, 1, 0],
                "size_m": 2.0,
            }
        ],  # fmt: skip
    }
    sc = build_scene(scene_from_dict(data, source="floor_pile.toml"))
    crossings = []

    def check(scene, frame):
        if frame % 3 == 0:
            x = scene.state.positions()
            crossings.append(count_intersecting_pairs(x, scene.model.tri_indices_np))

    r = run_scene(sc, progress=False, on_frame=check)
    x = r.positions
    assert np.isfinite(x).all()
    assert max(crossings) == 0 and r.metrics["intersecting_triangle_pairs"] == 0
    assert x[:, 1].min() > -1e-3  # on the floor, not through it
    assert x[:, 1].max() < 0.15  # it fell and piled up (it started 46 cm tall)
    assert np.ptp(x[:, 0]) < 0.45  # in folds, within its own footprint


def floor_pile(name: str) -> dict:
    """A 310-vertex silk sheet standing 1 cm over the floor, leaning: it piles in folds."""
    return {
        "scene": {"name": name},
        "simulation": {"damping_per_s": 0.5},
        "collision": {"thickness_m": 0.003},
        "cloth": [{"name": "sheet", "size_m": [0.3, 0.45], "edge_length_m": 0.025,
                   "material": "silk", "origin_m": [-0.15, 0.01, 0.0],
                   "rotation_deg": [15.0, 0.0, 5.0]}],
        "collider": [{"name": "floor", "shape": "plane", "point_m": [0, 0, 0],
                      "normal": [0, 1, 0], "size_m": 2.0}],
    }  # fmt: skip


@pytest.mark.slow
def test_the_same_scene_runs_to_the_same_positions():
    """Scripted runs must be reproducible: the candidate list is put in a fixed order after
    the parallel queries (whose threads append in any order) and the means are summed in
    order. Before that, two runs of this pile differed by up to 2.8 mm after 0.8 s."""
    data = floor_pile("determinism")
    runs = []
    for _ in range(2):
        sc = build_scene(scene_from_dict(data, source="determinism.toml"))
        sc.solver.advance(sc.state, sc.control, sc.dt_s, round(0.8 / sc.dt_s))
        runs.append(sc.state.positions())
    assert np.array_equal(runs[0], runs[1])


@pytest.mark.slow
def test_partial_refreshes_keep_every_pair_closer_than_the_thickness_in_the_list():
    """The candidate list is renewed in part (only the pairs of the few vertices that
    drifted) when the cloth moves slowly. After every step, each pair closer than h must
    still be in it: checked against a list built from scratch at those positions."""
    data = floor_pile("refresh")
    sc = build_scene(scene_from_dict(data, source="refresh.toml"))
    live = sc.model.self_collider
    scratch = SelfCollider(sc.model, thickness_m=0.003, margin_m=1e-6)
    still = sc.model.state()

    def pairs(collider):
        c = collider.pair_count[None]
        rows = np.c_[collider.pair.to_numpy()[:c], collider.pair_kind.to_numpy()[:c]]
        return {tuple(r) for r in rows}

    missing = checks = 0
    for k in range(round(0.8 / sc.dt_s)):
        sc.solver.step(sc.state, sc.state, sc.control, sc.dt_s, k)
        if k % 7 == 0:
            x = sc.state.positions()
            still.set(x, np.zeros_like(x))
            scratch.needs_build[None] = 1
            scratch._prepare_kernel(still.x, still.v, 0.0)
            scratch._rebuild_kernel(still.x, still.v, 0.0)
            missing += len(pairs(scratch) - pairs(live))
            checks += 1
    assert live.refreshes[None] > 20 and checks > 500
    assert missing == 0


def test_rigid_impact_zones_keep_each_zones_momentum_and_move_rigidly():
    """Bridson et al. §7.4: every zone moves as one rigid body with the linear and angular
    momentum its vertices had; a zone holding a pinned vertex stands still."""
    from sandbox.collision.self_contact_zones import _rigid_velocities

    rng = np.random.default_rng(3)
    x = rng.normal(size=(30, 3))
    v = rng.normal(size=(30, 3))
    m = rng.uniform(0.5, 2.0, 30)
    inv_m = 1.0 / m
    zone = np.repeat([4, 9, 2], 10)
    inv_m[25] = 0.0  # zone 2 holds a pinned vertex
    out = _rigid_velocities(x, v, m, inv_m, zone)
    for z in (4, 9):
        s = zone == z
        xc = (m[s, None] * x[s]).sum(0) / m[s].sum()
        assert np.allclose((m[s, None] * out[s]).sum(0), (m[s, None] * v[s]).sum(0))
        r = x[s] - xc
        assert np.allclose((m[s, None] * np.cross(r, out[s])).sum(0),
                           (m[s, None] * np.cross(r, v[s])).sum(0))  # fmt: skip
        d = x[s][:, None] - x[s][None]  # rigid: no pair of vertices approaches or separates
        dv = out[s][:, None] - out[s][None]
        assert np.abs((d * dv).sum(-1)).max() < 1e-12
    assert np.all(out[zone == 2] == 0.0)
