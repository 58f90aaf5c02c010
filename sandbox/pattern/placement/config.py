"""Settings of panel placement around the mannequin (:mod:`sandbox.pattern.placement`)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class PlacementConfig:
    """How panels are wrapped, pushed out, relaxed and untangled at the start.

    Lengths in metres, angles in radians, slopes in metres per metre of axis.
    """

    clearance_m: float = 0.02
    """[m] Distance from the body of a panel whose placement gives no ``clearance``: enough
    for the push-out to stay clear of the body's facets, small enough that the seams close
    without a visible drop."""
    side_gap_rad: float = 0.14
    """[rad] Angular gap left between the sectors of neighbouring panels (half on each
    side): about 2.8 cm at the waist, so front and back never overlap at the start."""
    sector_overlap: float = 0.25
    """[-] Two panels on one body part share the turn round it (each gets the sector up to
    halfway to the other's side) only where their height spans overlap by more than this
    fraction of the shorter span; a hood above a bodice wraps the whole turn at its height."""
    row_m: float = 0.01
    """[m] Height spacing of the placement curves; vertices in between are interpolated.
    1 cm follows the body's sections closely at a cost of one hull per row."""
    offset_directions: int = 48
    """[-] Directions sampling the disc by which a section hull is offset (a 48-gon is
    within 0.2 % of the offset distance)."""
    fit_margin: float = 1.08
    """[-] Extra offset is computed for a panel this much wider than it is: the offset
    curve's arc within a sector grows a little slower than the circle estimate."""
    max_offset_slope: float = 0.5
    """[m/m] Going down the axis (away from the head or the shoulder), the extra offset a row
    gets to fit its sector shrinks by at most this much per metre: a flared panel (a circle
    skirt's gore, whose hem centre hangs below its widest row) is placed as a cone instead
    of curling back under itself towards the legs."""
    shrink_slope: float = 0.4
    """[m/m] Going down the axis, the placement curve comes in towards the axis by at most
    this much per metre, in every direction: a panel hangs from a bulge (buttocks, bust, the
    top of the arm) instead of following the body in under it. Followed exactly, a 1 cm row
    step that comes 1.5 cm in stretched the pencil skirt's back 78 % along its length."""
    radial_samples: int = 120
    """[-] Directions in which the curves are compared for :attr:`shrink_slope` (3 degrees
    apart)."""
    push_iterations: int = 8
    """[-] Passes of the push-out (closest point, move out along the normal); a point in a
    crease needs a few as each move can bring it near another facet."""
    relax_iterations: int = 60
    """[-] Jacobi passes that bring each placed panel's mesh edges back towards their
    pattern lengths (:func:`~sandbox.pattern.placement.repair.relax_panel`) before a
    push-out ..."""
    relax_rounds: int = 3
    """[-] ... and how many times the two alternate (0: the wrap alone)."""
    relax_hold: float = 0.03
    """[-] Each relaxation pass also pulls every vertex this fraction of the way back to
    where the wrap put it, so a panel keeps its place (its anchor on the landmark) while
    its strains relax."""
    overlap_margin_m: float = 0.015
    """[m] Limb panels (sleeve caps) above the underarm start at least this far outside the
    torso panels, measured from the torso axis, so that they do not cut through the
    bodice."""
    untangle_rounds: int = 20
    """[-] At most this many smoothing rounds of
    :func:`~sandbox.pattern.placement.repair.untangle` (0: none) ..."""
    untangle_rings: int = 2
    """[-] ... each over the vertices of the crossing triangles and this many rings around
    them (smoothing and edge-length steps: :mod:`sandbox.collision.untangle`)."""


DEFAULT_PLACEMENT = PlacementConfig()
"""The defaults (frozen: shared as the default argument of the placement functions)."""
