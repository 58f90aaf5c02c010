"""Solver-independent contact measures: body inside/distance, triangle-pair intersections."""

import time

import numpy as np
import pytest
import trimesh

from sandbox.collision.body_probe import (
    body_inside_check,
    body_through_cloth,
    penetration_metrics,
)
from sandbox.collision.mesh_checks import edge_report
from sandbox.collision.metrics import (
    count_intersecting_pairs,
    count_intersections_between,
    intersecting_pairs,
    intersecting_pairs_between,
    seam_joined_pairs,
)
from sandbox.errors import SandboxError

RNG_SEED = 20240611


def sheet(nx, ny, size=(1.0, 1.0)):
    """A flat grid sheet in z = 0: (n, 3) vertices, (2 nx ny, 3) triangles."""
    x, y = np.meshgrid(np.linspace(0, size[0], nx + 1), np.linspace(0, size[1], ny + 1),
                       indexing="ij")  # fmt: skip
    v = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], 1)
    i = np.arange((nx + 1) * (ny + 1)).reshape(nx + 1, ny + 1)
    a, b, c, d = i[:-1, :-1].ravel(), i[1:, :-1].ravel(), i[1:, 1:].ravel(), i[:-1, 1:].ravel()
    return v, np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def rotation(seed=RNG_SEED):
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def moved(v, seed=RNG_SEED):
    """A rigid motion that makes nothing axis-aligned."""
    return v @ rotation(seed).T + np.array([0.3, 1.1, -0.7])


def folded_strip(gap, length=0.3, width=0.1, edge=0.005):
    """A strip folded over itself: two layers ``gap`` apart joined by a half cylinder."""
    r = gap / 2
    s_flat = np.arange(0, length + 1e-12, edge)
    arc = np.linspace(0, np.pi, max(int(np.pi * r / edge), 4) + 1)[1:-1]
    curve = np.concatenate([
        np.stack([s_flat, np.zeros_like(s_flat)], 1),
        np.stack([length + r * np.sin(arc), r - r * np.cos(arc)], 1),
        np.stack([s_flat[::-1], np.full_like(s_flat, gap)], 1),
    ])  # fmt: skip
    zs = np.arange(0, width + 1e-12, edge)
    v = np.array([[x, y, z] for x, y in curve for z in zs])
    nz = len(zs)
    tris = []
    for i in range(len(curve) - 1):
        for j in range(nz - 1):
            a, b, c, d = i * nz + j, (i + 1) * nz + j, (i + 1) * nz + j + 1, i * nz + j + 1
            tris += [(a, b, c), (a, c, d)]
    return v, np.array(tris)


def crossing_quads():
    """Quad A (z = 0, unit square, diagonal 0-2) and quad B (plane x = 0.25) crossing it.

    On the line x = 0.25, z = 0: A's triangle 0 covers y in [0, 0.25], triangle 1 covers
    [0.25, 1]; B's triangle 2 covers y >= 0.5 and triangle 3 y <= 0.5. Intersecting pairs:
    (0, 3), (1, 2), (1, 3); none of them only touches.
    """
    va = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    vb = np.array([[0.25, -1, -1], [0.25, 2, -1], [0.25, 2, 1], [0.25, -1, 1]], float)
    quad = np.array([[0, 1, 2], [0, 2, 3]])
    return va, quad, vb, quad


def sphere(radius=0.3, center=(0.1, 1.0, -0.2), subdivisions=4):
    m = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    v = np.asarray(m.vertices) + np.asarray(center)
    f = np.asarray(m.faces, np.int64)
    # discretisation error: the faces lie inside the sphere by at most this much
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    err = radius - np.min(np.einsum("ij,ij->i", v[f[:, 0]] - center, n))
    return v, f, np.asarray(center, float), err


def points_at(center, radii, seed=RNG_SEED):
    d = np.random.default_rng(seed).normal(size=(len(radii), 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return center + d * np.asarray(radii)[:, None]


# ---------------------------------------------------------------------------------------
# triangle pairs


@pytest.mark.parametrize("pose", ["axis", "moved", "float32"])
def test_flat_sheet_has_no_intersecting_pairs(pose):
    v, t = sheet(30, 20)
    if pose != "axis":
        v = moved(v)
    if pose == "float32":
        v = v.astype(np.float32)  # coplanarity only to ~1e-8 m
    assert count_intersecting_pairs(v, t) == 0


def test_folded_sheet_without_contact_has_none_and_pushed_through_has_some():
    v, t = folded_strip(gap=0.004)
    assert count_intersecting_pairs(moved(v), t) == 0
    pushed = v.copy()
    top = pushed[:, 1] > 0.003  # the upper layer
    pushed[top, 1] -= 0.1 * (0.3 - pushed[top, 0]) / 0.3  # tilt its free end through
    assert count_intersecting_pairs(moved(pushed), t) > 0


def test_two_crossing_quads_known_pairs():
    va, ta, vb, tb = crossing_quads()
    v = np.vstack([va, vb])
    t = np.vstack([ta, tb + 4])
    expected = [[0, 3], [1, 2], [1, 3]]
    assert intersecting_pairs(v, t).tolist() == expected
    assert intersecting_pairs(moved(v), t).tolist() == expected
    assert count_intersecting_pairs(v, t) == 3
    assert intersecting_pairs_between(va, ta, vb, tb).tolist() == [[0, 1], [1, 0], [1, 1]]
    assert count_intersections_between(moved(va), ta, moved(vb), tb) == 3
    assert count_intersections_between(va, ta, vb + [2.0, 0, 0], tb) == 0


def test_exclusions():
    va, ta, vb, tb = crossing_quads()
    v, t = np.vstack([va, vb]), np.vstack([ta, tb + 4])
    assert count_intersecting_pairs(v, t, exclude_pairs=[[3, 0]]) == 2  # either order
    # vertex 1 is only in triangle 0, vertex 7 only in triangle 3: pair (0, 3) goes
    assert intersecting_pairs(v, t, exclude_vertex_pairs=[[7, 1]]).tolist() == [[1, 2], [1, 3]]
    # vertices 0 and 4 are in every triangle of their quad: everything goes
    assert count_intersecting_pairs(v, t, exclude_vertex_pairs=[[0, 4]]) == 0
    with pytest.raises(SandboxError, match="exclude_vertex_pairs"):
        count_intersecting_pairs(v, t, exclude_vertex_pairs=[[0, 99]])


def test_seam_joined_points_are_partners_partners_partners_and_theirs():
    # a junction: 0 (front) sewn to 1 (back), 1 sewn to 2 (sleeve); a lone seam 5-6
    joined = seam_joined_pairs([[0, 1], [2, 1], [5, 6], [3, 3]], 8)
    assert joined.tolist() == [[0, 1], [0, 2], [1, 2], [5, 6]]
    assert seam_joined_pairs(None).shape == (0, 2)
    # four panels sewn in a chain at one point (a hood's corners and the two fronts at the
    # front neck): 10-11, 11-12, 12-13 are all one point; a fifth, 14, beyond it is not
    joined = seam_joined_pairs([[10, 11], [11, 12], [12, 13], [13, 14]], 15).tolist()
    assert [10, 13] in joined and [11, 14] in joined and [10, 14] not in joined
    # the crossing quads sewn 7-8 and 8-1 (vertex 8 of a third piece): 1 and 7 are one
    # point, so triangles 0 and 3 only touch there, as with a shared vertex
    va, ta, vb, tb = crossing_quads()
    v, t = np.vstack([va, vb, [[5.0, 5.0, 5.0]]]), np.vstack([ta, tb + 4])
    assert count_intersecting_pairs(v, t, exclude_vertex_pairs=[[7, 8], [8, 1]]) == 3
    joined = seam_joined_pairs([[7, 8], [8, 1]], len(v))
    assert intersecting_pairs(v, t, exclude_vertex_pairs=joined).tolist() == [[1, 2], [1, 3]]


TRI = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)


def two(a, b):
    """Two triangles with their own vertices (no shared index)."""
    return np.vstack([a, b]), np.array([[0, 1, 2], [3, 4, 5]])


COPLANAR_CASES = {
    # name: (second triangle, counted?)
    "identical": (TRI, 1),
    "partial_overlap": (TRI + [0.3, 0.3, 0], 1),
    "contained": (TRI * 0.2 + [0.1, 0.1, 0], 1),
    "contains": (TRI * 5 - [1, 1, 0], 1),
    "edge_to_edge": (np.array([[1, 0, 0], [0, 1, 0], [1, 1, 0]], float), 1),
    "corner_to_corner": (np.array([[1, 0, 0], [2, 0, 0], [1, -1, 0]], float), 1),
    "corner_on_edge": (np.array([[0.5, 0.5, 0], [1, 1, 0], [2, 0.5, 0]], float), 1),
    "gap_1um": (np.array([[1, 0, 0], [0, 1, 0], [1, 1, 0]], float) + [1e-6, 1e-6, 0], 0),
    "apart": (TRI + [2, 0, 0], 0),
}


@pytest.mark.parametrize("pose", ["axis", "moved"])
@pytest.mark.parametrize("case", sorted(COPLANAR_CASES))
def test_coplanar_rule(case, pose):
    """Coplanar triangles count when the closed triangles overlap or touch in their plane."""
    other, expected = COPLANAR_CASES[case]
    v, t = two(TRI, other)
    if pose == "moved":
        v = moved(v)
    assert count_intersecting_pairs(v, t) == expected
    assert count_intersections_between(v[:3], [[0, 1, 2]], v[3:], [[0, 1, 2]]) == expected


def test_coplanar_touching_is_skipped_when_vertices_are_shared_or_paired():
    # a flat fan folded onto itself around a shared vertex: never tested
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float)
    assert count_intersecting_pairs(v, [[0, 1, 2], [0, 3, 2]]) == 0
    # edge to edge with duplicated vertices (a sewn seam): counted unless paired
    v, t = two(TRI, COPLANAR_CASES["edge_to_edge"][0])
    assert count_intersecting_pairs(v, t) == 1
    assert count_intersecting_pairs(v, t, exclude_vertex_pairs=[[1, 3], [2, 4]]) == 0


@pytest.mark.parametrize("pose", ["axis", "moved"])
def test_touching_counts_and_tolerance(pose):
    apex = np.array([[0.2, 0.2, 0.0], [0.2, 0.2, 1.0], [1.0, 0.5, 1.0]])  # corner on A's face
    v, t = two(TRI, apex)
    lifted, _ = two(TRI, apex + [0, 0, 1e-7])
    if pose == "moved":
        v, lifted = moved(v), moved(lifted)
    assert count_intersecting_pairs(v, t) == 1
    assert count_intersecting_pairs(lifted, t) == 0
    assert count_intersecting_pairs(lifted, t, tolerance_m=2e-7) == 1
    with pytest.raises(SandboxError, match="tolerance"):
        count_intersecting_pairs(v, t, tolerance_m=-1.0)


def test_degenerate_triangles():
    needle = np.array([[0.2, 0.2, -1], [0.2, 0.2, 1], [0.2, 0.2, 0.5]])  # collinear
    v, t = two(TRI, needle)
    assert count_intersecting_pairs(v, t) == 1
    assert count_intersecting_pairs(v + np.repeat([[0, 0, 0], [2, 0, 0]], 3, axis=0), t) == 0
    # repeated vertex index: a segment through the triangle
    v = np.vstack([TRI, [[0.2, 0.2, -1], [0.2, 0.2, 1]]])
    assert count_intersecting_pairs(v, [[0, 1, 2], [3, 4, 4]]) == 1
    # two needles: crossing, then skew
    cross = np.array([[-1, 0, 0], [1, 0, 0], [0, 0, 0], [0, -1, 0], [0, 1, 0], [0, 0.5, 0]])
    assert count_intersecting_pairs(cross, [[0, 1, 2], [3, 4, 5]]) == 1
    skew = cross + np.repeat([[0, 0, 0], [0, 0, 0.01]], 3, axis=0)
    assert count_intersecting_pairs(skew, [[0, 1, 2], [3, 4, 5]]) == 0


def test_random_soup_matches_open3d_brute_force():
    """Broad phase + test against Open3D's O(n^2) Moller test (general position)."""
    import open3d as o3d

    rng = np.random.default_rng(RNG_SEED)
    for _ in range(3):
        c = rng.uniform(0, 1, (250, 1, 3))
        v = (c + rng.normal(scale=0.08, size=(250, 3, 3))).reshape(-1, 3)
        t = np.arange(len(v)).reshape(-1, 3)
        t[1::5, 0] = t[0::5, 1][: len(t[1::5])]  # some shared vertices
        mesh = o3d.geometry.TriangleMesh(
            o3d.utility.Vector3dVector(v), o3d.utility.Vector3iVector(t)
        )
        ref = np.unique(np.sort(np.asarray(mesh.get_self_intersecting_triangles()), 1), axis=0)
        ours = intersecting_pairs(v, t)
        assert len(ours) > 50
        assert ours.tolist() == ref.tolist()


def test_bad_mesh_input():
    with pytest.raises(SandboxError, match="shape"):
        count_intersecting_pairs(np.zeros((4, 2)), [[0, 1, 2]])
    with pytest.raises(SandboxError, match="missing vertex"):
        count_intersecting_pairs(np.zeros((3, 3)), [[0, 1, 3]])
    with pytest.raises(SandboxError, match="NaN"):
        count_intersecting_pairs(np.full((3, 3), np.nan), [[0, 1, 2]])


# ---------------------------------------------------------------------------------------
# body


def test_sphere_signed_distance_inside_and_penetration():
    v, f, c, err = sphere()
    probe = body_inside_check(v, f)
    assert probe.closed and not probe.inward
    radii = np.array([0.0, 0.1, 0.2, 0.28, 0.32, 0.4, 0.8])
    p = points_at(c, radii)
    tol = err + 1e-6  # faceting + float32
    assert np.allclose(probe.signed_distance(p), radii - 0.3, atol=tol)
    assert np.allclose(probe.distance(p), np.abs(radii - 0.3), atol=tol)
    assert probe.inside(p).tolist() == (radii < 0.3).tolist()

    cloth = points_at(c, [0.25, 0.29, 0.31, 0.4], seed=1)
    m = penetration_metrics(cloth, probe)
    assert m["vertices_inside_body"] == 2
    assert m["penetration_max_m"] == pytest.approx(0.05, abs=tol)
    assert penetration_metrics(cloth, probe, tolerance_m=0.02)["vertices_inside_body"] == 1
    outside = penetration_metrics(points_at(c, [0.35, 0.5]), probe)
    assert outside == {"penetration_max_m": 0.0, "vertices_inside_body": 0}


def test_sphere_many_points_against_analytic():
    v, f, c, err = sphere()
    probe = body_inside_check(v, f)
    p = np.random.default_rng(RNG_SEED).uniform(c - 0.5, c + 0.5, (5000, 3))
    r = np.linalg.norm(p - c, axis=1)
    clear = (r < 0.3 - err - 1e-6) | (r > 0.3 + 1e-6)  # not between facets and sphere
    assert (probe.inside(p)[clear] == (r < 0.3)[clear]).all()
    assert np.abs(probe.signed_distance(p) - (r - 0.3)).max() <= err + 1e-6


def test_box_lattice_points_inside():
    """Points on a lattice aligned with the box's vertices and edges."""
    m = trimesh.creation.box(extents=(2, 2, 2)).subdivide().subdivide()
    probe = body_inside_check(m.vertices, m.faces)
    g = np.linspace(-1.5, 1.5, 13)
    p = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    on_surface = (np.abs(np.abs(p) - 1) < 1e-9).any(1) & (np.abs(p) <= 1 + 1e-9).all(1)
    inside = probe.inside(p)
    assert (inside == (np.abs(p) < 1).all(1))[~on_surface].all()


def test_open_body_raises_for_inside_but_distance_works():
    v, f, c, err = sphere()
    top = np.argsort(-(v[f].mean(1)[:, 1]))[:5]  # five holes at the top
    probe = body_inside_check(v, np.delete(f, top, axis=0), name="holey")
    assert not probe.closed and probe.problems["boundary_edges"] > 0
    p = points_at(c, [0.1, 0.4]) * [1, 0, 1] + [0, c[1], 0]  # around the equator
    with pytest.raises(SandboxError, match=r"'holey'.*closed mesh.*\d+ boundary edges"):
        probe.inside(p)
    with pytest.raises(SandboxError, match="closed mesh"):
        probe.signed_distance(p)
    with pytest.raises(SandboxError, match="closed mesh"):
        penetration_metrics(p, probe)
    r = np.linalg.norm(p - c, axis=1)
    assert np.allclose(probe.distance(p), np.abs(r - 0.3), atol=err + 1e-6)


def test_misoriented_and_nonmanifold_bodies_raise():
    v, f, c, _ = sphere(subdivisions=2)
    flipped = f.copy()
    flipped[0] = flipped[0, ::-1]
    with pytest.raises(SandboxError, match="3 inconsistently oriented edges"):
        body_inside_check(v, flipped).inside([c])
    extra = np.vstack([f, f[:1]])  # one face twice: three faces on each of its edges
    report = edge_report(extra, len(v))
    assert report["nonmanifold_edges"] == 3
    with pytest.raises(SandboxError, match="non-manifold"):
        body_inside_check(v, extra).inside([c])


def test_inside_out_overlapping_and_hollow_bodies():
    v, f, c, _ = sphere(subdivisions=3)
    p = points_at(c, [0.1, 0.5])
    inverted = body_inside_check(v, f[:, ::-1])
    assert inverted.inward and inverted.inside(p).tolist() == [True, False]
    # two overlapping spheres in one mesh: the union is inside (ray parity gets this wrong)
    both = body_inside_check(np.vstack([v, v + [0.3, 0, 0]]), np.vstack([f, f + len(v)]))
    q = c + np.array([[0.15, 0, 0], [-0.2, 0, 0], [0.5, 0, 0], [0.15, 0.35, 0]])
    assert both.inside(q).tolist() == [True, True, True, False]
    # a hollow shell (inner surface facing into the cavity): the cavity is outside
    vi, fi, _, _ = sphere(radius=0.15, subdivisions=3)
    shell = body_inside_check(np.vstack([v, vi]), np.vstack([f, fi[:, ::-1] + len(v)]))
    assert shell.inside(points_at(c, [0.05, 0.2, 0.4])).tolist() == [False, True, False]


def test_contact_metrics_of_a_scene():
    """The contact keys of metrics.json (:func:`sandbox.scene.run.contact_metrics`) for a
    20 cm sheet of a built scene moved part-way into a 20 cm sphere collider: the deepest
    vertex's depth matches the analytic sphere to the tessellation's sag (< 1 mm), every
    vertex more than 1 mm inside counts, the flat sheet has no crossing pairs and folded
    onto itself it has; without a closed collider the body keys are None."""
    from sandbox.scene.build import build_scene
    from sandbox.scene.run import contact_metrics
    from sandbox.scene.spec import scene_from_dict

    def scene(colliders):
        cloth = {"name": "sheet", "edge_length_m": 0.02, "material": "jersey",
                 "size_m": [0.2, 0.2], "origin_m": [-0.1, 0.0, 0.1],
                 "rotation_deg": [-90, 0, 0]}  # fmt: skip
        data = {"scene": {"name": "contact_metrics"}, "stop": {"time_limit_s": 0.1},
                "cloth": [cloth], "collider": colliders}  # fmt: skip
        return build_scene(scene_from_dict(data, source="contact_metrics.toml"))

    ball = {"name": "ball", "shape": "sphere", "center_m": [0, 0, 0], "radius_m": 0.2}
    sc = scene([ball])
    x = sc.state.positions() + [0.0, 0.15, 0.0]  # the sheet in y = 0.15
    r = np.linalg.norm(x, axis=1)
    out = contact_metrics(sc.model, x)
    assert set(out) == {"penetration_max_m", "vertices_inside_body", "intersecting_triangle_pairs",
                        "body_through_cloth_vertices", "body_through_cloth_max_m"}  # fmt: skip
    assert out["body_through_cloth_vertices"] > 0  # the cap above the sheet shows through
    assert 0.0 < out["body_through_cloth_max_m"] <= 0.02
    assert out["penetration_max_m"] == pytest.approx(0.2 - r.min(), abs=1e-3)
    assert np.sum(r < 0.199) <= out["vertices_inside_body"] <= np.sum(r < 0.2)
    assert out["intersecting_triangle_pairs"] == 0
    folded = x.copy()
    folded[x[:, 0] > 0, 0] *= -1  # the right half laid onto the left, in the same plane
    assert contact_metrics(sc.model, folded)["intersecting_triangle_pairs"] > 100
    free = scene([])
    assert contact_metrics(free.model, free.state.positions()) == {
        "penetration_max_m": None, "vertices_inside_body": None, "intersecting_triangle_pairs": 0,
        "body_through_cloth_vertices": None, "body_through_cloth_max_m": None,
    }  # fmt: skip


def _ball(radius=0.1):
    b = trimesh.creation.icosphere(subdivisions=5, radius=radius)  # 10,242 vertices
    return np.asarray(b.vertices), np.asarray(b.faces)


@pytest.mark.parametrize("pose", [0, 1])
def test_a_sheet_cutting_a_ball_shows_its_cap_through_the_cloth(pose):
    """A flat sheet at y = 9 cm over a ball of r = 10 cm: the cap above the sheet shows
    through it, up to 1 cm deep at the top, and every cap vertex is counted; the same sheet
    at 10.3 cm (resting on the top) hides the ball."""
    bv, bt = _ball()
    v, t = sheet(30, 30, (0.3, 0.3))
    v = v[:, [0, 2, 1]] - [0.15, 0.0, 0.15]  # the horizontal plane y = 0, centred
    rigid = rotation(pose) if pose else np.eye(3)
    cap = np.sum(bv[:, 1] > 0.09 + 1e-6)
    m = body_through_cloth((v + [0, 0.09, 0]) @ rigid.T, t, bv @ rigid.T, bt)
    assert m["body_through_cloth_vertices"] == cap > 100
    assert m["body_through_cloth_max_m"] == pytest.approx(0.01, abs=1e-5)
    m = body_through_cloth((v + [0, 0.103, 0]) @ rigid.T, t, bv @ rigid.T, bt)
    assert m == {"body_through_cloth_vertices": 0, "body_through_cloth_max_m": 0.0}


def test_a_cloth_shell_around_a_ball_hides_it_and_a_smaller_one_does_not():
    """A closed cloth sphere of r + 3 mm around the ball covers it: nothing shows. A cloth
    sphere 2 mm inside the ball's surface: every body vertex shows through by 2 mm. Inside
    out, (the outward normals of a body wound the other way) the answer is the same."""
    bv, bt = _ball()
    sv, st = _ball(0.103)
    assert body_through_cloth(sv, st, bv, bt)["body_through_cloth_vertices"] == 0
    m = body_through_cloth(sv * (0.098 / 0.103), st, bv, bt[:, ::-1])
    assert m["body_through_cloth_vertices"] == len(bv)
    assert m["body_through_cloth_max_m"] == pytest.approx(0.002, rel=0.02)


def test_bad_body_input():
    with pytest.raises(SandboxError, match="no triangles"):
        body_inside_check(np.zeros((3, 3)), np.zeros((0, 3), int))
    with pytest.raises(SandboxError, match="'torso'.*NaN"):
        body_inside_check(np.full((3, 3), np.nan), [[0, 1, 2]], name="torso")
    v, f, _, _ = sphere(subdivisions=1)
    with pytest.raises(SandboxError, match="points must have shape"):
        body_inside_check(v, f).distance(np.zeros((4, 2)))


# ---------------------------------------------------------------------------------------
# speed (loose: the measured times are in docs/collision_metrics.md)


def test_speed_20k_triangles():
    rng = np.random.default_rng(RNG_SEED)
    v, t = sheet(100, 100)  # 20,000 triangles, 1 cm edges
    v = moved(v + rng.normal(scale=0.004, size=v.shape))  # crumpled: ~1,200 pairs
    start = time.perf_counter()
    n = count_intersecting_pairs(v, t)
    assert time.perf_counter() - start < 10.0
    assert n > 100

    body = trimesh.creation.icosphere(subdivisions=5, radius=0.3)  # 20,480 triangles
    p = rng.uniform(-0.4, 0.4, (10_000, 3))
    start = time.perf_counter()
    sd = body_inside_check(body.vertices, body.faces).signed_distance(p)
    assert time.perf_counter() - start < 5.0
    assert np.mean((sd < 0) == (np.linalg.norm(p, axis=1) < 0.3)) > 0.999


def test_points_follow_a_body_that_grows():
    """follow_body: a point beside a face moves with that face's closest point."""
    from sandbox.collision import shapes
    from sandbox.collision.body_probe import follow_body

    v, t, _ = shapes.sphere([0, 0, 0], 0.1, 3)
    p = np.array([[0.0, 0.103, 0.0], [0.0, 0.0, -0.105]])
    q = follow_body(p, v, t, 1.5 * v)
    r0, r1 = np.linalg.norm(p, axis=1), np.linalg.norm(q, axis=1)
    # the gap to the surface is kept (a faceted sphere: within its sag)
    np.testing.assert_allclose(r1 - 1.5 * 0.1, r0 - 0.1, atol=2e-3)
    np.testing.assert_allclose(q / r1[:, None], p / r0[:, None], atol=1e-2)
