"""The hem-node metric of a drape: folds around a free hem, counted like the Cusick test's."""

import numpy as np
import pytest

from sandbox.garment import build_drape, make_mannequin
from sandbox.garment.metrics import hem_nodes, hem_ring


@pytest.fixture(scope="module")
def mannequin():
    return make_mannequin(12)


def _fold(scene, k: int, amplitude_m: float) -> tuple[np.ndarray, np.ndarray]:
    """The placed garment with its hem vertices put at radius 0.4 m + a·cos(kθ) about the
    torso axis at the hip; returns (positions, hem ring)."""
    g, model = scene.garment, scene.model
    start = {n: model.pieces[i].particle_start for n, i in g.piece_index.items()}
    ring = hem_ring(g.pattern, g.meshes, start)
    x = model.initial_positions_np.astype(float).copy()
    hip_y = float(g.placement_body.landmarks["hip_front"][1])
    axis = g.placement_body.frame("torso", hip_y).origin[[0, 2]]
    d = x[ring][:, [0, 2]] - axis
    theta = np.arctan2(d[:, 0], d[:, 1])
    r = np.linalg.norm(d, axis=1)
    scale = (0.4 + amplitude_m * np.cos(k * theta)) / r
    x[ring, 0] = axis[0] + d[:, 0] * scale
    x[ring, 2] = axis[1] + d[:, 1] * scale
    return x, ring


def test_a_skirt_hem_waved_k_times_has_k_nodes_and_a_round_one_none(mannequin):
    scene = build_drape("circle-skirt", mannequin, edge_length_m=0.03)
    x, ring = _fold(scene, 7, 0.02)
    assert len(ring) > 40
    assert hem_nodes(scene.garment, scene.model, x) == 7
    x9, _ = _fold(scene, 9, 0.02)
    assert hem_nodes(scene.garment, scene.model, x9) == 9
    round_hem, _ = _fold(scene, 0, 0.0)
    assert hem_nodes(scene.garment, scene.model, round_hem) == 0
    x_ripples, _ = _fold(scene, 12, 0.001)  # 2 mm peak to trough: under 5 mm prominence
    assert hem_nodes(scene.garment, scene.model, x_ripples) == 0


def test_only_the_torso_hem_counts_and_a_garment_without_one_has_none(mannequin):
    scene = build_drape("t-shirt", mannequin, edge_length_m=0.03)
    g = scene.garment
    start = {n: scene.model.pieces[i].particle_start for n, i in g.piece_index.items()}
    ring = hem_ring(g.pattern, g.meshes, start)
    sleeves = [n for n, p in g.pattern.panels.items() if p.placement.get("body") != "torso"]
    assert sleeves  # the sleeves' hems are left out
    for n in sleeves:
        p = scene.model.pieces[g.piece_index[n]]
        assert not np.any((ring >= p.particle_start) & (ring < p.particle_start + p.particle_count))
    assert hem_nodes(g, scene.model, scene.model.initial_positions_np) is not None
    for panel in g.pattern.panels.values():  # no edge called "hem": no ring
        for e in panel.edges:
            e.name = "bottom" if e.name == "hem" else e.name
    assert hem_ring(g.pattern, g.meshes, start) is None
    assert hem_nodes(g, scene.model, scene.model.initial_positions_np) is None
