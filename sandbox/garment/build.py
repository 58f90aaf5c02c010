"""Build a garment scene: mesh the pattern's panels, place them around the mannequin, make
the seams' springs (paper §2.3-2.4, Fig. 5), and hand the lot to the same
:class:`~sandbox.scene.build.Scene` that :func:`~sandbox.scene.run.run_scene` runs.

pattern + mannequin -> :func:`~sandbox.pattern.panel_mesh.mesh_pattern` ->
:func:`~sandbox.pattern.placement.place.place_pattern` -> ModelBuilder (cloth with its grain, seams)
-> Model + the mannequin as a :class:`~sandbox.collision.body.BodyCollider` -> Scene, with
its :class:`GarmentContext` (what the sewing, the metrics and the writer need to know).
"""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass

import numpy as np

from sandbox.errors import SandboxError
from sandbox.garment.config import DrapeConfig, implicit_mesh_warning
from sandbox.garment.inputs import material_for, resolve_pattern

log = logging.getLogger(__name__)


@dataclass
class GarmentContext:
    """What a garment scene knows beyond the simulation: where its panels came from.

    Attributes: ``pattern`` (the loaded Pattern), ``mannequin``, ``placement_body`` (the
    mannequin's :class:`~sandbox.pattern.placement.body.PlacementBody`: landmarks, normals,
    push-out), ``config`` (the :class:`DrapeConfig` it was built with), ``builder`` (the
    ModelBuilder, kept to make seams live), ``meshes`` (panel name -> PanelMesh),
    ``piece_index`` (panel name -> piece index), ``placed`` (panel name -> (n, 3) placed
    positions [m]), ``seam_stiffness_N_m`` (stiffness of seams sewn live [N/m]: the cloth's
    own), ``edge_length_m`` (the mesh edge [m]) and ``integrator_warning`` (or None).
    """

    pattern: object
    mannequin: object
    placement_body: object
    config: DrapeConfig
    builder: object
    meshes: dict
    piece_index: dict
    placed: dict
    seam_stiffness_N_m: float
    edge_length_m: float
    integrator_warning: str | None = None


def build_drape(
    pattern,
    mannequin,
    *,
    fabric=None,
    edge_length_m: float | None = 0.01,
    config: DrapeConfig | None = None,
    sew_pattern: bool = True,
    seam_capacity: int = 0,
    place=None,
    like=None,
    contact_edge_m: float | None = None,
    implicit=None,
):
    """Mesh, place and sew a pattern on the mannequin: a Scene for ``run_scene``.

    Args:
        pattern: a loaded Pattern, a pattern dict, a path or a library garment's name.
        mannequin: a :class:`~sandbox.mannequin.Mannequin`.
        fabric: override of the pattern's fabric (preset name, table or Material).
        edge_length_m: target mesh edge [m]; None = the pattern's ``mesh_edge``.
        config: the drape's settings (default :class:`DrapeConfig`).
        sew_pattern: sew the pattern's seams (False: the panels start unsewn, for the
            interactive sandbox's click-to-sew, :func:`seam_springs`).
        seam_capacity: room for this many more seam springs, sewn while the scene runs.
        place: ``place(meshes) -> {panel name: (n, 3) positions [m]}`` instead of placing
            the panels on the body (a coarse drape's placement carried to this mesh).
        like: a scene built by this function on the same mannequin, whose body collider
            and placement body this one shares instead of making its own.
        contact_edge_m: the cloth edge [m] the body's crease thickness is sized for
            (:meth:`~sandbox.collision.body.BodyCollider.follow_cloth`); default the mesh's
            own. A coarse level sized for the fine mesh rests on the same body surface.
        implicit: the implicit solver's settings (an
            :class:`~sandbox.sim.implicit_config.ImplicitConfig`) when ``config.integrator``
            is ``"implicit_euler"``: the window's fixed Newton budget a step. Given, the
            warning for an implicit drape on a fine mesh is not logged (a drape's
            convergence is not what such a budget asks for).
    Returns the Scene, with ``scene.garment`` its :class:`GarmentContext`.
    """
    # Taichi-backed modules load when a scene is built, not when the package is imported:
    # `drape --list` and the input checks run before Taichi starts
    from sandbox import runtime
    from sandbox.collision.body import BodyCollider
    from sandbox.garment.circle_start import circle_gores, place_circle_skirt
    from sandbox.pattern.panel_mesh import mesh_pattern, pattern_seam_sides
    from sandbox.pattern.placement.body import PlacementBody
    from sandbox.pattern.placement.place import place_pattern
    from sandbox.scene.budget import log_built, mesher_limits
    from sandbox.scene.build import build_self_collider, scene_from_model
    from sandbox.scene.spec import CollisionSpec, SceneSpec, SimulationSpec, StopSpec
    from sandbox.sim.builder import ModelBuilder

    config = config or DrapeConfig()
    pattern = resolve_pattern(pattern, mannequin)
    if edge_length_m is not None and not (edge_length_m > 0 and math.isfinite(edge_length_m)):
        raise SandboxError(f"edge length must be a positive number of metres, got {edge_length_m}")
    material = material_for(pattern, fabric)
    size = check_drape_size(pattern, edge_length_m, material, config)
    meshes = mesh_pattern(pattern, edge_length_m, limits=mesher_limits(config.limits))
    body = like.garment.placement_body if like is not None else PlacementBody(mannequin)
    if place is not None:
        placed = place(meshes)
    elif circle_gores(pattern):  # a circle skirt starts on a cone with folds
        placed = place_circle_skirt(pattern, meshes, body)
    else:
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
    seam_k = k_cloth * max(1.0, edge / config.seam_reference_edge_m)
    names = list(meshes)
    if sew_pattern:
        for seam in pattern_seam_sides(pattern, meshes, index):
            for part in _seam_parts(seam, seam_k, names, meshes, placed):
                builder.add_seam(**part)
    model = builder.finalize(bending=True, seam_capacity=seam_capacity)
    # backward Euler damps the fast modes itself; its Newton step has no strain damping
    beta = 0.0 if config.implicit else config.strain_damping_s
    spec = SceneSpec(
        name=pattern.name,
        description=f"drape of {pattern.name} on the mannequin",
        simulation=SimulationSpec(integrator=config.integrator, dt_s=config.dt_s,
                                  frame_rate_hz=config.frame_rate_hz,
                                  damping_per_s=config.damping_per_s, strain_damping_s=beta,
                                  seam_damping_ratio=0.0 if config.implicit else
                                  config.seam_damping_ratio,
                                  seam_hold_m=0.0 if config.implicit else config.seam_hold_m),
        stop=StopSpec(max_displacement_m=config.stop_max_m,
                      mean_displacement_m=config.stop_mean_m, frames=1,
                      min_time_s=config.min_time_s, time_limit_s=config.time_limit_s,
                      wall_limit_s=config.wall_limit_s),
        collision=CollisionSpec(thickness_m=config.thickness_m,
                                self_collision=config.self_collision,
                                body_faces=config.body_faces),
        source=pattern.source,
    )  # fmt: skip
    if like is not None:
        model.colliders = list(like.model.colliders)
    else:
        model.colliders = [
            BodyCollider(mannequin.vertices, mannequin.triangles, thickness_m=config.thickness_m,
                         friction_static=spec.collision.friction_static,
                         friction_kinetic=spec.collision.friction_kinetic, name="mannequin",
                         closed=True, face_pass=config.body_faces)
        ]  # fmt: skip
    for c in model.colliders:  # the shoulder line and a coarse bust: see crease.py
        if c.cloth_edge_m != (contact_edge_m or edge):
            c.follow_cloth(contact_edge_m or edge)
    model.self_collider = build_self_collider(model, spec)
    scene = scene_from_model(spec, model, implicit)
    log_built(scene, size.name)
    warning = None if implicit is not None else implicit_mesh_warning(config.integrator, edge)
    if warning:
        log.warning("%s: %s", pattern.name, warning)
    # seams sewn live (the window's clicks) keep the cloth's own stiffness
    scene.garment = GarmentContext(
        pattern=pattern, mannequin=mannequin, placement_body=body, config=config,
        builder=builder, meshes=meshes, piece_index=index, placed=placed,
        seam_stiffness_N_m=k_cloth, edge_length_m=edge, integrator_warning=warning,
    )  # fmt: skip
    return scene


def check_drape_size(pattern, edge_length_m: float | None, material, config: DrapeConfig,
                     *, say: bool = True):  # fmt: skip
    """The predicted size of a drape (:func:`sandbox.scene.budget.pattern_size`), refused
    (SandboxError) over ``config.limits`` before anything is meshed; logged if ``say``."""
    from sandbox.scene.budget import check_size, pattern_size

    h = pattern.mesh_edge_m if edge_length_m is None else float(edge_length_m)
    size = pattern_size(pattern, h, material, config)
    check_size(size, config.limits, where=f"{pattern.source} at {h * 100:g} cm edges", say=say)
    return size


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
        scene: the drape scene (its ``garment`` context: pattern, meshes and builder).
        seams: :class:`~sandbox.pattern.spec.SeamSpec` records (panel names, edge indices).
        positions: (n, 3) world positions [m] the direction rule looks at (default: the
            current state), so a seam made live is sewn the way the panels now lie.
    Returns ``(pairs (k, 2), rest (k,) [m], stiffness (k,) [N/m])``: the same springs the
    builder makes for a pattern file (Fig. 5 direction rule, parametric matching).
    """
    from sandbox.pattern.panel_mesh import pattern_seam_sides

    if not seams:
        return np.zeros((0, 2), np.int64), np.zeros(0), np.zeros(0)
    g = scene.garment
    x = scene.state.positions() if positions is None else np.asarray(positions, float)
    names = list(g.meshes)
    placed = {}
    for piece in scene.model.pieces:
        placed[piece.name] = x[piece.particle_start : piece.particle_start + piece.particle_count]
    tmp = dataclasses.replace(g.pattern, seams=list(seams))
    builder = g.builder
    saved = builder._seams
    builder._seams = []
    try:
        for seam in pattern_seam_sides(tmp, g.meshes, g.piece_index):
            for part in _seam_parts(seam, g.seam_stiffness_N_m, names, g.meshes, placed):
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
    would be sewn to the gap, with long rest lengths). Here both sides are parametrised by
    their own arc length without the jumps, cut at every edge end of either side (at the
    nearest vertex) and sewn piecewise with direction "same" (side b reversed first if needed).
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
