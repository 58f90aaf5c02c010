"""Typed settings of a garment drape: what to simulate, how to sew, how to repair, what to accept.

Every field has its unit in its name or docstring and a default chosen by measurement
(docs/drape.md gives the figures). Settings are passed explicitly: ``drape(...,
config=DrapeConfig(...))``, ``build_drape(..., config=...)``; nothing changes them at run time.
Frozen, so ``dataclasses.replace(config, time_limit_s=4.0)`` makes a variant.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field, fields

from sandbox.errors import SandboxError
from sandbox.garment.fit import FitConfig
from sandbox.scene.budget import ResourceLimits
from sandbox.scene.spec import INTEGRATORS


def _check_positive(owner: str, **values: float) -> None:
    for name, value in values.items():
        if not (isinstance(value, int | float) and value > 0 and math.isfinite(value)):
            raise SandboxError(f"{owner}.{name} must be a positive number, got {value!r}")


def _check_nonnegative(owner: str, **values: float) -> None:
    for name, value in values.items():
        if not (isinstance(value, int | float) and value >= 0 and math.isfinite(value)):
            raise SandboxError(f"{owner}.{name} must be a number >= 0, got {value!r}")


@dataclass(frozen=True)
class SewingConfig:
    """The sewing phase (:func:`sandbox.garment.sewing.sew`): seams pull the placed panels
    together at a fraction of their stiffness, then seams and cloth stiffen to full strength."""

    gap_m: float = 2e-3
    """Sewing ends when every seam spring is shorter than this [m] (or at ``time_limit_s``)."""
    time_limit_s: float = 1.5
    """Longest simulated sewing time [s] before the stiffening ramp."""
    stiffness_factor: float = 0.05
    """Seam springs pull at this fraction of their final stiffness while the seams close: as
    stiff as the cloth, so the seams then carry the garment's weight without a shock."""
    self_collision: bool = True
    """Cloth-cloth contact while sewing. Off, seams close about 3x faster, but a panel that
    starts on the wrong side of another passes through it and the garment keeps those
    crossings (3 cm: 44 crossing pairs on the T-shirt without it, 5 with it)."""
    gravity_fraction_tops: float = 0.3
    """Fraction of gravity while a garment that hangs from the shoulders is sewn (garments
    hanging from the waist sew weightless, or their panels slide down before the seams hold).
    Weightless, a blouse's back folds at the waist as the armholes pull the bodice up; at full
    gravity the weight holds the seams open against their sewing stiffness."""
    speed_limit_m_s: float = 3.0
    """No particle keeps a speed above this [m/s] while the seams close (explicit solver;
    0: none). A seam closing across a 10 cm gap pulls at the cloth's wave speed, and the shock
    flings hems up into rolls; at 1 m/s the seams can no longer drag an end pressed into the
    body past friction."""
    friction_implicit: float = 0.0
    """Body and cloth friction coefficient while sewing with ``implicit_euler``, whose friction
    acts inside the step's energy and resists the seams' own pull into the body (at the scene's
    0.4 the halter top's neck seams stalled 13.5 mm open at 3 cm). The explicit solver sews
    with the scene's friction; the drape after sewing always has it."""
    at_rest_implicit: bool = True
    """With ``implicit_euler``, a garment sewn weightless (the skirts) ends every sewing frame
    at rest: backward Euler at 1/60 s keeps the seams' pull as momentum (the circle skirt's
    hem swung 22.8 cm up and the sewing stalled 22.7 mm open without it)."""
    stall_frames: int = 6
    """Frames over which the largest seam gap must shrink (see ``stall_shrink``)."""
    stall_shrink: float = 0.95
    """Sewing also ends when the largest gap is above this fraction of what it was
    ``stall_frames`` frames before (``sew_stalled``): the last open spring is a corner held by
    the body, which the ramp's stiffer seams close."""
    ramp_frames: int = 6
    """Frames over which the seams stiffen geometrically to their final stiffness."""

    def __post_init__(self):
        _check_positive("SewingConfig", gap_m=self.gap_m, time_limit_s=self.time_limit_s,
                        stiffness_factor=self.stiffness_factor,
                        stall_shrink=self.stall_shrink)  # fmt: skip
        _check_nonnegative("SewingConfig", gravity_fraction_tops=self.gravity_fraction_tops,
                           speed_limit_m_s=self.speed_limit_m_s,
                           friction_implicit=self.friction_implicit)  # fmt: skip
        for name in ("stall_frames", "ramp_frames"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 1):
                raise SandboxError(f"SewingConfig.{name} must be a whole number >= 1, got "
                                   f"{value!r}")  # fmt: skip


@dataclass(frozen=True)
class RepairConfig:
    """Untangling crossing triangle pairs (:mod:`sandbox.garment.repair`)."""

    after_sewing: bool = True
    """Smooth away crossing pairs once the seams are sewn: a panel beside a closing seam can
    slip through its neighbour in the seam zone, which self-collision leaves free so the seam
    can close, and contact never undoes a crossing."""
    max_passes: int = 2
    """At most this many untangling passes in all (the one after sewing included); a drape
    that ends with crossing pairs and has time left is untangled and settled again."""
    settle_s: float = 0.2
    """A repaired drape runs at least this long [s] before the stop rule is checked again."""
    clearance_m: float = 3e-3
    """Untangled vertices are pushed out to this distance from the body [m] (1.5 x the
    contact thickness)."""
    narrow_seam_exclusion: bool = True
    """Settle a repaired drape with self-collision's seam exclusion narrowed to the seam
    partners alone: the seams are closed by then, and with the partners' mesh neighbours left
    free the panels beside a seam cross again."""
    cover_passes: int = 2
    """A drape that ends with the body showing through the cloth deeper than the acceptance
    allows (``AcceptanceConfig.body_through_m``) has its contact thickened where the body
    shows (``BodyCollider.cover``, as the window does after a resize) and runs on to the stop
    rule again (at least ``settle_s``): at most this many passes, 0 switches it off. Not on a
    coarse-to-fine drape's coarse level, whose shape the fine level settles anyway."""

    def __post_init__(self):
        _check_positive("RepairConfig", settle_s=self.settle_s, clearance_m=self.clearance_m)
        for name in ("max_passes", "cover_passes"):
            v = getattr(self, name)
            if not (isinstance(v, int) and not isinstance(v, bool) and v >= 0):
                raise SandboxError(f"RepairConfig.{name} must be a whole number >= 0, got "
                                   f"{v!r}")  # fmt: skip


@dataclass(frozen=True)
class AcceptanceConfig:
    """What a drape must reach to be accepted (``meets_acceptance`` in metrics.json)."""

    seam_gap_m: float = 2e-3
    """Largest distance between a seam's two sides [m]."""
    penetration_m: float = 1e-3
    """Deepest cloth vertex inside the body [m]."""
    body_through_m: float = 1e-3
    """Deepest body vertex showing through the cloth where it covers the body [m]
    (``body_through_cloth_max_m``, docs/collision_metrics.md)."""
    slide_tolerance_m: float = 0.03
    """A garment has slid off when its top ends more than this [m] below the landmark it
    hangs from."""
    fold_tolerance_pct: float = 2.0
    """A garment has rolled up when more than this share of its area [%] ends turned over."""
    fold_free_m: float = 0.03
    """Cloth further than this from the body [m] hangs free, and counts as turned over only
    upside down (:func:`~sandbox.garment.metrics.fold_metrics`): a flare's flutes turn
    past 90° about the vertical. Within it cloth lies on the body or on the garment's
    layers over it (a collar, a lapel, a bodice under a yoke)."""

    def __post_init__(self):
        _check_positive("AcceptanceConfig", seam_gap_m=self.seam_gap_m,
                        penetration_m=self.penetration_m,
                        body_through_m=self.body_through_m,
                        slide_tolerance_m=self.slide_tolerance_m,
                        fold_tolerance_pct=self.fold_tolerance_pct,
                        fold_free_m=self.fold_free_m)  # fmt: skip


DRAPE_METHODS = ("direct", "coarse_to_fine")


@dataclass(frozen=True)
class DrapeConfig:
    """A garment drape: the simulation's settings, and those of its sewing, repair and
    acceptance. The defaults are the gallery's."""

    method: str = "coarse_to_fine"
    """How the rest shape is reached: ``"direct"`` sews and drapes the requested mesh itself;
    ``"coarse_to_fine"`` sews and drapes a ``coarse_edge_m`` mesh of the same panels first,
    carries its shape to the fine mesh through the pattern coordinates and lets the fine mesh
    settle (:mod:`sandbox.garment.multilevel`)."""
    coarse_edge_m: float = 0.03
    """Mesh edge [m] of ``coarse_to_fine``'s first level (used only when the drape's own mesh
    is finer)."""
    coarse_self_collision: bool = False
    """``coarse_to_fine``: cloth-cloth contact on the coarse level. Off by default: the
    coarse level then runs the fused step (one kernel launch for many steps), and the few
    crossings it leaves are untangled on the fine mesh, which has self-collision."""
    coarse_tangled_fraction: float = 0.05
    """``coarse_to_fine``, without ``coarse_self_collision``: a coarse level that comes to rest
    with more crossing triangle pairs than this fraction of its triangles has passed through
    itself where cloth lies in layers (tiers, collars, facings: 23 % of the triangles of
    GarmentCode's three-tier dress), which no untangling on the fine mesh undoes. It is
    draped again with cloth-cloth contact. The library's garments leave at most 0.3 %
    (6 pairs)."""
    coarse_damping_per_s: float | None = 6.0
    """``coarse_to_fine``: mass-proportional damping γ [1/s] on the coarse level (None: the
    drape's ``damping_per_s``). Measured on the t-shirt against the 1 cm reference: 2/s
    drapes the coarse level in 4.5 s simulated (mean distance 0.86 cm), 6/s in 2.6 s
    (0.90 cm), 20/s in 1.4 s but leaves more to the fine level (0.95 cm)."""
    fine_damping_per_s: float = 60.0
    """``coarse_to_fine``: mass-proportional damping γ [1/s] on the fine level, which starts
    next to rest: above critical for a garment's slow swinging (ω ≈ 10 rad/s), so it settles
    in a few frames instead of swinging, and the cloth settles where friction first holds
    it (measured on the t-shirt against the 1 cm reference: mean distance 1.00 cm at 20/s,
    0.86 cm at 60/s, 0.81 cm at 200/s, where the residual grows). The equilibrium residual
    checks that it stopped at rest, not merely slowed down."""
    fine_measured_dt: bool = True
    """``coarse_to_fine``, explicit: the fine level's step from the stability limit measured
    on the carried shape (:mod:`sandbox.sim.stability`: power iteration on the stiffness),
    not from the bound on the rest shape; at most twice the bound's step, with the guard
    as the safety net. Where the measure's dominant mode is an element squeezed flat (a
    negative eigenvalue), the bound's step."""
    fine_inertia_scale: float = 4.0
    """``coarse_to_fine``, explicit: the fine level runs with its inertia s times its mass and
    its gravity and damping γ divided by s (:func:`sandbox.sim.inertia.scaled_inertia`):
    the weight m g and the drag γ m are unchanged, so are the rest shape and, while the
    motion is overdamped, the path; the stable explicit step grows by √s. 1 switches it off.
    At s = 4, γ = 15 /s still exceeds twice the slowest swinging mode (about 5 rad/s once the
    inertia is scaled)."""
    fine_residual_mean: float = 0.25
    """``coarse_to_fine``: the fine level stops only where the mean equilibrium residual
    (:mod:`sandbox.sim.residual`: net force over weight per free vertex) is below this too,
    so that its heavy damping cannot pass a sliding garment off as one at rest."""
    fine_min_time_s: float = 0.1
    """``coarse_to_fine``: the fine level's stop rule is not checked before this simulated
    time [s] (it starts from the coarse level's rest shape, not from the placed panels)."""
    integrator: str = "symplectic_euler"
    """``"symplectic_euler"`` (the paper's Eq. 2) or ``"implicit_euler"`` (backward Euler)."""
    dt_s: float | None = None
    """Time step [s]; None: 0.9 x the explicit stability estimate, or 1/60 s implicit."""
    damping_per_s: float = 2.0
    """Mass-proportional damping γ [1/s] (F = -γ m v). A drape looks for the rest state, not
    the motion: 4x the default scene's; the terminal speed g/γ ≈ 5 m/s is far above a drape's."""
    strain_damping_s: float = 4e-6
    """Strain-rate damping β [s] of the membrane (explicit only; implicit Euler damps its
    fast modes itself). It settles the contact chatter that keeps stiff cloth moving on the
    body at 1 cm (a mode of angular frequency ω decays at about β ω²/2 per second: 10-20 /s
    for that chatter, 1e-4 /s for a garment swinging at 10 rad/s); it shortens the explicit
    step by √(1+ζ²) − ζ, ζ = β / the undamped stable step (~18 % for cotton at 1 cm)."""
    seam_damping_ratio: float = 0.3
    """Damping ratio ζ of each seam spring's dashpot (explicit only): a seam pair is two
    masses on a stiff spring, and undamped it rings at a few steps' period long after the
    garment has come to rest, its amplitude (up to a millimetre on a 3 cm mesh) hidden from
    a stop rule that samples positions once a frame. The dashpot acts on the pair's relative
    velocity only and leaves the rest shape alone."""
    seam_hold_m: float = 1e-3
    """How far a sewn stitch may open [m] (explicit only; 0: seams are springs alone). A
    seam spring is as stiff as a centimetre of the cloth, so where the cloth is stretched
    hard (a tight skirt over the seat) its stitches open by millimetres; thread does not
    stretch. Once a stitch has come within 3 times this distance the solver draws it in to
    this distance and keeps it there (its seam hold, a velocity filter that costs no step
    size: ``SymplecticEulerSolver._seam_hold``). Half the acceptance's
    :attr:`AcceptanceConfig.seam_gap_m`."""
    thickness_m: float = 2e-3
    """Contact thickness against the body and the cloth itself [m]."""
    self_collision: bool = True
    """Cloth-cloth contact (Bridson et al. 2002) while the garment drapes."""
    body_faces: bool = False
    """The face pass: the body's vertices are also kept the thickness under the cloth's
    triangles, so the body cannot show through a triangle spanning a convex part of it
    (docs/self_collision.md)."""
    frame_rate_hz: float = 30.0
    """Frames per second: the stop rule is checked once a frame."""
    stop_max_m: float = 1.5e-3
    """Stop rule (paper §2.2): every vertex moved less than this in one frame [m] ..."""
    stop_mean_m: float = 1.0e-4
    """... and the mean less than this [m]."""
    min_time_s: float = 0.5
    """The stop rule is not checked before this simulated time [s]."""
    time_limit_s: float = 8.0
    """Simulated time limit of the drape after sewing [s]."""
    wall_limit_s: float = 1800.0
    """Wall-clock limit of the drape after sewing [s]."""
    seam_reference_edge_m: float = 0.01
    """A seam spring is as stiff as the cloth (its larger stretch stiffness [N/m]) on a mesh
    of this edge [m]; on a coarser mesh each spring carries a longer piece of seam, so its
    stiffness grows with the edge and the seam's gap under the weight does not depend on
    the mesh."""
    sewing: SewingConfig = field(default_factory=SewingConfig)
    repair: RepairConfig = field(default_factory=RepairConfig)
    acceptance: AcceptanceConfig = field(default_factory=AcceptanceConfig)
    limits: ResourceLimits = field(default_factory=ResourceLimits)
    """The largest drape a build accepts (vertices, memory; :mod:`sandbox.scene.budget`)."""
    fit: FitConfig = field(default_factory=FitConfig)
    """Whether the pattern closes around the body, checked before meshing
    (:mod:`sandbox.garment.fit`)."""

    def __post_init__(self):
        if self.method not in DRAPE_METHODS:
            raise SandboxError(f"method must be one of {', '.join(DRAPE_METHODS)}, got "
                               f"{self.method!r}")  # fmt: skip
        _check_positive("DrapeConfig", coarse_edge_m=self.coarse_edge_m)
        if self.seam_damping_ratio > 1.0:
            raise SandboxError(f"DrapeConfig.seam_damping_ratio must be at most 1 (critical "
                               f"damping), got {self.seam_damping_ratio}")  # fmt: skip
        if self.integrator not in INTEGRATORS:
            raise SandboxError(f"integrator must be symplectic_euler or implicit_euler, got "
                               f"{self.integrator!r}")  # fmt: skip
        if self.dt_s is not None:
            _check_positive("DrapeConfig", dt_s=self.dt_s)
        _check_positive("DrapeConfig", thickness_m=self.thickness_m,
                        frame_rate_hz=self.frame_rate_hz, stop_max_m=self.stop_max_m,
                        stop_mean_m=self.stop_mean_m, time_limit_s=self.time_limit_s,
                        wall_limit_s=self.wall_limit_s,
                        seam_reference_edge_m=self.seam_reference_edge_m)  # fmt: skip
        _check_nonnegative("DrapeConfig", damping_per_s=self.damping_per_s,
                           strain_damping_s=self.strain_damping_s,
                           seam_damping_ratio=self.seam_damping_ratio,
                           seam_hold_m=self.seam_hold_m,
                           min_time_s=self.min_time_s,
                           fine_min_time_s=self.fine_min_time_s,
                           fine_damping_per_s=self.fine_damping_per_s)  # fmt: skip
        _check_positive("DrapeConfig", fine_residual_mean=self.fine_residual_mean,
                        coarse_tangled_fraction=self.coarse_tangled_fraction)  # fmt: skip
        if not self.fine_inertia_scale >= 1.0:
            raise SandboxError(f"DrapeConfig.fine_inertia_scale must be at least 1, got "
                               f"{self.fine_inertia_scale}")  # fmt: skip

    @property
    def implicit(self) -> bool:
        return self.integrator == "implicit_euler"


def config_dict(config) -> dict:
    """A config (nested dataclasses) as a plain dict, for metrics.json."""
    out = {}
    for f in fields(config):
        value = getattr(config, f.name)
        out[f.name] = config_dict(value) if dataclasses.is_dataclass(value) else value
    return out


IMPLICIT_GARMENT_EDGE_M = 0.03
"""Finest mesh edge [m] at which ``implicit_euler`` drapes converge: at 1 cm Newton does not
converge in its iterations per 1/60 s step (15-30 s a step), so a drape takes hours. A finer
mesh gets :func:`implicit_mesh_warning`, not an error."""

EXPLICIT_GARMENT_EDGE_M = 0.01
"""Mesh edge [m] of an explicit drape when none is given: the gallery's 1 cm."""


def default_edge_m(integrator: str) -> float:
    """The mesh edge [m] the CLI and the gallery use when none is given."""
    return IMPLICIT_GARMENT_EDGE_M if integrator == "implicit_euler" else EXPLICIT_GARMENT_EDGE_M


def implicit_mesh_warning(integrator: str, edge_length_m: float | None) -> str | None:
    """The warning for an ``implicit_euler`` drape meshed finer than
    :data:`IMPLICIT_GARMENT_EDGE_M`, or None."""
    if integrator != "implicit_euler" or edge_length_m is None:
        return None
    if edge_length_m >= IMPLICIT_GARMENT_EDGE_M - 1e-9:
        return None
    return (f"implicit_euler at a {edge_length_m * 100:g} cm mesh: Newton does not converge "
            f"within its iterations per step on garments finer than "
            f"{IMPLICIT_GARMENT_EDGE_M * 100:g} cm (measured at 1 cm: 15-30 s per 1/60 s "
            f"step, so hours per drape; docs/implicit.md). Use symplectic_euler at this mesh, "
            f"or --edge-cm {IMPLICIT_GARMENT_EDGE_M * 100:g} with implicit_euler.")  # fmt: skip


_SECTIONS = {"sewing": SewingConfig, "repair": RepairConfig, "acceptance": AcceptanceConfig,
             "limits": ResourceLimits, "fit": FitConfig}  # fmt: skip


def _from_table(cls, table, where: str, base=None):
    """An instance of the config dataclass ``cls`` from a TOML/JSON table; unknown keys and
    values of the wrong type are refused with a message naming ``where`` and the key."""
    if not isinstance(table, dict):
        raise SandboxError(f"{where}: expected a table of settings, got {type(table).__name__}")
    names = {f.name: f for f in fields(cls)}
    unknown = sorted(set(table) - set(names))
    if unknown:
        raise SandboxError(f"{where}: unknown setting(s) {', '.join(unknown)}; known: "
                           f"{', '.join(sorted(names))}")  # fmt: skip
    values = {}
    for key, value in table.items():
        if key in _SECTIONS and cls is DrapeConfig:
            value = _from_table(_SECTIONS[key], value, f"{where}.{key}", getattr(base, key, None))
        elif isinstance(value, bool) != isinstance(getattr(cls(), key), bool) or not isinstance(
            value, bool | int | float | str | type(None)
        ):
            raise SandboxError(f"{where}.{key}: {value!r} is not a valid value for this setting")
        values[key] = value
    try:
        return dataclasses.replace(base, **values) if base is not None else cls(**values)
    except SandboxError as exc:
        raise SandboxError(f"{where}: {exc}") from None
    except TypeError as exc:
        raise SandboxError(f"{where}: {exc}") from None


def drape_config_from_dict(table: dict, where: str = "drape settings",
                           base: DrapeConfig | None = None) -> DrapeConfig:  # fmt: skip
    """A :class:`DrapeConfig` from a table of its field names (sub-tables ``sewing``,
    ``repair``, ``acceptance``); fields not given keep ``base``'s values (default: the
    defaults)."""
    return _from_table(DrapeConfig, table, where, base or DrapeConfig())


def load_drape_config(path) -> DrapeConfig:
    """A :class:`DrapeConfig` from a TOML file of its fields (see docs/drape.md)."""
    import tomllib
    from pathlib import Path

    p = Path(path)
    if not p.is_file():
        raise SandboxError(f"{p}: no such drape settings file")
    try:
        table = tomllib.loads(p.read_text())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise SandboxError(f"{p}: not a TOML file ({exc})") from None
    return drape_config_from_dict(table, str(p))
