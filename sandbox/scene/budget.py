"""What a scene will cost, known before its mesh is built: vertices, triangles, memory, time.

:func:`scene_size` (a scene file's :class:`~sandbox.scene.spec.SceneSpec`) and
:func:`pattern_size` (a garment's panels) predict the size from the pieces' areas and
the mesh edge; :func:`check_size` refuses a prediction over the :class:`ResourceLimits`
with one line giving the numbers and the way past the limit. Both builders call them
before any mesh exists (:func:`sandbox.scene.build.build_scene`,
:func:`sandbox.garment.build.build_drape`) and log the predicted and then the built size
(logger ``sandbox.scene.budget``, INFO; the CLI prints it).

The figures below were measured on the 2-core, 24 GiB machine the project runs on
(docs/errors.md, "Resource limits").
"""

from __future__ import annotations

import logging
import math
import os
import resource
import sys
from dataclasses import dataclass, fields, replace

import numpy as np

from sandbox.errors import SandboxError

log = logging.getLogger(__name__)

TRIANGLE_FACTOR = 1.10
"""Triangles of an irregular mesh of target edge h per equilateral triangle of side h that
fits in its area (Triangle with a 28° minimum angle and a maximum area 1.4 × (√3/4) h²):
1.07-1.10 on sheets, 0.92-1.14 (median 1.10) on the library's 117 panels at 1-3 cm."""

BASE_BYTES = 0.15e9
"""Peak resident memory [bytes] of a scene without contact, apart from its vertices:
Python, numpy and Taichi's runtime (the intercept of the fit below)."""

MIN_BYTES = 0.22e9
"""Peak resident memory [bytes] of the smallest scenes (the packaged 832-vertex hanging
sheet, run to its time limit: 0.22 GB)."""

BYTES_PER_VERTEX = 6.3e3
"""Peak resident memory per vertex [bytes] of a scene without contact, for building (the
hinges, the stability estimate) and stepping: sheets of 20k-200k vertices, float64."""

CONTACT_BASE_BYTES = 0.5e9
"""Peak resident memory [bytes] of a scene with colliders or self-collision, apart from its
vertices (the contact kernels' compilation, the collider's grid)."""

CONTACT_BYTES_PER_VERTEX = 24.5e3
"""Peak resident memory per vertex [bytes] with colliders or self-collision (the
self-contact lists): sheets of 5k-50k vertices over a sphere."""

DRAPE_BASE_BYTES = 0.48e9
"""Peak resident memory [bytes] of a garment drape apart from its vertices (the mannequin's
collider, 17,772 triangles at size 12, the placement body, the contact kernels)."""

DRAPE_BYTES_PER_VERTEX = 78e3
"""Peak resident memory per garment vertex [bytes] (seams, sewing, self-contact in folds):
the tank top at 3 cm (757 vertices) peaked at 0.54 GB, the t-shirt at 1 cm (8,600) held
1.16 GB in its first frame."""

DT_MEMBRANE = 0.32
"""The explicit stability estimate of the stretch modes is DT_MEMBRANE · h · √(ρ/k) for a
mesh of edge h, areal density ρ and the largest stretch or shear stiffness k (every fabric
preset at 5 mm-3 cm)."""

DT_BENDING = 0.07
"""The bending modes' share: DT_BENDING · h² · √(ρ/B), B the largest bending rigidity;
the two combine as 1/dt² = 1/dt_membrane² + 1/dt_bending²."""

VERTEX_STEPS_PER_S = 5e6
"""Explicit steps of a scene without contact [vertex-steps/s] on this machine (float64;
benchmarks/bench_step.py measures 4-13 M in float32)."""

CONTACT_VERTEX_STEPS_PER_S = 2e6
"""Explicit steps with a collider and self-collision [vertex-steps/s]: the 1 cm drapes of
docs/results/bench_drape.txt run at 1.8-3.6 M."""

STEP_OVERHEAD_S = 2.5e-4
"""Wall time of an explicit step apart from its vertices [s] (kernel launches): the
832-vertex hanging sheet takes 0.42 ms a step."""

CONTACT_STEP_OVERHEAD_S = 3e-3
"""The same with a collider and self-collision [s] (the contact passes): the tank top at
3 cm (757 vertices) takes about 7 ms a step, compilation included."""

IMPLICIT_VERTEX_STEPS_PER_S = 4e3
"""Backward Euler at 1/60 s steps [vertex-steps/s], Newton iterations included: the 3 cm
garments of docs/gallery-implicit take about 15 s of wall time per simulated second."""

GB = 1e9
"""The unit of memory in messages and settings [bytes]."""

ENV_VARS = {"max_vertices": "SANDBOX_MAX_VERTICES", "max_memory_gb": "SANDBOX_MAX_MEMORY_GB"}
"""Environment variables that set the limits (over a scene file's ``[limits]``, under the
command line's flags)."""


@dataclass(frozen=True)
class ResourceLimits:
    """The largest scene a build accepts; a larger prediction is refused before meshing.

    The defaults fit a machine of 2 cores and 24 GiB: 8 GB leaves room for a second drape
    (``gallery --jobs 2``) and the system, and 400,000 vertices is 25 times the library's
    1 cm garments, where a step already takes about 0.2 s and a simulated second hours.
    """

    max_vertices: int = 400_000
    """Most vertices over all pieces (predicted)."""
    max_memory_gb: float = 8.0
    """Most peak memory [GB = 1e9 bytes] (predicted)."""

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, int | float) or not value > 0:
                raise SandboxError(f"ResourceLimits.{f.name} must be a positive number, "
                                   f"got {value!r}")  # fmt: skip
        if not isinstance(self.max_vertices, int):
            if not float(self.max_vertices).is_integer():
                raise SandboxError(f"ResourceLimits.max_vertices must be a whole number, "
                                   f"got {self.max_vertices!r}")  # fmt: skip
            object.__setattr__(self, "max_vertices", int(self.max_vertices))


@dataclass(frozen=True)
class SceneSize:
    """A scene's size: predicted before its mesh is built, or counted after."""

    name: str
    vertex_count: float
    """Vertices over all pieces (a float: a prediction may overflow to inf)."""
    triangle_count: float
    memory_bytes: float
    """Peak resident memory of the process [bytes]."""
    seconds_per_sim_s: float
    """Wall time per simulated second [s] (rough: within a factor of 2)."""

    def line(self, what: str) -> str:
        """``scene NAME: WHAT N vertices, M triangles, ~G GB, ~T s per simulated second``."""
        return (f"scene {self.name}: {what} {_count(self.vertex_count)} vertices, "
                f"{_count(self.triangle_count)} triangles, ~{_gb(self.memory_bytes)} GB, "
                f"~{_seconds(self.seconds_per_sim_s)} s per simulated second")  # fmt: skip


def _count(n: float) -> str:
    return f"{n:,.0f}" if math.isfinite(n) else "too many to count"


def _gb(b: float) -> str:
    g = b / GB
    if not math.isfinite(g):
        return "inf"
    return f"{g:.2f}" if g < 1 else f"{g:,.1f}" if g < 100 else f"{g:,.0f}"


def _seconds(s: float) -> str:
    if not math.isfinite(s):
        return "inf"
    return f"{s:.2g}" if s < 100 else f"{s:,.0f}"


# ---------------------------------------------------------------------------- meshes
def irregular_mesh_size(area_m2: float, boundary_vertices: float,
                        edge_length_m: float) -> tuple[float, float]:  # fmt: skip
    """(vertices, triangles) of an irregular mesh of one piece without holes.

    Triangles: :data:`TRIANGLE_FACTOR` × area / (√3/4 h²). Vertices from Euler's formula for
    a triangulated disc with B boundary vertices: V = (T + B + 2) / 2 (exact for every mesh
    of the calibration set)."""
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        h = np.float64(edge_length_m)
        t = float(TRIANGLE_FACTOR * abs(area_m2) / (math.sqrt(3.0) / 4.0 * h * h))
    t = t if math.isfinite(t) else math.inf
    return 0.5 * (t + boundary_vertices + 2.0), t


def _segments(lengths_m, edge_length_m: float) -> float:
    """Boundary vertices of sides of these lengths cut into pieces at most h long."""
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        n = np.maximum(1.0, np.ceil(np.asarray(lengths_m, float) / edge_length_m - 1e-9))
    total = float(n.sum())
    return total if math.isfinite(total) else math.inf


def cloth_mesh_size(cloth) -> tuple[float, float]:
    """(vertices, triangles) of a scene file's ``[[cloth]]`` (a :class:`ClothSpec`)."""
    outline = np.asarray(cloth.outline_m, float)
    h = cloth.edge_length_m
    if cloth.mesher == "grid":  # exact: sandbox.pattern.mesh2d.mesh_grid
        w, d = np.ptp(outline, axis=0)
        nx, ny = max(1.0, round(w / h)), max(1.0, round(d / h))
        return (nx + 1.0) * (ny + 1.0), 2.0 * nx * ny
    x, y = outline[:, 0], outline[:, 1]
    area = 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))
    sides = np.linalg.norm(outline - np.roll(outline, -1, axis=0), axis=1)
    return irregular_mesh_size(area, _segments(sides, h), h)


def panel_mesh_size(panel, edge_length_m: float) -> tuple[float, float]:
    """(vertices, triangles) of a pattern panel meshed at ``edge_length_m`` [m]."""
    lengths = [e.length_m for e in panel.edges]
    outline = np.vstack([e.sample(max(L, 1e-12) / 32.0)[:-1]
                         for e, L in zip(panel.edges, lengths, strict=True)])  # fmt: skip
    x, y = outline[:, 0], outline[:, 1]
    area = 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))
    return irregular_mesh_size(area, _segments(lengths, edge_length_m), edge_length_m)


# ---------------------------------------------------------------------------- cost
def memory_bytes(vertex_count: float, *, contact: bool) -> float:
    """Predicted peak resident memory [bytes] of building and running a scene."""
    if contact:
        return CONTACT_BASE_BYTES + CONTACT_BYTES_PER_VERTEX * vertex_count
    return max(MIN_BYTES, BASE_BYTES + BYTES_PER_VERTEX * vertex_count)


def explicit_dt_limit(material, edge_length_m: float) -> float:
    """Predicted explicit stability estimate [s] of a mesh of this edge and material
    (:func:`sandbox.scene.build.stable_dt_estimate` on the built mesh)."""
    m, h = material, edge_length_m
    k = max(m.stretch_u_N_m, m.stretch_v_N_m, 2.0 * m.shear_N_m)
    b = max(m.bend_warp_Nm, m.bend_weft_Nm, m.bend_bias_Nm)
    if not (DT_BENDING * h * h) ** 2 > 0:  # an edge so small that h⁴ underflows
        return 0.0
    inv2 = k / (m.density_kg_m2 * (DT_MEMBRANE * h) ** 2)
    if b > 0:
        inv2 += b / (m.density_kg_m2 * (DT_BENDING * h * h) ** 2)
    return 1.0 / math.sqrt(inv2) if inv2 > 0 else math.inf


def seconds_per_sim_s(vertex_count: float, dt_s: float, *, contact: bool,
                      implicit: bool) -> float:  # fmt: skip
    """Rough wall time [s] per simulated second at step ``dt_s`` [s]."""
    if implicit:
        return vertex_count / (max(dt_s, 1e-30) * IMPLICIT_VERTEX_STEPS_PER_S)
    rate = CONTACT_VERTEX_STEPS_PER_S if contact else VERTEX_STEPS_PER_S
    overhead = CONTACT_STEP_OVERHEAD_S if contact else STEP_OVERHEAD_S
    return (overhead + vertex_count / rate) / max(dt_s, 1e-30)


def _auto_dt(limit_s: float, integrator: str, dt_s: float | None, frame_rate_hz: float,
             strain_damping_s: float) -> float:  # fmt: skip
    """The step ``dt_s = "auto"`` would take (sandbox.scene.build.scene_from_model)."""
    from sandbox.scene.build import DT_SAFETY, IMPLICIT_DT_S, damped_step

    frame = 1.0 / frame_rate_hz
    if dt_s is not None:
        return min(dt_s, frame)
    if integrator == "implicit_euler":
        return min(IMPLICIT_DT_S, frame)
    if not limit_s > 0:
        return 0.0
    return min(frame, DT_SAFETY * damped_step(limit_s, strain_damping_s))


def has_contact(spec) -> bool:
    """Whether a scene builds contact structures (colliders or self-collision)."""
    wanted = spec.collision.self_collision
    return bool(spec.colliders) or bool(wanted)


def scene_size(spec) -> SceneSize:
    """The predicted size of a scene file's scene (a checked :class:`SceneSpec`)."""
    v = t = 0.0
    limit = math.inf
    for c in spec.cloths:
        cv, ct = cloth_mesh_size(c)
        v, t = v + cv, t + ct
        limit = min(limit, explicit_dt_limit(c.material, c.edge_length_m))
    s = spec.simulation
    dt = _auto_dt(limit, s.integrator, s.dt_s, s.frame_rate_hz, s.strain_damping_s)
    return _size(spec.name, v, t, dt, s.integrator, has_contact(spec))


def pattern_size(pattern, edge_length_m: float, material, config) -> SceneSize:
    """The predicted size of a garment drape: the pattern's panels meshed at
    ``edge_length_m`` [m] in ``material``, on the mannequin, stepped as ``config`` (a
    :class:`~sandbox.garment.config.DrapeConfig`) says."""
    v = t = 0.0
    for panel in pattern.panels.values():
        pv, pt = panel_mesh_size(panel, edge_length_m)
        v, t = v + pv, t + pt
    limit = explicit_dt_limit(material, edge_length_m)
    beta = 0.0 if config.integrator == "implicit_euler" else config.strain_damping_s
    dt = _auto_dt(limit, config.integrator, config.dt_s, config.frame_rate_hz, beta)
    name = f"{pattern.name} at {edge_length_m * 100:g} cm"
    memory = DRAPE_BASE_BYTES + DRAPE_BYTES_PER_VERTEX * v
    return _size(name, v, t, dt, config.integrator, True, memory)


def _size(name, v, t, dt_s, integrator, contact, memory=None) -> SceneSize:
    implicit = integrator == "implicit_euler"
    memory = memory_bytes(v, contact=contact) if memory is None else memory
    return SceneSize(name, v, t, memory,
                     seconds_per_sim_s(v, dt_s, contact=contact, implicit=implicit))  # fmt: skip


def built_size(scene, name: str | None = None) -> SceneSize:
    """The size of a built scene (called ``name``, default its spec's): its counts, the
    process's peak memory so far and the rough time per simulated second at its step."""
    model = scene.model
    contact = bool(model.colliders) or model.self_collider is not None
    implicit = scene.spec.simulation.integrator == "implicit_euler"
    v = model.particle_count
    return SceneSize(name or scene.spec.name, v, model.tri_count, peak_memory_bytes(),
                     seconds_per_sim_s(v, scene.dt_s, contact=contact,
                                       implicit=implicit))  # fmt: skip


def peak_memory_bytes() -> float:
    """Peak resident memory of this process so far [bytes]."""
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return float(rss) * (1 if sys.platform == "darwin" else 1024)


# ---------------------------------------------------------------------------- limits
def check_size(size: SceneSize, limits: ResourceLimits, *, where: str = "",
               say: bool = True) -> None:  # fmt: skip
    """Refuse (SandboxError, one line) a predicted size over ``limits``; log it otherwise
    (``say``)."""
    over = []
    if not size.vertex_count <= limits.max_vertices:
        over.append(f"{_count(size.vertex_count)} vertices (limit {limits.max_vertices:,})")
    if not size.memory_bytes / GB <= limits.max_memory_gb:
        over.append(f"~{_gb(size.memory_bytes)} GB of memory (limit "
                    f"{limits.max_memory_gb:g} GB)")  # fmt: skip
    if over:
        where = where or f"scene {size.name}"
        if not (math.isfinite(size.vertex_count) and math.isfinite(size.memory_bytes)):
            raise SandboxError(f"{where}: the mesh would have more vertices than can be "
                               f"counted; is the edge length in the wrong unit?")  # fmt: skip
        need_v = max(limits.max_vertices, math.ceil(size.vertex_count))
        need_gb = max(limits.max_memory_gb, math.ceil(size.memory_bytes / GB))
        raise SandboxError(
            f"{where}: the mesh would have {' and '.join(over)}; is the edge length or a "
            f"size in the wrong unit? To build it anyway: --max-vertices {need_v} "
            f"--max-memory-gb {need_gb:g} (or a [limits] table in the scene or --config file, "
            f"{ENV_VARS['max_vertices']}, {ENV_VARS['max_memory_gb']})"
        )
    if say:
        log.info("%s", size.line("predicted"))


def log_built(scene, name: str | None = None) -> None:
    """Log the built scene's size (after :func:`check_size` logged the prediction)."""
    if log.isEnabledFor(logging.INFO):
        log.info("%s", built_size(scene, name).line("built"))


def mesher_limits(limits: ResourceLimits):
    """The mesher's own backstop (:class:`~sandbox.pattern.limits.PatternLimits`
    ``max_mesh_vertices``) raised along with ``limits``, so that a scene allowed here is
    not refused again by Triangle's caller (its estimate differs from this one by a few
    per cent: twice the vertex limit leaves room)."""
    from sandbox.pattern.limits import DEFAULT_LIMITS

    most = max(DEFAULT_LIMITS.max_mesh_vertices, 2 * limits.max_vertices)
    return replace(DEFAULT_LIMITS, max_mesh_vertices=most)


def limits_from_table(table, base: ResourceLimits, where: str) -> ResourceLimits:
    """``base`` with the fields of a ``[limits]`` table (a scene or drape settings file)."""
    if not isinstance(table, dict):
        raise SandboxError(f"{where}: [limits] must be a table")
    known = {f.name for f in fields(ResourceLimits)}
    unknown = sorted(set(table) - known)
    if unknown:
        raise SandboxError(f"{where}: [limits] has unknown key(s) {', '.join(unknown)}; known: "
                           f"{', '.join(sorted(known))}")  # fmt: skip
    try:
        return replace(base, **table)
    except SandboxError as exc:
        raise SandboxError(f"{where}: [limits] {exc}") from None


def limits_from_env(base: ResourceLimits, environ=None) -> ResourceLimits:
    """``base`` with the limits set by :data:`ENV_VARS` in ``environ`` (default: the
    process's environment)."""
    environ = os.environ if environ is None else environ
    changes = {}
    for name, var in ENV_VARS.items():
        text = environ.get(var)
        if text is None or not text.strip():
            continue
        try:
            value = float(text)
        except ValueError:
            raise SandboxError(f"{var}={text!r}: not a number") from None
        changes[name] = int(value) if name == "max_vertices" and value.is_integer() else value
    try:
        return replace(base, **changes)
    except SandboxError as exc:
        raise SandboxError(f"{', '.join(ENV_VARS.values())}: {exc}") from None


def add_limit_flags(parser) -> None:
    """Add ``--max-vertices`` and ``--max-memory-gb`` to an argparse parser."""
    parser.add_argument("--max-vertices", type=int, default=None, metavar="N",
                        help=f"refuse a scene predicted over N vertices (default "
                        f"{ResourceLimits.max_vertices:,}; docs/errors.md)")  # fmt: skip
    parser.add_argument("--max-memory-gb", type=float, default=None, metavar="GB",
                        help=f"refuse a scene predicted over GB of memory (default "
                        f"{ResourceLimits.max_memory_gb:g})")  # fmt: skip


def limits_from_args(args, base: ResourceLimits | None = None, environ=None) -> ResourceLimits:
    """The limits of a command: ``base`` (a file's, or the defaults), then the environment
    (:data:`ENV_VARS`), then the flags of :func:`add_limit_flags`."""
    limits = limits_from_env(base or ResourceLimits(), environ)
    changes = {}
    if getattr(args, "max_vertices", None) is not None:
        changes["max_vertices"] = args.max_vertices
    if getattr(args, "max_memory_gb", None) is not None:
        changes["max_memory_gb"] = args.max_memory_gb
    try:
        return replace(limits, **changes)
    except SandboxError as exc:
        raise SandboxError(f"--max-vertices/--max-memory-gb: {exc}") from None


class _Print(logging.Handler):
    def emit(self, record):
        print(self.format(record), flush=True)


def show_sizes(on: bool = True) -> None:
    """Print the scenes' sizes (this module's INFO lines) on standard output, or stop."""
    for h in [h for h in log.handlers if isinstance(h, _Print)]:
        log.removeHandler(h)
    if on:
        log.addHandler(_Print())
        log.setLevel(logging.INFO)
        log.propagate = False
    else:
        log.setLevel(logging.NOTSET)
        log.propagate = True
