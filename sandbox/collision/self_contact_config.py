"""Settings and constants of the cloth's self-collision (:mod:`sandbox.collision.self_contact`).

The settings are one frozen dataclass, read by the collider at construction and compiled
into its kernels as constants; a Python caller passes
``SelfCollider(model, ..., config=SelfContactConfig(...))``. The scene sets the thickness
and friction (``[collision]``), which are the collider's own arguments.
"""

import dataclasses

KIND_VT = 0  # a candidate pair: vertex-triangle
KIND_EE = 1  # a candidate pair: edge-edge
# the passes' status: bit 0, the list covered the step and no pair collides at its end;
# bit 1, a query overflowed the list (the step must be redone)
RESOLVED = 1
OVERFLOWED = 2
SCAN_BLOCK = 1024  # cells (or pairs) per block of the parallel prefix sums


@dataclasses.dataclass(frozen=True)
class SelfContactConfig:
    """Tunables of the proximity, CCD and impact-zone passes and of the candidate list."""

    ccd_passes: int = 8
    """Serial CCD passes per step before the rest is left to the impact zones: colliding
    pairs are few, and a handful of passes resolves a step unless pairs keep hitting each
    other (then the zones are the cure)."""
    ccd_gap_fraction: float = 0.1
    """Gap [1, of the thickness] a CCD impulse leaves between a colliding pair at the end of
    the step (Bridson et al. 2002 §7.3: a small gap, so round-off cannot cross it)."""
    separation_fraction: float = 0.25
    """Part of the missing thickness [1] the proximity pass restores per step, as a position
    correction: a quarter separates gently (a 1/dt kick would throw the cloth apart)."""
    zone_rounds: int = 100
    """Rounds of rigid impact zones before the step fails with an error: each round merges
    the pairs that still collide, so a step needs a few; 100 means it is not converging."""
    margin_steps: float = 8.0
    """The candidate list's margin covers this many steps of the fastest relative motion
    [1], so a fast-moving cloth rebuilds its list every few steps, not every step..."""
    margin_edge_fraction: float = 0.3
    """...but the margin stays below this part of the mean edge length [1]: a wider one
    fills the list with neighbours in the cloth's own plane."""
    sweep_safety: float = 1.25
    """A fast step's list keeps the pairs that the step's relative motion, times this [1],
    could bring together: the impulses change velocities by a little after the build."""
    cell_scale: float = 1.5
    """Grid cell size over max(mean rest edge length, reach) [1]: fewer cells per query box
    at the cost of more items per cell."""
    cells_per_item: int = 8
    """Grid cells allocated per vertex or edge (whichever are more); a cloth spread wider
    than that allows gets larger cells, not more memory."""
    max_grid_extent_m: float = 1e4
    """The grid covers at most this much [m] of the cloth's bounding box per axis, so a
    cloth flung absurdly far still gets a grid that fits."""
    pairs_per_vertex: int = 32
    """Candidate-list capacity per vertex and edge (plus 1024): a draped garment uses a few;
    a step that overflows it is redone with the resting list."""
    partial_tau: float = 0.2
    """A slow step refreshes only the pairs of vertices that drifted more than this many
    margins [1] since the last rebuild (:meth:`~SelfCollider.refresh`)..."""
    partial_fraction: float = 0.05
    """...when they are at most this fraction [1] of the vertices; more, and a full rebuild
    costs about as much."""
