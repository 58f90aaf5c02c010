"""Contact thickness over a body's convex creases and where it shows through the cloth
(sandbox.collision.crease, BodyCollider.cover)."""

import math

import numpy as np
import pytest

from sandbox.collision.crease import EDGE_SPAN, cover_thickness, crease_thickness


def ridge(theta_deg: float, half_width=0.05, length=0.4):
    """A closed tent along x: two slopes meeting in a ridge whose normals differ by theta,
    on a flat floor, with a ridge vertex half-way, far from the tent's other edges.
    Vertices (9, 3) [m] (0-2 the ridge, 1 its middle), outward triangles."""
    a = math.radians(theta_deg) / 2.0  # each slope's tilt from horizontal
    h = half_width * math.tan(a)
    xs = (0.0, 0.5 * length, length)
    v = np.array([[x, h, 0.0] for x in xs] + [[x, 0.0, half_width] for x in xs]
                 + [[x, 0.0, -half_width] for x in xs], float)  # fmt: skip
    r, f, b = (0, 1, 2), (3, 4, 5), (6, 7, 8)
    t = []
    for k in range(2):
        t += [[r[k], f[k], f[k + 1]], [r[k], f[k + 1], r[k + 1]]]  # front slope
        t += [[r[k], r[k + 1], b[k + 1]], [r[k], b[k + 1], b[k]]]  # back slope
        t += [[f[k], b[k], b[k + 1]], [f[k], b[k + 1], f[k + 1]]]  # floor
    t += [[r[0], b[0], f[0]], [r[2], f[2], b[2]]]  # ends
    t = np.array(t)
    c = v.mean(axis=0)  # convex: orient every face away from the centroid
    for k, (i, j, m) in enumerate(t):
        if np.cross(v[j] - v[i], v[m] - v[i]) @ (v[i] - c) < 0:
            t[k] = [i, m, j]
    return v, t


@pytest.mark.parametrize("theta", [40.0, 65.0])
def test_the_ridge_is_lifted_by_the_depth_a_cloth_edge_would_cut(theta):
    v, t = ridge(theta)
    edge, h = 0.0175, 0.002
    extra = crease_thickness(v, t, edge, h)
    half = math.radians(theta) / 2.0
    want = (0.5 * EDGE_SPAN * edge * math.sin(half) - h * math.cos(half)) / math.cos(half)
    # the ridge's middle: its own crease's lift; the feet's creases are 5 cm away, beyond
    # the 1.5 cloth edges the lift spreads over, and add nothing
    assert extra[1] == pytest.approx(want, rel=1e-9)


def test_a_fine_cloth_or_a_flat_body_needs_no_lift():
    v, t = ridge(10.0)
    assert crease_thickness(v, t, 0.01, 0.002)[1] == 0.0  # 10°: the chord clears it
    v, t = ridge(65.0)
    assert crease_thickness(v, t, 0.003, 0.002)[1] == 0.0  # a 3 mm cloth edge
    assert crease_thickness(v, t, 0.0, 0.002).max() == 0.0


def test_the_lift_grows_with_the_cloth_edge_and_is_bounded():
    v, t = ridge(65.0)
    lifts = [crease_thickness(v, t, e, 0.002)[1] for e in (0.01, 0.0175, 0.03, 0.2)]
    assert lifts == sorted(lifts) and lifts[0] > 0.0
    assert lifts[-1] == pytest.approx(0.25 * EDGE_SPAN * 0.2)  # a quarter of the span


def test_a_body_vertex_that_shows_is_covered_by_how_far_it_shows():
    """A flat 1 cm grid of body vertices; one shows through a 3 cm cloth by 1.5 mm."""
    xs = np.arange(-0.1, 0.1001, 0.01)
    v = np.array([[x, 0.0, z] for x in xs for z in xs])
    src = int(np.argmin(np.linalg.norm(v, axis=1)))
    through = np.zeros(len(v))
    through[src] = 1.5e-3
    extra = np.zeros(len(v))
    extra[np.argmax(v[:, 0])] = 4e-3  # a crease elsewhere keeps its own thickness
    edge, margin = 0.03, 5e-4
    out = cover_thickness(v, extra, through, edge, margin)
    span = EDGE_SPAN * edge
    dist = np.linalg.norm(v - v[src], axis=1)
    want = np.maximum(extra, (1.5e-3 + margin) * np.clip(2.0 - 2.0 * dist / span, 0.0, 1.0))
    np.testing.assert_allclose(out, want, rtol=0, atol=1e-15)
    assert out[src] == pytest.approx(2e-3) and out[dist > span].max() == 4e-3
    # where a thickness is already there, the raise comes on top of it
    again = cover_thickness(v, out, through, edge, margin)
    assert again[src] == pytest.approx(2e-3 + 1.5e-3 + margin)
    # nothing shows, or no cloth edge known: unchanged
    assert np.array_equal(cover_thickness(v, extra, np.zeros(len(v)), edge, margin), extra)
    assert np.array_equal(cover_thickness(v, extra, through, 0.0, margin), extra)


def test_the_collider_covers_a_sphere_showing_through_a_coarse_sheet():
    """A 10 cm sphere under a flat 8 cm cloth square whose corners rest on it: the top shows
    through; :meth:`BodyCollider.cover` thickens the contact there by how far it shows."""
    import trimesh

    from sandbox.collision.body import BodyCollider

    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.1)
    v, t = np.asarray(sphere.vertices), np.asarray(sphere.faces)
    body = BodyCollider(v, t, thickness_m=2e-3)
    body.follow_cloth(0.02)  # facets 12° apart: no crease thickness for a 2 cm cloth
    assert body.vert_extra.to_numpy().max() == 0.0
    top = int(np.argmax(v[:, 1]))
    y = v[top, 1] - 1e-3  # the sheet 1 mm below the top
    cloth = np.array([[-0.04, y, -0.04], [0.04, y, -0.04], [0.04, y, 0.04], [-0.04, y, 0.04]])
    tris = np.array([[0, 2, 1], [0, 3, 2]])
    assert body.cover(cloth, tris) > 0
    extra = body.vert_extra.to_numpy()
    assert extra[top] == pytest.approx(1e-3 + 0.25 * 2e-3, rel=1e-3)
    assert body.extra_max[None] == pytest.approx(extra.max())
    # a sheet clear of the body: nothing shows, nothing changes
    assert body.cover(cloth + [0.0, 0.01, 0.0], tris) == 0
    np.testing.assert_array_equal(body.vert_extra.to_numpy(), extra)
    # a new body (the window's resize) starts again from the crease thickness
    body.uncover()
    body.update(v * 1.1)
    assert body.vert_extra.to_numpy().max() == 0.0 and body.extra_max[None] == 0.0


@pytest.mark.slow
def test_the_demo_dress_hides_the_body_only_with_the_crease_thickness(tmp_path, monkeypatch):
    """The demo (sheath dress, 1.75 cm): without the crease thickness the shoulder line and
    the bust show through the dress (37 body vertices, 4.7 mm when measured); with it, none."""
    from sandbox.collision.body import BodyCollider
    from sandbox.garment import drape

    def run(out):
        r = drape("sheath-dress", out_dir=tmp_path / out, edge_length_m=0.0175, render=False,
                  meshes=False, progress=False)  # fmt: skip
        return r.metrics

    m = run("with")
    assert m["body_through_cloth_vertices"] == 0 and m["meets_acceptance"]
    monkeypatch.setattr(BodyCollider, "follow_cloth", lambda self, edge: None)
    m = run("without")
    assert m["body_through_cloth_vertices"] > 10
    assert m["body_through_cloth_max_m"] > 2e-3 and not m["meets_acceptance"]
