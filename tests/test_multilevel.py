"""Coarse to fine (sandbox/garment/multilevel.py): locating fine vertices in a coarse mesh,
carrying positions, the method's settings and a whole drape."""

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

from sandbox.errors import SandboxError
from sandbox.garment import DrapeConfig
from sandbox.garment.multilevel import _layers_crossed, carry, panel_maps
from sandbox.scene.multilevel import barycentric_locate
from sandbox.sim.inertia import scaled_inertia


def grid(n: int, size: float = 0.3):
    """A square panel of size [m] as an n x n grid of vertices, two triangles a cell."""
    u = np.linspace(0.0, size, n)
    pts = np.stack(np.meshgrid(u, u, indexing="xy"), -1).reshape(-1, 2)
    tris = []
    for j in range(n - 1):
        for i in range(n - 1):
            a = j * n + i
            tris += [[a, a + 1, a + n + 1], [a, a + n + 1, a + n]]
    return SimpleNamespace(points=pts, triangles=np.array(tris))


def affine(uv):
    """A rigid-plus-stretch map of the pattern plane into space [m]."""
    return np.stack([0.9 * uv[:, 0] + 0.1 * uv[:, 1], 0.2 * uv[:, 0] - uv[:, 1] + 1.2,
                     0.3 * uv[:, 0] + 0.05], 1)  # fmt: skip


def test_points_inside_are_found_with_their_barycentric_coordinates():
    coarse = grid(4)
    pts = np.random.default_rng(1).uniform(0.0, 0.3, (200, 2))
    tri, bary = barycentric_locate(pts, coarse.points, coarse.triangles)
    assert (bary >= 0).all()
    np.testing.assert_allclose(bary.sum(1), 1.0)
    back = np.einsum("pk,pkd->pd", bary, coarse.points[coarse.triangles[tri]])
    np.testing.assert_allclose(back, pts, atol=1e-12)


def test_a_point_outside_goes_to_the_nearest_point_of_the_mesh():
    coarse = grid(3, 0.2)
    tri, bary = barycentric_locate(np.array([[0.1, -0.01]]), coarse.points, coarse.triangles)
    back = bary[0] @ coarse.points[coarse.triangles[tri[0]]]
    np.testing.assert_allclose(back, [0.1, 0.0], atol=1e-12)


def test_an_affine_drape_is_carried_exactly():
    """Positions that are an affine function of the pattern coordinates on the coarse mesh
    reach the fine mesh unchanged: the transfer adds no error of its own."""
    coarse, fine = {"p": grid(4)}, {"p": grid(13)}
    maps = panel_maps(coarse, fine)
    moved = carry(maps, coarse, {"p": affine(coarse["p"].points)})
    np.testing.assert_allclose(moved["p"], affine(fine["p"].points), atol=1e-12)


@pytest.mark.parametrize("change, needle", [
    ({"method": "multigrid"}, "method"),
    ({"coarse_edge_m": 0.0}, "coarse_edge_m"),
    ({"fine_damping_per_s": -1.0}, "fine_damping_per_s"),
    ({"fine_residual_mean": 0.0}, "fine_residual_mean"),
    ({"seam_damping_ratio": 1.5}, "seam_damping_ratio"),
    ({"fine_inertia_scale": 0.5}, "fine_inertia_scale"),
    ({"coarse_tangled_fraction": 0.0}, "coarse_tangled_fraction"),
])  # fmt: skip
def test_bad_settings_are_named(change, needle):
    with pytest.raises(SandboxError, match=needle):
        DrapeConfig(**change)


def test_a_coarse_level_in_layers_passed_through_itself_is_draped_again():
    """Crossings above the fraction of the triangles, at rest, without cloth contact: redo;
    a level with contact, one not at rest, or a few crossings: carry on."""
    scene = SimpleNamespace(model=SimpleNamespace(tri_indices_np=np.zeros((1000, 3), int)))
    config = DrapeConfig(self_collision=False)  # as the coarse level; 5 % of 1000: 50 pairs
    at_rest = {"converged": True, "intersecting_triangle_pairs": 51}
    assert _layers_crossed(at_rest, scene, config)
    assert not _layers_crossed({**at_rest, "intersecting_triangle_pairs": 50}, scene, config)
    assert not _layers_crossed({**at_rest, "converged": False}, scene, config)
    assert not _layers_crossed(at_rest, scene, dataclasses.replace(config, self_collision=True))


def _hanging_sheet(damping_per_s: float):
    from sandbox.scene.build import build_scene
    from tests.helpers import sheet_spec

    return build_scene(sheet_spec(simulation={"damping_per_s": damping_per_s}))


def test_scaled_inertia_keeps_the_forces_and_lengthens_the_stable_step():
    """Inertia x 4 with gravity and damping / 4: the same static forces (F + m g) at any
    shape, a stable step twice as long (ω_max halves), everything restored on exit."""
    from sandbox.sim.stability import measured_stable_dt

    sc = _hanging_sheet(60.0)
    f0 = sc.solver.static_forces(sc.state.x, sc.control.gravity)
    dt0 = measured_stable_dt(sc.solver, sc.state, sc.control, sc.model)
    mass0 = sc.model.particle_mass.to_numpy()
    with scaled_inertia(sc, 4.0):
        f4 = sc.solver.static_forces(sc.state.x, sc.control.gravity)
        dt4 = measured_stable_dt(sc.solver, sc.state, sc.control, sc.model)
        assert sc.control.damping_per_s[None] == pytest.approx(15.0)
        np.testing.assert_allclose(sc.model.particle_mass.to_numpy(), 4.0 * mass0)
    np.testing.assert_allclose(f4, f0, rtol=1e-12, atol=1e-15)
    assert dt4 / dt0 == pytest.approx(2.0, rel=1e-6)
    np.testing.assert_array_equal(sc.model.particle_mass.to_numpy(), mass0)
    assert sc.control.damping_per_s[None] == 60.0
    assert sc.control.gravity[None][1] == pytest.approx(-9.80665)


def test_an_overdamped_sheet_settles_to_the_same_shape_with_scaled_inertia():
    """A pinned sheet damped at 60 /s (it swings down over about γ L / g = 1.2 s), run 8 s
    with its own inertia and with inertia x 4 at twice the step: the same rest shape to
    0.1 mm, in half the steps."""
    from sandbox.scene.build import retime

    shapes, steps = [], []
    for s in (1.0, 4.0):
        sc = _hanging_sheet(60.0)
        with scaled_inertia(sc, s):
            retime(sc, sc.dt_limit_s * s**0.5, at_most=s**0.5)
            n = round(8.0 / sc.dt_s)
            sc.solver.advance(sc.state, sc.control, sc.dt_s, n)
        shapes.append(sc.state.positions().astype(np.float64))
        steps.append(n)
    assert steps[1] <= 0.51 * steps[0]
    assert np.abs(shapes[1] - shapes[0]).max() < 1e-4


@pytest.mark.slow
def test_a_coarse_to_fine_drape_meets_the_acceptance_at_rest(tmp_path):
    """The camisole at 2 cm from a 4 cm coarse level: sewn, at rest by the residual, and
    accepted; the metrics tell both levels apart."""
    from sandbox.garment import drape

    config = DrapeConfig(method="coarse_to_fine", coarse_edge_m=0.04)
    r = drape("camisole", out_dir=tmp_path, edge_length_m=0.02, config=config, render=False,
              meshes=False, progress=False)  # fmt: skip
    m = r.metrics
    assert m["method"] == "coarse_to_fine"
    assert m["coarse_vertex_count"] < m["vertex_count"]
    assert m["converged"] and m["meets_acceptance"]
    assert m["residual_mean_over_weight"] < config.fine_residual_mean
    assert m["total_wall_time_s"] >= m["coarse_wall_time_s"] + m["fine_wall_time_s"]


@pytest.mark.slow
def test_a_coarse_level_that_is_not_at_rest_falls_back_to_the_direct_drape(tmp_path):
    """A coarse level stopped by the time limit has no rest shape to carry: the drape is
    direct, and says so, and its wall time includes the coarse level's."""
    import dataclasses

    from sandbox.garment import drape

    base = DrapeConfig(method="coarse_to_fine", coarse_edge_m=0.05, time_limit_s=0.1)
    config = dataclasses.replace(base, sewing=dataclasses.replace(base.sewing, time_limit_s=0.1))
    r = drape("camisole", out_dir=tmp_path, edge_length_m=0.03, config=config, render=False,
              meshes=False, progress=False)  # fmt: skip
    m = r.metrics
    assert m["method"] == "direct"
    assert not m["coarse_converged"] and "draped directly" in m["coarse_fallback"]
    assert m["coarse_vertex_count"] < m["vertex_count"]
    assert m["total_wall_time_s"] >= m["coarse_wall_time_s"] + m["wall_time_s"]


def test_a_triangle_squeezed_flat_does_not_set_the_fine_step():
    """Two neighbours of a hanging sheet pushed to 0.1 mm apart: the dominant eigenvalue is
    negative (a compression instability, not a stiffness) and far larger than the rest
    shape's, so the fine level's limit is the rest shape's bound; the sheet as it hangs
    keeps its measured limit."""
    from sandbox.scene.multilevel import settle_limit
    from sandbox.sim.stability import dominant_eigenvalue, measured_stable_dt

    sc = _hanging_sheet(60.0)
    bound = sc.dt_limit_s
    assert settle_limit(sc, bound) == pytest.approx(
        measured_stable_dt(sc.solver, sc.state, sc.control, sc.model), rel=1e-9
    )
    x = sc.state.positions().astype(np.float64)
    a, b = (int(i) for i in sc.model.tri_indices_np[len(sc.model.tri_indices_np) // 2][:2])
    x[a] = x[b] + 1e-4 * (x[a] - x[b]) / np.linalg.norm(x[a] - x[b])
    sc.state.set(x, np.zeros_like(x))
    lam = dominant_eigenvalue(sc.solver, sc.state, sc.control, sc.model)
    assert lam < 0.0
    assert measured_stable_dt(sc.solver, sc.state, sc.control, sc.model) < 0.5 * bound
    assert settle_limit(sc, bound) == bound
