"""A circle skirt starts on a cone from the waist with its extra width in folds."""

import dataclasses
import math

import numpy as np
import pytest

from sandbox.collision.body_probe import body_inside_check
from sandbox.garment.circle_start import (
    CircleStart,
    circle_gores,
    fold_amplitude,
    place_circle_skirt,
)
from sandbox.mannequin import build_mannequin
from sandbox.pattern.panel_mesh import mesh_pattern
from sandbox.pattern.placement.body import PlacementBody
from sandbox.pattern.placement.repair import crossings, start_stretches
from sandbox.pattern.spec import load_pattern
from sandbox.validate.cusick_measure import count_nodes


def circle_skirt(m, fullness: float):
    """The library's circle skirt drafted for mannequin ``m`` at ``fullness``."""
    from sandbox.drafting.garments import draft, load_garment

    g = load_garment("circle-skirt")
    g = dataclasses.replace(g, params={**g.params, "fullness": fullness})
    return load_pattern(draft(g, m.measurements_requested, mannequin=m))


def test_fold_amplitude_gives_the_row_its_length():
    r0 = np.array([0.2, 0.3, 0.3])
    want = 2 * math.pi * r0 * np.array([1.5, 1.2, 0.9])
    a = fold_amplitude(want, r0, 10)
    assert a[2] == 0.0  # shorter than the circle: no folds
    theta = np.linspace(0, 2 * math.pi, 20001)
    for k in range(2):
        r = r0[k] + a[k] * np.cos(10 * theta)
        got = np.trapezoid(np.hypot(r, -a[k] * 10 * np.sin(10 * theta)), theta)
        assert got == pytest.approx(want[k], rel=1e-3)


@pytest.mark.parametrize("size", [12, 26])
def test_a_full_circle_starts_outside_the_body_in_ten_folds_without_crossings(size):
    m = build_mannequin(size=size)
    body = PlacementBody(m)
    pattern = circle_skirt(m, 1.0)
    assert set(circle_gores(pattern)) == {"front", "left", "back", "right"}
    meshes = mesh_pattern(pattern, 0.03)
    placed = place_circle_skirt(pattern, meshes, body)
    assert crossings(placed, meshes) == 0
    x = np.vstack(list(placed.values()))
    probe = body_inside_check(m.vertices, m.triangles)
    assert probe.signed_distance(x).min() >= 0.02 - 1.5e-3  # the clearance, as the wrap's
    stretch = start_stretches(meshes, placed)
    assert np.percentile(stretch, 1) > 0.8 and np.percentile(stretch, 99) < 1.25
    # the hem: ten folds about the torso's axis, as the hem-node metric counts them
    y_w = float(body.landmarks["waist_front"][1])
    axis = body.frame("torso", y_w).origin[[0, 2]]
    hem = np.vstack([placed[n][meshes[n].edge("hem")] for n in placed])
    d = hem[:, [0, 2]] - axis
    theta = np.arctan2(d[:, 0], d[:, 1])
    assert count_nodes(np.mod(theta, 2 * math.pi), np.hypot(d[:, 0], d[:, 1])) == 10
    assert hem[:, 1].max() < y_w - 0.3  # the hem hangs below the waist


def test_a_half_circle_is_wrapped_and_one_just_fuller_fits_the_cone():
    m = build_mannequin(size=12)
    pattern = circle_skirt(m, 0.5)
    assert circle_gores(pattern) is None  # wrapped as every panel: it needs no folds
    pattern = circle_skirt(m, 0.51)
    assert set(circle_gores(pattern)) == {"front", "left", "back", "right"}
    meshes = mesh_pattern(pattern, 0.03)
    placed = place_circle_skirt(pattern, meshes, PlacementBody(m), CircleStart(relax_rounds=0))
    stretch = start_stretches(meshes, placed)
    assert np.percentile(stretch, 5) > 0.9 and np.percentile(stretch, 95) < 1.1
