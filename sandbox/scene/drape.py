"""Drape a garment on the mannequin (issue 5, paper §2.3-2.5 and Fig. 7).

pattern (JSON or a library garment) -> mesh each panel (:mod:`sandbox.pattern.panel_mesh`)
-> place it around the mannequin (:mod:`sandbox.pattern.place`) -> ModelBuilder (cloth
with its grain, seams) -> the mannequin as a :class:`~sandbox.collision.body.BodyCollider`
-> the same :class:`~sandbox.scene.build.Scene` that :func:`~sandbox.scene.run.run_scene`
runs -> outputs (garment and body meshes, front and back renders, metrics with the ease).

Simulation settings for draping (see docs/drape.md):

* time step from :func:`~sandbox.scene.build.stable_dt_estimate` (× 0.9), a whole number of
  steps per 1/30 s frame (explicit symplectic Euler, Eq. 2);
* damping γ = :data:`DRAPE_DAMPING_PER_S` (mass-proportional, F = -γ m v): draping looks for
  the rest state, not the motion, so the cloth is damped about 4× more than the default
  scene (0.5 /s); the terminal speed g/γ ≈ 2.5 m/s is still far above what a drape needs;
* the paper's stop rule: every vertex moved less than 1.5 mm and the mean less than 0.1 mm
  during one frame, after :data:`DRAPE_MIN_TIME_S` (the seams need ~0.1 s to close);
* contact thickness 2 mm, friction 0.4 / 0.3 against the body; self-collision on.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sandbox.errors import SandboxError

log = logging.getLogger(__name__)

DRAPE_DAMPING_PER_S = 2.0
SEAM_REFERENCE_EDGE_M = 0.01
"""A seam spring is as stiff as the cloth (its larger stretch stiffness [N/m]) on a mesh of
this edge [m]. On a coarser mesh each spring stands for a longer piece of seam and carries
more of the garment's weight, so its stiffness grows with the edge: the seam's stiffness
per length, and its gap under the weight, do not depend on the mesh. At 3 cm with the
cloth's stiffness, the T-shirt's and the long-sleeve shirt's shoulder seams hung 2.0-2.1 mm
open and the raglan top's 2.5 mm (implicit gallery of 3 Dec 2026). A finer mesh keeps the
cloth's stiffness."""
SEW_GAP_M = 2e-3
"""Sewing ends when every seam spring is shorter than this [m] (or at SEW_TIME_LIMIT_S)."""
SEW_TIME_LIMIT_S = 1.5
SEW_STIFFNESS_FACTOR = 0.05
"""Seam springs pull at this fraction of their final stiffness while sewing (no gravity)."""
SEW_MAX_DT_S = 0.0
"""Off by default (0): set to 1e-4 to soften a stiff cloth while it sews, as the code did from
2 Dec 2026 until the speed limit (:data:`SEW_SPEED_LIMIT_M_S`) replaced it: softened cloth
compresses under the seams' pull and the rolled hems it left failed three sleeveless tops at
1 cm (docs/drape.md). While sewing, an explicit scene whose step is shorter than this [s] (a
stiff fabric or a fine mesh) softens its cloth (membrane and bending) so that this step is
stable (the stable step goes as 1/sqrt(stiffness)), but by no more than
:data:`SEW_STIFFNESS_FACTOR`; the seams close with that longer step. A placed panel starts a
few per cent strained where it is wrapped around the body, and at full stiffness that strain
energy shook a stiff fabric at a median 10-17 m/s for the whole sewing phase (polyester at
1.5 cm, dt = 20 us; speed ~ strain x sqrt(E/density)): every step rebuilt the self-collision
list, and the seams were still open at the time limit (ad-hoc runs, docs/drape.md "Run").
Soft fabrics sew as before: with jersey at 3 cm (0.4 ms steps) softened too and sewn at 1.9
ms steps, four sleeved tops of the quick gallery ended with 1-4 vertices inside the body."""
SEW_SELF_COLLISION = True
"""Self-collision during the sewing phase too. Off, seams close faster and a panel that starts
on the wrong side of another can pass through it, but the garment keeps those crossings
(gallery at 3 cm: 44 intersecting pairs on the T-shirt and 110 on the A-line dress without
it, 5 and 0 with it, for about 3 x the wall time)."""
SEW_CLOTH_MIN_FACTOR = 0.05
"""The softest a stiff cloth is made while it sews (a factor on its membrane and bending
stiffness; see :data:`SEW_MAX_DT_S`). Soft cloth compresses instead of moving as a whole:
the halter top (cotton, 1.5 cm) sewn at 0.05 ends sewing with its front's lowest point
15.3 cm higher than placed (the panels pulled up to the neckband, the lower part rolled),
at 0.25 3.4 cm but its seams 4.2 mm open at the 1.5 s limit, unsoftened 3.3 cm, sewn in
11 frames (ad-hoc script, 2 Dec 2026)."""
SEW_GRAVITY_TOPS = 0.3
"""Fraction of gravity while a garment that hangs from the shoulders is sewn (0: none, like
every garment). Measured at 3 cm (2 Dec 2026, ``benchmarks/bench_drape.py --sew-gravity``):
without gravity the armhole seams, whose sleeve caps start outside and above the bodice,
pull the T-shirt's bodice up 3.3 cm while it is sewn, and the sleeveless blouse's back
ends folded up (3.9 % of its area turned over); with full gravity the T-shirt's bodice
rises 1.0 cm and the blouse hangs straight (0.1 %), but the weight holds the seams open
against their 5 % sewing stiffness: the tank top's were still 46 mm open at the 1.5 s
limit (12 mm without) and ended 3.9 mm (1.4 mm), failing the seam-gap acceptance.
From the fifteenth session (2 Dec 2026) 0.3: the 1 cm blouse (silk) sewn without gravity
ended with its back folded at the waist (2.4 % of its area turned over, 1 crossing pair);
with 0.3 it hangs straight (0.8 %) and meets the acceptance (docs/drape.md)."""
SEW_SPEED_LIMIT_M_S = 3.0
"""While seams close, no particle keeps a speed above this [m/s] (the explicit solver's
``speed_limit``; 0: none); off again for the ramp. A seam spring pulls its two ends
together at the cloth's own wave speed: the sleeveless blouse (polyester, 1 cm) placed with
7-11 cm side-seam gaps had them closed within one frame, and the shock flung its lower part
28 cm up into a roll that it kept (17 % of its area turned over). At 3 m/s its lowest point
rises 4.6 cm while it is sewn and every gap ends below 0.5 mm. At 1 m/s the seams' pull,
capped before the body's contact response, could no longer drag an end pressed into the
body past friction: the tank top's underarm corners (3 cm mesh) stayed 3.5 mm open
(ad-hoc scripts and ``benchmarks/bench_drape.py --sew-speed-limit``, 2 Dec 2026)."""
SEW_FRICTION = None
"""Friction coefficient of the body (static and kinetic) and of the cloth on itself while
sewing (``None``: the scene's own, the default). Frictionless sewing let a seam end pressed
into the body slide round to its partner, but at 3 cm the raglan top then ended with 6
vertices inside the body and the long-sleeve shirt with 2 (1 m/s speed limit)."""
SEW_FRICTION_IMPLICIT = 0.0
"""The same for ``implicit_euler``, whose friction acts inside the step's energy with the
penalty's contact force at each Newton iterate: that force includes the seams' own pull
into the body, so at the scene's friction (cotton on the body, 0.4) the halter top's neck
seams stalled 13.5 mm open at 3 cm; frictionless they closed in 11 frames (ad-hoc trace,
3 Dec 2026). The drape after the sewing has the scene's friction."""
SEW_AT_REST_IMPLICIT = True
"""With ``implicit_euler``, a garment sewn weightless (gravity fraction 0: the skirts, see
:data:`SEW_GRAVITY_TOPS`) ends every sewing frame, the ramp's included, at rest (velocities
set to 0): the seams' pull moves the panels but is not kept as momentum. The explicit
solver's :data:`SEW_SPEED_LIMIT_M_S` does not act on the implicit solver, and backward Euler
at 1/60 s keeps what the seams give: the 3 cm circle skirt, placed with 10-13 cm gaps,
reached 3 m/s in its second frame, its hem swung up to 22.8 cm between the legs, the gaps
grew to 25-36 mm and the sewing stalled 22.7 mm open after 13 frames (65 s), with 222 crossing pairs
to untangle. At rest after each frame its gaps were below 2 mm after 3 frames (18 s, the
ramp included). With γ = 20/s instead (10 times the drape's damping) it still stalled
12.9 mm open (ad-hoc traces, 4 Dec 2026).

Not for garments sewn with gravity (the tops and dresses): from rest, a frame of 0.3 g moves
the cloth 1.6 mm, so the sewing's gravity, there to hang them straight, no longer acts. With
every garment sewn at rest (one ad-hoc implicit gallery run, 4 Dec 2026) the circle skirt
met the acceptance but the long-sleeve shirt's sewing stalled 13.6 mm open (6.1 mm before)
and ended with a 4.2 mm seam gap, and the A-line dress did not settle in 8 s."""
SEW_STALL_FRAMES = 6
SEW_STALL_SHRINK = 0.95
"""Sewing also ends when the largest seam gap has not shrunk below this fraction of what it
was :data:`SEW_STALL_FRAMES` frames before (``sew_stalled`` in the metrics): the last open
spring is then a corner held by the body, such as a side seam's top in the armpit crease
(3 mm at 3 cm), which the time limit would not close but which cost the 1 cm sleeveless
blouse 51 sewing frames, about 18 min on one core. The ramp's stiffer seams close it."""
SEW_RAMP_FRAMES = 6
"""Frames over which the seams stiffen geometrically to their final stiffness."""
SEW_NARROW_EXCLUSION = False
"""After sewing, narrow the self-collision's seam exclusion from the partners and their
mesh neighbours to the partners alone (:meth:`SelfCollider.set_seam_partners`), so the
panels beside a closed seam cannot pass through each other while the garment drapes.

Off: the 1 cm T-shirt's crossing pairs at its underarm junction are made while it is sewn
(5 after sewing, 5 at the end of a drape without the option), and self-collision does not
undo crossings it is handed, so narrowing afterwards cannot remove them (that run was
stopped before its end). Narrowed from the start, sewing included, it ended with 0 pairs
but a 3.2 mm seam gap at the junction, still moving at the 30 min wall-clock limit. Ad-hoc
runs of the thirteenth session, whose start also fitted each sleeve rigidly to its
armhole (the twelfth session's experiment; docs/drape.md)."""
UNTANGLE_AFTER_SEWING = True
"""Smooth away crossing triangle pairs once the seams are sewn (:func:`untangle_state`):
a panel beside a closing seam can slip through its neighbour in the seam zone, which the
self-collider leaves free so the seam can close, and contact never undoes a crossing."""
REPAIR_NARROW_EXCLUSION = True
"""When a drape ends with crossing pairs and is untangled (:data:`UNTANGLE_REPAIRS`), settle
it with the self-collision's seam exclusion narrowed to the partners alone
(:data:`SEW_NARROW_EXCLUSION` explains the choice): the seams are closed by then, and with
the partners' mesh neighbours left free the panels beside a seam cross again. The 1 cm
long-sleeve shirt, size 12, ended its drape with 2 pairs where its back meets the right
sleeve at the underarm, untangled to 0, and after 0.2 s of settling had the same 2 again
(seventeenth session). Restarted at rest from its final state (ad-hoc script, 1 s limit),
untangled and settled, it kept 0 pairs narrowed (seam gap 0.23 mm) and also without
(0.24 mm): the restart does not tell the two apart, so the narrowing is a precaution
whose cost is bounded (only a drape that ended tangled gets here)."""
UNTANGLE_REPAIRS = 2
"""At most this many untangling passes in all (the one after sewing included); a drape that
ends with crossing pairs and has simulated time left is untangled and run on to the stop
rule again, for at least :data:`UNTANGLE_SETTLE_S`."""
UNTANGLE_SETTLE_S = 0.2
UNTANGLE_CLEARANCE_M = 3e-3
"""Untangled vertices are pushed out to this distance from the body [m] (1.5 x the contact
thickness)."""
DRAPE_STRAIN_DAMPING_S = 4e-6
"""Strain-rate damping β [s] of the drape's membrane (``Model.strain_damping_s``,
:func:`~sandbox.sim.forces.membrane_damping_gradient`; 0: off, as before the sixteenth
session). A mode of angular frequency ω decays at about β ω²/2 [1/s]: 10-20 /s for the
contact chatter below, 1e-4 /s for a garment swinging at 10 rad/s.

Body contact keeps stiff cloth at 1 cm chattering: the long-sleeve shirt (cotton) restarted
at rest from a drape's state kept a sum of squared speeds of ~2,000 m²/s² (0.4 m/s per
vertex, 0.22 mm mean motion per frame) whatever the step (dt/2 alike) and with
self-collision off; with the body moved away it decayed at the mass damping's rate, with
frictionless contact it grew. β = 1e-6 s cut it to ~200-350 and β = 3e-6 s to ~70-110, the
mean motion per frame after 0.6 s from 0.26 to 0.11 and 0.10 mm (ad-hoc scripts, 3 Dec
2026); with 2e-6 the 1 cm long-sleeve shirt met the stop rule in 686 s where it was still
moving at the 30 min limit (docs/drape.md), but at size 8 it still moved 0.20 mm a frame at
the limit; with 4e-6 (the default since the seventeenth session) it met the rule in 410 s.
The explicit step shrinks by √(1+ζ²) − ζ, ζ = β / (the undamped stable step): ~18 % for
cotton at 1 cm with 4e-6 s."""
IMPLICIT_GARMENT_EDGE_M = 0.03
"""Finest mesh edge [m] at which ``implicit_euler`` drapes have been measured to work: the
pencil skirt at 3 cm converges (about 25 s). At 1 cm Newton does not converge in its 50
iterations per 1/60 s step, neither while sewing nor after an explicit sewing phase (15-30 s
per step on the A-line skirt, docs/implicit.md), so a drape would take hours. A finer mesh
gets :func:`implicit_mesh_warning` (logged and kept in metrics.json), not an error. At 3 cm
all 14 garments meet the acceptance with it (docs/implicit.md, "Skirts sewn at rest";
docs/gallery-implicit)."""
DRAPE_MIN_TIME_S = 0.5
DRAPE_TIME_LIMIT_S = 8.0
DRAPE_WALL_LIMIT_S = 1800.0
FRAME_RATE_HZ = 30.0
STOP_MAX_M = 1.5e-3
STOP_MEAN_M = 1.0e-4
EASE_LANDMARKS = {"bust": "bust_point_left", "waist": "waist_front", "hip": "hip_front"}
GARMENT_COLOR = (0.32, 0.45, 0.75)
BODY_COLOR = (0.82, 0.76, 0.68)


@dataclass
class DrapeResult:
    """A finished drape: the scene, the run, the metrics written and the files."""

    scene: object
    run: object
    metrics: dict
    paths: dict = field(default_factory=dict)


# --------------------------------------------------------------------------------------
# inputs


def garment_names() -> list[str]:
    """Names of the library's garments (empty until the drafting package exists)."""
    try:
        from sandbox.drafting import garment_names as names
    except ImportError:
        return []
    return list(names())


def resolve_pattern(garment_or_path, mannequin=None):
    """A loaded :class:`~sandbox.pattern.spec.Pattern` from a path, a dict or a garment name.

    Library garments are drafted for the mannequin's measurements.
    """
    from sandbox.pattern.spec import Pattern, load_pattern

    if isinstance(garment_or_path, Pattern):
        return garment_or_path
    if isinstance(garment_or_path, dict):
        return load_pattern(garment_or_path)
    text = str(garment_or_path)
    path = Path(text)
    if path.suffix.lower() == ".json" or path.exists():
        if not path.is_file():
            raise SandboxError(f"{path}: no such pattern file")
        return load_pattern(path)
    names = garment_names()
    if text not in names:
        listed = ", ".join(names) if names else "none yet"
        raise SandboxError(f"unknown garment {text!r}: give a pattern .json file or one of the "
                           f"library's garments ({listed})")  # fmt: skip
    from sandbox.drafting import draft

    measurements = mannequin.measurements_requested if mannequin is not None else None
    data = draft(text, measurements, mannequin=mannequin)
    return load_pattern(data, where=f"garment {text!r}")


def check_garment(garment) -> None:
    """Raise SandboxError early (before Taichi starts) for a missing file or unknown name."""
    path = Path(str(garment))
    if path.suffix.lower() == ".json" or path.exists():
        if not path.is_file():
            raise SandboxError(f"{path}: no such pattern file")
        return
    names = garment_names()
    if str(garment) not in names:
        listed = ", ".join(names) if names else "none yet"
        raise SandboxError(f"unknown garment {str(garment)!r}: give a pattern .json file or one "
                           f"of the library's garments ({listed})")  # fmt: skip


def make_mannequin(size: int | None = None, measurements: dict | None = None):
    """The mannequin for a drape: a database size (default 12), resized by any
    measurements given in cm (keys of :data:`sandbox.mannequin.KEYS`)."""
    from sandbox.mannequin import build_mannequin
    from sandbox.mannequin.cli import FLAGS
    from sandbox.mannequin.measurements import size_entry

    given = {k: float(v) for k, v in (measurements or {}).items() if v is not None}
    if not given:
        return build_mannequin(size=size if size is not None else 12)
    base = size_entry(size if size is not None else 12).measurements
    return build_mannequin(base.replace(**given), size=size, flag_names=FLAGS)


def material_for(pattern, fabric=None):
    """The cloth material: ``fabric`` (a preset name, a material table or a Material), else
    the pattern's own fabric."""
    from sandbox.sim.materials import Material, get_material, material_from_spec

    choice = pattern.fabric if fabric is None else fabric
    if isinstance(choice, Material):
        return choice
    where = f"{pattern.source}: fabric"
    if isinstance(choice, str):
        return get_material(choice, where=where)
    return material_from_spec(choice, where=where)


# --------------------------------------------------------------------------------------
# build


def build_drape(
    pattern,
    mannequin,
    *,
    fabric=None,
    edge_length_m: float | None = 0.01,
    damping_per_s: float = DRAPE_DAMPING_PER_S,
    time_limit_s: float = DRAPE_TIME_LIMIT_S,
    wall_limit_s: float = DRAPE_WALL_LIMIT_S,
    min_time_s: float = DRAPE_MIN_TIME_S,
    thickness_m: float = 2e-3,
    self_collision: bool = True,
    integrator: str = "symplectic_euler",
    dt_s: float | None = None,
    sew_pattern: bool = True,
    seam_capacity: int = 0,
    strain_damping_s: float | None = None,
):
    """Mesh, place and sew a pattern on the mannequin: a Scene for ``run_scene``.

    Args:
        pattern: a loaded Pattern, a pattern dict or a path.
        mannequin: a :class:`~sandbox.mannequin.Mannequin`.
        fabric: override of the pattern's fabric (preset name, table or Material).
        edge_length_m: target mesh edge [m]; None = the pattern's ``mesh_edge``.
        damping_per_s: mass-proportional damping γ [1/s].
        time_limit_s, wall_limit_s: simulated and wall-clock limits [s].
        min_time_s: the stop rule is not checked before this simulated time [s].
        thickness_m: contact thickness against the body and the cloth itself [m].
        self_collision: cloth-cloth contact (Bridson et al. 2002).
        integrator: "symplectic_euler" (Eq. 2) or "implicit_euler".
        dt_s: time step [s]; None = 0.9 × the stability estimate (1/60 s implicit).
        sew_pattern: sew the pattern's seams (False: the panels start unsewn, for the
            interactive sandbox's click-to-sew, :func:`seam_springs`).
        seam_capacity: room for this many more seam springs, sewn while the scene runs.
        strain_damping_s: the membrane's strain-rate damping β [s]; None =
            :data:`DRAPE_STRAIN_DAMPING_S` (explicit only: 0 with ``implicit_euler``).
    """
    from sandbox import runtime
    from sandbox.collision.body import BodyCollider
    from sandbox.pattern.panel_mesh import mesh_pattern, pattern_seam_sides
    from sandbox.pattern.place import PlacementBody, place_pattern
    from sandbox.scene.build import (
        DT_SAFETY,
        IMPLICIT_DT_S,
        Scene,
        build_self_collider,
        damped_step,
        make_solver,
        stable_dt_estimate,
    )
    from sandbox.scene.spec import (
        INTEGRATORS,
        CollisionSpec,
        SceneSpec,
        SimulationSpec,
        StopSpec,
    )
    from sandbox.sim.builder import ModelBuilder

    pattern = resolve_pattern(pattern, mannequin)
    if edge_length_m is not None and not (edge_length_m > 0 and math.isfinite(edge_length_m)):
        raise SandboxError(f"edge length must be a positive number of metres, got {edge_length_m}")
    if integrator not in INTEGRATORS:
        raise SandboxError(f"integrator must be symplectic_euler or implicit_euler, got "
                           f"{integrator!r}")  # fmt: skip
    material = material_for(pattern, fabric)
    meshes = mesh_pattern(pattern, edge_length_m)
    body = PlacementBody(mannequin)
    placed = place_pattern(pattern, meshes, body)
    runtime.ensure_init()
    builder = ModelBuilder()
    index = {}
    for name, mesh in meshes.items():
        index[name] = builder.add_cloth(
            name=name,
            pattern_uv=mesh.points,
            triangles=mesh.triangles,
            material=material,
            grain_rad=mesh.grain_rad,
            positions=placed[name],
            where=f"{pattern.source}: panel {name!r}",
            meta={"mesher": "panel_mesh"},
        )
    edge = pattern.mesh_edge_m if edge_length_m is None else float(edge_length_m)
    k_cloth = max(material.stretch_u_N_m, material.stretch_v_N_m)
    seam_k = k_cloth * max(1.0, edge / SEAM_REFERENCE_EDGE_M)
    names = list(meshes)
    if sew_pattern:
        for seam in pattern_seam_sides(pattern, meshes, index):
            for part in _seam_parts(seam, seam_k, names, meshes, placed):
                builder.add_seam(**part)
    model = builder.finalize(bending=True, seam_capacity=seam_capacity)
    spec = SceneSpec(
        name=pattern.name,
        description=f"drape of {pattern.name} on the mannequin",
        simulation=SimulationSpec(integrator=integrator, dt_s=dt_s, frame_rate_hz=FRAME_RATE_HZ,
                                  damping_per_s=damping_per_s),
        stop=StopSpec(max_displacement_m=STOP_MAX_M, mean_displacement_m=STOP_MEAN_M, frames=1,
                      min_time_s=min_time_s, time_limit_s=time_limit_s,
                      wall_limit_s=wall_limit_s),
        collision=CollisionSpec(thickness_m=thickness_m, self_collision=self_collision),
        source=pattern.source,
    )  # fmt: skip
    model.colliders = [
        BodyCollider(mannequin.vertices, mannequin.triangles, thickness_m=thickness_m,
                     friction_static=spec.collision.friction_static,
                     friction_kinetic=spec.collision.friction_kinetic, name="mannequin",
                     closed=True)
    ]  # fmt: skip
    model.self_collider = build_self_collider(model, spec)
    frame = 1.0 / FRAME_RATE_HZ
    limit = stable_dt_estimate(model)
    beta = DRAPE_STRAIN_DAMPING_S if strain_damping_s is None else float(strain_damping_s)
    if not (beta >= 0 and math.isfinite(beta)):
        raise SandboxError(f"strain damping must be >= 0 s, got {strain_damping_s}")
    if integrator == "implicit_euler":
        beta = 0.0  # backward Euler damps the fast modes itself; its Newton step has no β
    model.strain_damping_s[None] = beta
    auto = min(frame, IMPLICIT_DT_S if integrator == "implicit_euler" else
               DT_SAFETY * damped_step(limit, beta))  # fmt: skip
    dt = dt_s if dt_s is not None else auto
    steps = max(1, math.ceil(frame / dt - 1e-9))
    dt = frame / steps
    control = model.control(gravity=spec.simulation.gravity_m_s2, damping_per_s=damping_per_s)
    scene = Scene(spec, model, model.state(), control, make_solver(model, integrator), dt, steps,
                  limit)  # fmt: skip
    scene.pattern = pattern
    scene.mannequin = mannequin
    scene.placement_body = body
    scene.builder, scene.meshes, scene.piece_index, scene.placed = builder, meshes, index, placed
    # seams sewn live (the app's clicks) keep the cloth's own stiffness: with the edge-scaled
    # one the app's click-sewing test failed 1 run in 4 (3 Dec 2026, not yet understood)
    scene.seam_stiffness_N_m = k_cloth
    scene.edge_length_m = edge
    scene.integrator_warning = implicit_mesh_warning(integrator, scene.edge_length_m)
    if scene.integrator_warning:
        log.warning("%s: %s", pattern.name, scene.integrator_warning)
    return scene


def _seam_parts(seam: dict, seam_k: float, names, meshes, placed) -> list[dict]:
    """One pattern seam (``pattern_seam_sides`` form) as ``add_seam`` keyword sets."""
    if seam.get("stiffness_N_m") is None:
        seam["stiffness_N_m"] = seam_k
    if seam.get("direction", "auto") == "auto":
        seam["direction"] = seam_direction(seam, names, meshes, placed)
    return split_seam(seam, names, meshes)


def seam_springs(scene, seams: list, positions: np.ndarray | None = None):
    """Seam springs of pattern seam records, for a scene built by :func:`build_drape`.

    Args:
        scene: the drape scene (its pattern, meshes and builder).
        seams: :class:`~sandbox.pattern.spec.SeamSpec` records (panel names, edge indices).
        positions: (n, 3) world positions [m] the direction rule looks at (default: the
            current state), so a seam made live is sewn the way the panels now lie.
    Returns ``(pairs (k, 2), rest (k,) [m], stiffness (k,) [N/m])``: the same springs the
    builder makes for a pattern file (Fig. 5 direction rule, parametric matching).
    """

    from sandbox.pattern.panel_mesh import pattern_seam_sides

    if not seams:
        return np.zeros((0, 2), np.int64), np.zeros(0), np.zeros(0)
    x = scene.state.positions() if positions is None else np.asarray(positions, float)
    names = list(scene.meshes)
    placed = {}
    for piece in scene.model.pieces:
        placed[piece.name] = x[piece.particle_start : piece.particle_start + piece.particle_count]
    tmp = dataclasses.replace(scene.pattern, seams=list(seams))
    builder = scene.builder
    saved = builder._seams
    builder._seams = []
    try:
        for seam in pattern_seam_sides(tmp, scene.meshes, scene.piece_index):
            for part in _seam_parts(seam, scene.seam_stiffness_N_m, names, scene.meshes, placed):
                builder.add_seam(**part)
        starts = [p.particle_start for p in scene.model.pieces]
        pairs, rest, k = builder._sew(x, starts)
    finally:
        builder._seams = saved
    keep = pairs[:, 0] != pairs[:, 1]  # a shared corner (a dart's tip) needs no spring
    return pairs[keep], rest[keep], k[keep]


def seam_direction(seam: dict, names: list[str], meshes: dict, placed: dict,
                   samples: int = 9) -> str:  # fmt: skip
    """ "same" or "reverse" for an "auto" seam, from the placed panels.

    The paper's rule (Fig. 5a) compares the distances between the two lines' end points. It
    cannot decide a closed line (a sleeve cap sewn into an armhole: both ends of each line
    meet at the underarm), so the lines are compared at ``samples`` points evenly spaced by
    rest arc length (the ends included, so open seams get Fig. 5a's answer in all usual
    cases): the direction with the smaller summed distance wins.
    """

    def line(side):
        world, rest = [], []
        for piece, idx in side:
            idx = np.asarray(idx)
            world.append(placed[names[piece]][idx])
            rest.append(meshes[names[piece]].points[idx])
        w, r = np.vstack(world), np.vstack(rest)
        # rest arc length within each part, parts joined end to end
        seg = np.linalg.norm(np.diff(r, axis=0), axis=1)
        cuts = np.cumsum([len(p) for p in world])[:-1] - 1
        seg[cuts] = 0.0  # no rest length between the end of one part and the next
        s = np.concatenate([[0.0], np.cumsum(seg)])
        t = np.linspace(0.0, s[-1], samples)
        return np.stack([np.interp(t, s, w[:, k]) for k in range(3)], 1)

    a, b = line(seam["side_a"]), line(seam["side_b"])
    same = np.linalg.norm(a - b, axis=1).sum()
    rev = np.linalg.norm(a - b[::-1], axis=1).sum()
    return "same" if same <= rev else "reverse"


def split_seam(seam: dict, names: list[str], meshes: dict) -> list[dict]:
    """A seam whose sides join edges of several panels, as seams between single edges.

    The builder parametrises a merged side by its pattern coordinates; edges of different
    panels do not meet in the pattern plane, so the jump between them would take a share of
    the parameter (an armhole made of the back and front armholes: the sleeve cap's middle
    was sewn to the gap, with long rest lengths). Here both sides are parametrised by their
    own arc length without the jumps, cut at every edge end of either side (at the nearest
    vertex) and sewn piecewise with direction "same" (side b reversed first if needed).
    """
    a, b = list(seam["side_a"]), list(seam["side_b"])
    if len(a) == 1 and len(b) == 1:
        return [seam]
    if seam["direction"] == "reverse":
        b = [(piece, np.asarray(idx)[::-1]) for piece, idx in reversed(b)]

    def params(side):
        out, start = [], 0.0
        for piece, idx in side:
            pts = meshes[names[piece]].points[np.asarray(idx)]
            cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
            out.append((piece, np.asarray(idx), start + cum))
            start += cum[-1]
        return [(piece, idx, t / max(start, 1e-12)) for piece, idx, t in out]

    pa, pb = params(a), params(b)
    cuts = sorted({0.0, 1.0} | {float(t[-1]) for _, _, t in pa[:-1] + pb[:-1]})
    merged = [cuts[0]]
    for c in cuts[1:]:
        if c - merged[-1] > 1e-3:
            merged.append(c)
    merged[-1] = 1.0

    def piece_of(side, t0, t1):
        mid = 0.5 * (t0 + t1)
        for piece, idx, t in side:
            if t[0] - 1e-9 <= mid <= t[-1] + 1e-9:
                i0 = int(np.argmin(np.abs(t - t0)))
                i1 = int(np.argmin(np.abs(t - t1)))
                if i1 <= i0:
                    i0, i1 = (i0, i0 + 1) if i0 + 1 < len(idx) else (i0 - 1, i0)
                return piece, idx[i0 : i1 + 1]
        return None

    out = []
    for t0, t1 in zip(merged[:-1], merged[1:], strict=True):
        sa, sb = piece_of(pa, t0, t1), piece_of(pb, t0, t1)
        if sa is None or sb is None:
            continue
        out.append(dict(seam, side_a=[sa], side_b=[sb], direction="same"))
    return out


# --------------------------------------------------------------------------------------
# ease


def ease_cm(x: np.ndarray, triangles: np.ndarray, mannequin, body=None) -> dict:
    """Ease at bust, waist and hip: garment girth minus body girth [cm].

    At the height of each landmark (bust point, waist front, hip front), the garment's
    section (all its pieces cut by the horizontal plane) is reduced to the pieces around
    the torso (cut lines whose centre lies within 75 % of the torso's half-width: sleeves
    are left out) and measured like the tape measure measures the body: the perimeter of
    the convex hull. ``None`` where the garment does not reach that height or its cut does
    not go around the body axis.
    Returns ``{"ease_bust_cm", "ease_waist_cm", "ease_hip_cm", "garment_girth_*_cm",
    "body_girth_*_cm"}``.
    """
    from scipy.spatial import ConvexHull, QhullError

    from sandbox.mannequin.tape import girth_at, section_polylines
    from sandbox.pattern.place import PlacementBody

    body = body or PlacementBody(mannequin)
    out = {}
    for key, lm in EASE_LANDMARKS.items():
        out[f"ease_{key}_cm"] = None
        out[f"garment_girth_{key}_cm"] = None
        out[f"body_girth_{key}_cm"] = None
        if lm not in body.landmarks:
            continue
        y = float(body.landmarks[lm][1])
        frame = body.frame("torso", y)
        axis = frame.origin[[0, 2]]
        try:
            body_girth = girth_at(body.vertices, body.triangles, y, axis_xz=axis)
        except SandboxError:
            continue
        out[f"body_girth_{key}_cm"] = 100.0 * body_girth
        sel = body.vertices[body.parts["torso"] & (np.abs(body.vertices[:, 1] - y) < 0.02)]
        half = float(np.abs(sel[:, 0] - axis[0]).max()) if len(sel) else 0.2
        cuts = section_polylines(x, triangles, (0.0, y, 0.0), (0.0, 1.0, 0.0))
        pts = [p[:, [0, 2]] for p, _ in cuts if abs(p[:, 0].mean() - axis[0]) <= 0.75 * half]
        if not pts:
            continue
        p2 = np.vstack(pts)
        try:
            hull = ConvexHull(p2)
        except QhullError:
            continue
        if np.any(hull.equations[:, :2] @ axis + hull.equations[:, 2] > 0):
            continue  # the cut does not go around the body
        girth = float(hull.area)
        out[f"garment_girth_{key}_cm"] = 100.0 * girth
        out[f"ease_{key}_cm"] = 100.0 * (girth - body_girth)
    return out


# --------------------------------------------------------------------------------------
# run and write


def drape(
    garment_or_path,
    *,
    size: int | None = None,
    measurements: dict | None = None,
    fabric=None,
    out_dir,
    edge_length_m: float | None = 0.01,
    render: bool = True,
    meshes: bool = True,
    progress: bool | None = None,
    mannequin=None,
    sew_self_collision: bool = SEW_SELF_COLLISION,
    **build_options,
) -> DrapeResult:
    """Drape a garment (library name, pattern file or dict) on a mannequin and write it.

    The mannequin is ``mannequin`` if given, else the database ``size`` (default 12)
    resized by ``measurements`` (cm). Writes into ``out_dir``: ``garment.obj`` /
    ``garment.ply`` (UVs = pattern coordinates [m]), ``body.obj``, ``render.png`` (front),
    ``render_back.png`` and ``metrics.json`` (``meshes=False``: no meshes). Raises
    SandboxError on bad input and SimulationDiverged (nothing written) if the run blows up.
    """
    if mannequin is None:
        mannequin = make_mannequin(size, measurements)
    pattern = resolve_pattern(garment_or_path, mannequin)
    t0 = time.perf_counter()
    scene = build_drape(pattern, mannequin, fabric=fabric, edge_length_m=edge_length_m,
                        **build_options)  # fmt: skip
    build_s = time.perf_counter() - t0
    result = run_drape(scene, progress=progress, sew_self_collision=sew_self_collision)
    metrics = drape_metrics(scene, result, build_s=build_s)
    paths = write_drape(scene, result, metrics, out_dir, render=render, meshes=meshes)
    return DrapeResult(scene, result, metrics, paths)


def sew(
    scene,
    *,
    gap_m: float = SEW_GAP_M,
    time_limit_s: float = SEW_TIME_LIMIT_S,
    self_collision: bool = SEW_SELF_COLLISION,
    gravity_fraction: float | None = None,
) -> dict:
    """Sewing phase: close the seams, then stiffen them and turn full gravity on.

    The seam springs pull at :data:`SEW_STIFFNESS_FACTOR` of their final stiffness (as stiff as
    the cloth: the seams then hold the garment's weight) until every spring is shorter than
    ``gap_m``, the largest gap stalls (:data:`SEW_STALL_FRAMES`) or ``time_limit_s`` of
    simulated time has passed. Meanwhile no particle keeps a speed above
    :data:`SEW_SPEED_LIMIT_M_S`, and the body's and the cloth's friction is :data:`SEW_FRICTION`
    if that is set (default: the scene's own); a stiff cloth is softened only if
    :data:`SEW_MAX_DT_S` is set (off by default). Then seams and cloth stiffen together over
    :data:`SEW_RAMP_FRAMES` frames at the scene's own step, without the speed limit. With
    ``implicit_euler`` and no gravity, every sewing frame ends at rest
    (:data:`SEW_AT_REST_IMPLICIT`). With
    ``self_collision=False`` the cloth does not collide with itself while sewing (seam edges
    that start on the wrong side of another panel, like a sleeve cap over the bodice, can then
    reach their partner). Returns ``{"sew_sim_time_s", "sew_wall_time_s", "sew_frames",
    "sew_gap_m", "sew_dt_s", "sew_cloth_stiffness_factor", "sew_gravity_fraction",
    "sew_stalled", "sew_at_rest"}`` (``sew_dt_s`` and the factor: the sewing frames' step [s]
    and the cloth's stiffness factor in them).

    ``gravity_fraction`` scales gravity while sewing. Default: :data:`SEW_GRAVITY_TOPS` for
    a garment that hangs from the shoulders (:func:`hangs_from`), none for one that hangs
    from the waist, whose panels would slide down before their seams hold them (the circle
    skirt's gores did).
    """
    from sandbox import runtime
    from sandbox.scene.run import SimulationDiverged

    model, solver, state, control = scene.model, scene.solver, scene.state, scene.control
    out = {"sew_sim_time_s": 0.0, "sew_wall_time_s": 0.0, "sew_frames": 0, "sew_gap_m": 0.0}
    if not model.seam_count:
        return out
    k_final = model.seam_stiffness_np.astype(runtime.float_dtype())
    pairs, rest = model.seam_pairs_np, model.seam_rest_np
    gravity = control.gravity[None]
    t0 = time.perf_counter()
    solver.reset_watch()
    if gravity_fraction is None:
        mannequin = getattr(scene, "mannequin", None)
        shoulders = mannequin is not None and hangs_from(
            model.initial_positions_np, mannequin) == "shoulder_point_left"  # fmt: skip
        gravity_fraction = SEW_GRAVITY_TOPS if shoulders else 0.0
    control.gravity[None] = [float(gravity_fraction) * float(g) for g in gravity]
    saved = solver.self_collider
    speed_limit = getattr(solver, "speed_limit", None)  # the explicit solver's
    if speed_limit is not None:
        speed_limit[None] = SEW_SPEED_LIMIT_M_S
    mu = [(c.mu_s, c.mu_k) for c in model.colliders if hasattr(c, "mu_s")]
    mu_saved = [(a[None], b[None]) for a, b in mu]
    mu_self = getattr(solver.self_collider, "mu", None)
    mu_self_saved = mu_self[None] if mu_self is not None else None
    friction = SEW_FRICTION
    if scene.spec.simulation.integrator == "implicit_euler":
        friction = SEW_FRICTION_IMPLICIT
    if friction is not None:
        for a, b in mu:
            a[None] = b[None] = friction
        if mu_self is not None:
            mu_self[None] = friction
    if not self_collision:
        solver.self_collider = None  # the solver runs the fused step without its passes
    frame_s = scene.dt_s * scene.steps_per_frame
    frames = max(1, math.ceil(time_limit_s / frame_s))
    ramp = [SEW_STIFFNESS_FACTOR ** (1 - k / SEW_RAMP_FRAMES) for k in range(SEW_RAMP_FRAMES + 1)]
    # A stiff cloth is softened as far as a step of SEW_MAX_DT_S needs (the stable step goes
    # as 1/sqrt(stiffness)), at most down to the seams' factor; a soft one sews as it is.
    soft, sew_steps = 1.0, scene.steps_per_frame
    if scene.spec.simulation.integrator == "symplectic_euler" and scene.dt_s < SEW_MAX_DT_S:
        soft = max(SEW_CLOTH_MIN_FACTOR, (scene.dt_s / SEW_MAX_DT_S) ** 2)
        sew_steps = max(1, math.ceil(scene.steps_per_frame * math.sqrt(soft) - 1e-9))
    model.set_seam_stiffness(k_final * ramp[0])
    if soft < 1.0:
        model.scale_cloth_stiffness(soft)
    at_rest = (SEW_AT_REST_IMPLICIT and scene.spec.simulation.integrator == "implicit_euler"
               and gravity_fraction == 0.0)  # fmt: skip
    gap, gaps, stalled = math.inf, [], False
    done = 0
    try:
        while done < frames:
            solver.advance(state, control, frame_s / sew_steps, sew_steps)
            done += 1
            if at_rest:
                state.v.fill(0.0)
            bad = solver.first_bad()
            if bad is not None:
                raise SimulationDiverged(f"{scene.spec.source}: the simulation diverged while "
                                         f"sewing (vertex {bad[1]})")  # fmt: skip
            x = state.positions()
            gap = float(np.max(np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1) - rest))
            gaps.append(gap)
            if gap < gap_m:
                break
            back = gaps[-1 - SEW_STALL_FRAMES] if len(gaps) > SEW_STALL_FRAMES else math.inf
            if gap > SEW_STALL_SHRINK * back:
                stalled = True  # a corner held by the body: the ramp's stiffer seams close it
                break
        if speed_limit is not None:  # the seams have closed: no shock left to tame
            speed_limit[None] = 0.0
        for k, f in enumerate(ramp[1:], 1):  # stiffen seams and cloth, then gravity acts
            model.set_seam_stiffness(k_final * f)
            if soft < 1.0:
                model.scale_cloth_stiffness(soft ** (1 - k / SEW_RAMP_FRAMES))
            solver.advance(state, control, scene.dt_s, scene.steps_per_frame)
            done += 1
            if at_rest:
                state.v.fill(0.0)
    finally:
        model.set_seam_stiffness(k_final)
        if soft < 1.0:
            model.scale_cloth_stiffness(1.0)
        control.gravity[None] = gravity
        solver.self_collider = saved
        if speed_limit is not None:
            speed_limit[None] = 0.0
        for (a, b), (sa, sb) in zip(mu, mu_saved, strict=True):
            a[None], b[None] = sa, sb
        if mu_self is not None:
            mu_self[None] = mu_self_saved
    if SEW_NARROW_EXCLUSION and solver.self_collider is not None:
        solver.self_collider.set_seam_partners(pairs, neighbours=False)
    out.update(sew_sim_time_s=done * frame_s, sew_wall_time_s=time.perf_counter() - t0,
               sew_frames=done, sew_gap_m=gap, sew_dt_s=frame_s / sew_steps,
               sew_cloth_stiffness_factor=soft,
               sew_gravity_fraction=float(gravity_fraction), sew_stalled=stalled,
               sew_at_rest=at_rest)  # fmt: skip
    return out


def run_drape(scene, *, progress: bool | None = None,
              sew_self_collision: bool = SEW_SELF_COLLISION):  # fmt: skip
    """Sew (:func:`sew`), then drape under gravity to the paper's stop rule (``run_scene``).

    The RunResult's metrics get the sewing phase's keys and ``total_wall_time_s``.
    """
    from sandbox.scene.run import run_scene

    sewn = sew(scene, self_collision=sew_self_collision)
    repairs = [untangle_state(scene, "after sewing")] if UNTANGLE_AFTER_SEWING else []
    result = run_scene(scene, progress=progress)
    stop = scene.spec.stop
    while len(repairs) < UNTANGLE_REPAIRS and result.metrics["intersecting_triangle_pairs"]:
        sim, wall = result.metrics["sim_time_s"], result.metrics["wall_time_s"]
        if sim >= stop.time_limit_s - 1e-9 or wall >= stop.wall_limit_s:
            break  # no time left to settle a repair
        repair = untangle_state(scene, "after the drape")
        repairs.append(repair)
        if repair["pairs_after"] >= repair["pairs_before"]:
            break
        collider = getattr(scene.solver, "self_collider", None)
        if REPAIR_NARROW_EXCLUSION and collider is not None and scene.model.seam_count:
            # the seams are closed: keep the untangled panels beside them apart
            collider.set_seam_partners(scene.model.seam_pairs_np, neighbours=False)
            repair["narrowed_seam_exclusion"] = True
        scene.spec = dataclasses.replace(scene.spec, stop=dataclasses.replace(
            stop, min_time_s=UNTANGLE_SETTLE_S, time_limit_s=stop.time_limit_s - sim,
            wall_limit_s=stop.wall_limit_s - wall))  # fmt: skip
        try:
            again = run_scene(scene, progress=progress)
        finally:
            scene.spec = dataclasses.replace(scene.spec, stop=stop)
        for key in ("steps", "frames", "sim_time_s", "wall_time_s", "compile_time_s"):
            again.metrics[key] += result.metrics[key]
        result = again
    result.metrics.update(sewn)
    result.metrics["untangle"] = repairs
    result.metrics["untangled_pairs"] = sum(r["pairs_before"] - r["pairs_after"] for r in repairs)
    result.metrics["strain_damping_s"] = float(scene.model.strain_damping_s[None])
    result.metrics["total_wall_time_s"] = result.metrics["wall_time_s"] + sewn["sew_wall_time_s"]
    return result


def untangle_state(scene, when: str = "") -> dict:
    """Smooth away the garment's crossing triangle pairs in place
    (:func:`~sandbox.collision.untangle.untangle_positions`; seam pairs are not crossings, and
    sewn vertices move together). The moved vertices stop (velocity 0) and are pushed out to
    :data:`UNTANGLE_CLEARANCE_M` from the body. Returns ``{"when", "pairs_before",
    "pairs_after", "vertices_moved", "largest_move_m", "wall_time_s"}``.
    """
    from sandbox.collision.untangle import untangle_positions

    t0 = time.perf_counter()
    model, state = scene.model, scene.state
    x, v = state.positions(), state.velocities()
    body = getattr(scene, "placement_body", None)

    def push_out(y, mask):
        y = y.copy()
        y[mask], _ = body.push_out(y[mask], UNTANGLE_CLEARANCE_M)
        return y

    new, before, after, moved = untangle_positions(
        x, model.tri_indices_np, model.rest_uv_np, push_out if body is not None else None,
        seam_pairs=model.seam_pairs_np)  # fmt: skip
    largest = 0.0
    if after < before:
        v = v.copy()
        v[moved] = 0.0
        state.set(new, v)
        largest = float(np.max(np.linalg.norm(new - x, axis=1)))
    else:
        after, moved = before, np.zeros(len(x), bool)
    out = {"when": when, "pairs_before": int(before), "pairs_after": int(after),
           "vertices_moved": int(moved.sum()), "largest_move_m": largest,
           "wall_time_s": time.perf_counter() - t0}  # fmt: skip
    if before:
        log.info("untangle %s: %d -> %d crossing pairs (%d vertices moved, at most %.1f mm)",
                 when, before, after, out["vertices_moved"], 1e3 * largest)  # fmt: skip
    return out


def default_edge_m(integrator: str) -> float:
    """The mesh edge [m] the CLI and the gallery use when none is given: 1 cm, or
    :data:`IMPLICIT_GARMENT_EDGE_M` with ``implicit_euler``."""
    return IMPLICIT_GARMENT_EDGE_M if integrator == "implicit_euler" else 0.01


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


def drape_metrics(scene, result, *, build_s: float = 0.0) -> dict:
    """metrics.json of a drape: the run's metrics, the garment, the body and the ease."""
    model, mannequin = scene.model, scene.mannequin
    m = dict(result.metrics)
    m.setdefault("seam_gap_max_m", None)
    mat = model.pieces[0].material
    m.update(
        garment=scene.pattern.name,
        pattern_source=scene.pattern.source,
        panels=[p.name for p in model.pieces],
        fabric=getattr(mat, "name", None),
        mannequin_size=mannequin.size,
        mannequin_measurements_cm=_measurements_dict(mannequin),
        edge_length_m=getattr(scene, "edge_length_m", None),
        integrator=scene.spec.simulation.integrator,
        integrator_warning=getattr(scene, "integrator_warning", None),
        damping_per_s=float(scene.control.damping_per_s[None]),
        self_collision=scene.model.self_collider is not None,
        build_time_s=build_s,
        nan_positions=int(np.count_nonzero(~np.isfinite(result.positions))),
    )
    m.update(ease_cm(result.positions, model.tri_indices_np, mannequin, scene.placement_body))
    m.update(hang_metrics(model.initial_positions_np, result.positions, mannequin))
    m.update(fold_metrics(model.initial_positions_np, result.positions, model.tri_indices_np,
                          scene.placement_body))  # fmt: skip
    m["meets_acceptance"] = meets_acceptance(m)
    return m


SLIDE_TOLERANCE_M = 0.03
"""A garment has slid off when its top ends more than this [m] below the landmark it hangs
from (:func:`hang_metrics`)."""
ACCEPT_SEAM_GAP_M = 2e-3
ACCEPT_PENETRATION_M = 1e-3


FOLD_TOLERANCE_PCT = 2.0
"""A garment has folded over (a hem rolled up) when more than this per cent of its area ends
turned over: triangles whose side that faced away from the body at the start faces it at
the end (:func:`fold_metrics`)."""


def hangs_from(x_start: np.ndarray, mannequin) -> str:
    """The landmark a garment placed at ``x_start`` (n, 3) [m] hangs from: the shoulders
    (``shoulder_point_left``) when its top is above half-way between the waist and the
    shoulder points, else the waist (``waist_front``)."""
    lm = mannequin.landmarks
    shoulder, waist = float(lm["shoulder_point_left"][1]), float(lm["waist_front"][1])
    start_top = float(np.max(np.asarray(x_start)[:, 1]))
    return "shoulder_point_left" if start_top > 0.5 * (shoulder + waist) else "waist_front"


def hang_metrics(x_start: np.ndarray, x_end: np.ndarray, mannequin) -> dict:
    """Which landmark the garment hangs from, whether it slid off (issue 5's acceptance) and
    how far its hem rose.

    A garment whose placed top (``x_start`` (n, 3) [m], highest y) is above half-way between
    the waist and the shoulder points hangs from the shoulders (``shoulder_point_left``),
    any other from the waist (``waist_front``). Returns ``hangs_from`` (the landmark),
    ``top_below_anchor_m`` (the landmark's height minus the final top's [m]; negative: the
    top is above it), ``slid_off`` (that distance is more than
    :data:`SLIDE_TOLERANCE_M`) and ``hem_rise_m`` (the final lowest point's height minus
    the placed one's [m]; a garment whose hem folds up rises, but so does one that started
    stretched downwards, so :func:`fold_metrics` decides).
    """
    lm = mannequin.landmarks
    name = hangs_from(x_start, mannequin)
    below = float(lm[name][1]) - float(np.max(np.asarray(x_end)[:, 1]))  # NaN: slid_off
    rise = float(np.min(np.asarray(x_end)[:, 1])) - float(np.min(np.asarray(x_start)[:, 1]))
    return {"hangs_from": name, "top_below_anchor_m": below,
            "slid_off": bool(not below <= SLIDE_TOLERANCE_M),
            "hem_rise_m": rise}  # fmt: skip


def fold_metrics(x_start: np.ndarray, x_end: np.ndarray, triangles: np.ndarray,
                 body=None) -> dict:  # fmt: skip
    """How much of a garment ended turned over: ``folded_area_pct``, the area [%] (at the
    start) of the triangles turned over, and ``rolled_up``, that share above
    :data:`FOLD_TOLERANCE_PCT` (or NaN positions).

    A garment hanging from the body keeps its outside out; a hem folded up into a roll, or
    a back panel caught in a fold, turns a band of cloth over. (The 1 cm camisole whose
    panels started strained folded its lower 7 cm up into a roll while it was sewn, and the
    other metrics did not see it.) A triangle is turned over when its normal turned more
    than 90 degrees and, with ``body`` (a :class:`~sandbox.pattern.place.PlacementBody`),
    the side of it that faced away from the body at the start also faces it at the end (its
    normal against the nearest body normal). A strap that bends over the shoulder as it
    should turns its normal but still faces out, so it is not counted; nor is a flare that
    a hanging hand presses in towards the thigh, which faces the hand (the nearest body
    part) but has not turned (the sixteenth session counted it: 3.6 % of the 1 cm circle
    skirt at size 12).
    """
    t = np.asarray(triangles, np.int64)

    def normals(x):
        x = np.asarray(x, float)
        return np.cross(x[t[:, 1]] - x[t[:, 0]], x[t[:, 2]] - x[t[:, 0]])

    n0, n1 = normals(x_start), normals(x_end)
    area = np.linalg.norm(n0, axis=1)
    finite = bool(np.all(np.isfinite(x_end)))
    if body is not None and finite:

        def outward(x, n):  # fmt: skip
            c = np.asarray(x, float)[t].mean(axis=1)
            return np.sum(n * body.surface_normals(c), axis=1) > 0

    turned = np.sum(n0 * n1, axis=1) < 0
    if body is not None and finite:
        turned &= outward(x_start, n0) != outward(x_end, n1)
    pct = float(100.0 * area[turned].sum() / max(area.sum(), 1e-300))
    return {"folded_area_pct": pct if finite else float("nan"),
            "rolled_up": bool(not finite or pct > FOLD_TOLERANCE_PCT)}  # fmt: skip


def meets_acceptance(m: dict) -> bool:
    """Issue 5's acceptance for one drape's metrics: converged by the stop rule, largest seam
    gap <= 2 mm, no vertex inside the body deeper than 1 mm, no intersecting cloth triangle
    pairs, not slid off (:func:`hang_metrics`), not rolled up (:func:`fold_metrics`), no
    NaN."""
    gap = m.get("seam_gap_max_m")
    depth = m.get("penetration_max_m")
    return bool(
        m.get("converged")
        and (gap is None or gap <= ACCEPT_SEAM_GAP_M)
        and depth is not None
        and depth <= ACCEPT_PENETRATION_M
        and m.get("intersecting_triangle_pairs") == 0
        and not m.get("slid_off", False)
        and not m.get("rolled_up", False)
        and m.get("nan_positions", 0) == 0
    )


def _measurements_dict(mannequin) -> dict | None:
    meas = getattr(mannequin, "measurements_requested", None)
    if meas is None:
        return None
    if hasattr(meas, "to_dict"):
        return {k: float(v) for k, v in meas.to_dict().items()}
    from dataclasses import asdict, is_dataclass

    return {k: float(v) for k, v in asdict(meas).items()} if is_dataclass(meas) else None


def write_drape(scene, result, metrics: dict, out_dir, *, render: bool = True,
                meshes: bool = True) -> dict:  # fmt: skip
    """Write the garment and body meshes (unless ``meshes=False``), front/back renders and
    metrics.json."""
    from sandbox.atomic import write_json
    from sandbox.render.meshio import write_mesh
    from sandbox.scene.output import _jsonable

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    model, mannequin = scene.model, scene.mannequin
    x = result.positions
    tris = model.tri_indices_np
    paths = {}
    if meshes:
        paths["garment_obj"] = write_mesh(out / "garment.obj", x, tris, uvs=model.rest_uv_np)
        paths["garment_ply"] = write_mesh(out / "garment.ply", x, tris, uvs=model.rest_uv_np)
        paths["body_obj"] = write_mesh(out / "body.obj", mannequin.vertices, mannequin.triangles)
    if render:
        paths["render_front"] = render_drape(out / "render.png", x, tris, mannequin, "front")
        paths["render_back"] = render_drape(out / "render_back.png", x, tris, mannequin, "back")
    metrics = dict(metrics)
    metrics["outputs"] = {k: p.name for k, p in paths.items()}
    metrics["bounding_box_m"] = [x.min(axis=0).tolist(), x.max(axis=0).tolist()]
    paths["metrics"] = write_json(out / "metrics.json", _jsonable(metrics))
    return paths


def render_drape(path, x, tris, mannequin, view: str = "front", *, size: int = 640):
    """Off-screen PNG of the garment on the body from one view ("front", "back", "side")."""
    from sandbox.render.offscreen import render_png

    meshes = [
        {"vertices": x, "triangles": tris, "color": GARMENT_COLOR},
        {"vertices": mannequin.vertices, "triangles": mannequin.triangles, "color": BODY_COLOR},
    ]
    return render_png(path, meshes, views=(view,), width=size, height=size)


def drape_image(x, tris, mannequin, view: str = "front", *, size: int = 320) -> np.ndarray:
    """RGB uint8 image (size, size, 3) of the garment on the body (for contact sheets)."""
    from sandbox.render.offscreen import render_image

    meshes = [
        {"vertices": x, "triangles": tris, "color": GARMENT_COLOR},
        {"vertices": mannequin.vertices, "triangles": mannequin.triangles, "color": BODY_COLOR},
    ]
    return render_image(meshes, views=(view,), width=size, height=size)
