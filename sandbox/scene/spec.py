"""Scene files: what a scene has, checked before anything is built.

A scene is a TOML file (``docs/scene_format.md`` documents every key). Parsing checks
every key and value and raises :class:`SandboxError` naming the file, the entry and the
problem, so bad input stops before any Taichi kernel runs.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, fields
from itertools import pairwise
from pathlib import Path

from sandbox.errors import SandboxError
from sandbox.scene.budget import ResourceLimits, limits_from_table
from sandbox.scene.multilevel_spec import MultilevelSpec, check_levels, multilevel_from_table
from sandbox.scene.plausible import PLAUSIBLE, PlausibleRanges, warn_scene
from sandbox.sim.materials import Material, material_from_spec

INTEGRATORS = ("symplectic_euler", "implicit_euler")
LINEAR_SOLVERS = ("auto", "direct", "cg")  # the implicit solver's Newton systems
SHAPES = ("rectangle", "polygon")
MESHERS = ("irregular", "grid")
SIDES = ("top", "bottom", "left", "right")


@dataclass
class PinSpec:
    """One pin entry: exactly one of vertex indices, a pattern-plane box, a side, corners."""

    vertices: list[int] | None = None
    region_m: tuple[tuple[float, float], tuple[float, float]] | None = None
    side: str | None = None
    corners: str | None = None
    where: str = ""


@dataclass
class ClothSpec:
    """A flat cloth piece: outline in the pattern plane [m], mesh, material, placement."""

    name: str
    outline_m: list[tuple[float, float]]
    edge_length_m: float
    material: Material
    mesher: str = "irregular"
    grain_deg: float = 0.0
    origin_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotation_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    velocity_m_s: tuple[float, float, float] = (0.0, 0.0, 0.0)
    pins: list[PinSpec] = field(default_factory=list)
    mesh_lines_m: list[tuple[tuple[float, float], tuple[float, float]]] = field(
        default_factory=list
    )
    where: str = ""


@dataclass
class SimulationSpec:
    integrator: str = "symplectic_euler"
    dt_s: float | None = None  # None: automatic from the stability estimate
    frame_rate_hz: float = 30.0
    gravity_m_s2: tuple[float, float, float] = (0.0, -9.80665, 0.0)
    damping_per_s: float = 0.5
    strain_damping_s: float = 0.0  # the membrane's strain-rate damping β [s]; explicit only
    seam_damping_ratio: float = 0.0  # ζ of each seam spring's dashpot; explicit only
    seam_hold_m: float = 0.0  # how far a closed stitch may open [m]; 0: no hold; explicit only
    bending: bool = True
    linear_solver: str = "auto"  # implicit_euler only: "auto", "direct" or "cg"


@dataclass
class StopSpec:
    """Paper §2.2 stop rule, measured over one output frame of simulated time."""

    max_displacement_m: float = 1.5e-3
    mean_displacement_m: float = 1.0e-4
    frames: int = 1
    min_time_s: float = 0.0
    time_limit_s: float = 10.0
    wall_limit_s: float = 3600.0
    residual_mean: float | None = None  # also: mean equilibrium residual / weight below this


@dataclass
class CollisionSpec:
    """Contact settings (Bridson et al. 2002): proximity thickness and Coulomb friction."""

    thickness_m: float = 2e-3
    friction_static: float = 0.4
    friction_kinetic: float = 0.3
    self_collision: bool | None = None  # None: on when the scene has a collider
    body_faces: bool = False  # closed bodies' vertices kept under the cloth's triangles


COLLIDER_KEYS = {
    "sphere": {"center_m", "radius_m", "subdivisions"},
    "box": {"center_m", "size_m", "rotation_deg"},
    "cylinder": {"center_m", "radius_m", "height_m", "rotation_deg"},
    "plane": {"point_m", "normal", "size_m"},
    "mesh": {"path", "scale", "origin_m", "rotation_deg"},
    "mannequin": {"size", "measurements_cm"},
}


@dataclass
class ColliderSpec:
    """A rigid collider: a shape name and its checked parameters (SI units)."""

    name: str
    shape: str
    params: dict
    where: str = ""


@dataclass
class SeamSpec:
    """Two seam lines, each a list of (cloth name, (u0, v0), (u1, v1)) pattern edges."""

    name: str
    side_a: list
    side_b: list
    direction: str = "auto"
    stiffness_N_m: float | None = None
    where: str = ""


@dataclass
class SceneSpec:
    name: str
    description: str = ""
    simulation: SimulationSpec = field(default_factory=SimulationSpec)
    stop: StopSpec = field(default_factory=StopSpec)
    collision: CollisionSpec = field(default_factory=CollisionSpec)
    cloths: list[ClothSpec] = field(default_factory=list)
    colliders: list[ColliderSpec] = field(default_factory=list)
    seams: list[SeamSpec] = field(default_factory=list)
    source: str = "<scene>"
    limits: ResourceLimits = field(default_factory=ResourceLimits)  # refused above these
    multilevel: MultilevelSpec | None = None  # run coarse to fine (sandbox.scene.multilevel)


# ---------------------------------------------------------------------------- loading
def load_scene(path: str | Path, *, ranges: PlausibleRanges = PLAUSIBLE) -> SceneSpec:
    """Read and check a TOML scene file; log a warning for each value outside ``ranges``
    (:mod:`sandbox.scene.plausible`)."""
    path = Path(path)
    if not path.is_file():
        raise SandboxError(f"{path}: no such scene file")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise SandboxError(f"{path}: not valid TOML ({exc})") from None
    except UnicodeDecodeError:
        raise SandboxError(f"{path}: not a text file") from None
    spec = scene_from_dict(data, source=str(path))
    warn_scene(spec, ranges)  # valid but odd values: one warning each
    return spec


def scene_from_dict(data: dict, *, source: str = "<scene>") -> SceneSpec:
    """Check a scene given as nested dicts (as read from TOML)."""
    r = _Reader(source)
    r.keys(data, "", {"scene", "simulation", "stop", "cloth", "collision", "collider", "seam",
                      "limits", "multilevel"})  # fmt: skip
    head = data.get("scene", {})
    r.keys(head, "[scene]", {"name", "description"})
    spec = SceneSpec(
        name=r.string(head, "[scene]", "name", "scene"),
        description=r.string(head, "[scene]", "description", ""),
        source=source,
    )
    spec.simulation = _simulation(r, data.get("simulation", {}))
    spec.stop = _stop(r, data.get("stop", {}))
    spec.limits = limits_from_table(data.get("limits", {}), spec.limits, source)
    cloths = data.get("cloth", [])
    if not isinstance(cloths, list) or not cloths:
        raise SandboxError(f"{source}: the scene needs at least one [[cloth]] table")
    spec.cloths = [_cloth(r, c, f"cloth[{i}]") for i, c in enumerate(cloths)]
    spec.collision = _collision(r, data.get("collision", {}))
    colliders = data.get("collider", [])
    if not isinstance(colliders, list):
        raise SandboxError(f"{source}: collider must be an array of tables [[collider]]")
    spec.colliders = [_collider(r, c, f"collider[{i}]") for i, c in enumerate(colliders)]
    seams = data.get("seam", [])
    if not isinstance(seams, list):
        raise SandboxError(f"{source}: seam must be an array of tables [[seam]]")
    by_name = {c.name: c for c in spec.cloths}
    spec.seams = [_seam(r, t, f"seam[{i}]", by_name) for i, t in enumerate(seams)]
    if "multilevel" in data:
        r.keys(data["multilevel"], "[multilevel]", {f.name for f in fields(MultilevelSpec)})
        spec.multilevel = multilevel_from_table(data["multilevel"], source)
        check_levels(spec)
    names = [c.name for c in spec.cloths]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise SandboxError(f"{source}: cloth names must be unique, repeated: {sorted(dup)}")
    return spec


def _simulation(r: _Reader, t: dict) -> SimulationSpec:
    w = "[simulation]"
    r.keys(t, w, {"integrator", "dt_s", "frame_rate_hz", "gravity_m_s2", "damping_per_s",
                  "strain_damping_s", "seam_damping_ratio", "seam_hold_m", "bending",
                  "linear_solver"})  # fmt: skip
    s = SimulationSpec()
    s.integrator = r.choice(t, w, "integrator", INTEGRATORS, s.integrator)
    dt = t.get("dt_s", "auto")
    s.dt_s = None if dt == "auto" else r.number(t, w, "dt_s", positive=True)
    s.frame_rate_hz = r.number(t, w, "frame_rate_hz", s.frame_rate_hz, positive=True)
    s.gravity_m_s2 = r.vector(t, w, "gravity_m_s2", 3, s.gravity_m_s2)
    s.damping_per_s = r.number(t, w, "damping_per_s", s.damping_per_s, minimum=0.0)
    s.strain_damping_s = r.number(t, w, "strain_damping_s", s.strain_damping_s, minimum=0.0)
    if s.strain_damping_s > 0 and s.integrator != "symplectic_euler":
        raise SandboxError(f"{r.source}: {w} strain_damping_s is for symplectic_euler only "
                           f"(backward Euler damps the fast modes itself)")  # fmt: skip
    s.seam_damping_ratio = r.number(t, w, "seam_damping_ratio", s.seam_damping_ratio,
                                    minimum=0.0)  # fmt: skip
    if s.seam_damping_ratio > 1.0:
        raise SandboxError(f"{r.source}: {w} seam_damping_ratio must be at most 1 (critical "
                           f"damping), got {s.seam_damping_ratio}")  # fmt: skip
    s.seam_hold_m = r.number(t, w, "seam_hold_m", s.seam_hold_m, minimum=0.0)
    if s.seam_hold_m > 0 and s.integrator != "symplectic_euler":
        raise SandboxError(f"{r.source}: {w} seam_hold_m is for symplectic_euler only "
                           f"(backward Euler takes stiff seams as they are)")  # fmt: skip
    s.bending = r.boolean(t, w, "bending", s.bending)
    s.linear_solver = r.choice(t, w, "linear_solver", LINEAR_SOLVERS, s.linear_solver)
    if s.dt_s is not None and s.dt_s > 1.0 / s.frame_rate_hz:
        raise SandboxError(f"{r.source}: {w} dt_s ({s.dt_s}) is longer than one frame")
    return s


def _stop(r: _Reader, t: dict) -> StopSpec:
    w = "[stop]"
    s = StopSpec()
    r.keys(t, w, set(s.__dataclass_fields__))
    s.max_displacement_m = r.number(t, w, "max_displacement_m", s.max_displacement_m, True)
    s.mean_displacement_m = r.number(t, w, "mean_displacement_m", s.mean_displacement_m, True)
    s.frames = int(r.number(t, w, "frames", s.frames, positive=True, integer=True))
    s.min_time_s = r.number(t, w, "min_time_s", s.min_time_s, minimum=0.0)
    s.time_limit_s = r.number(t, w, "time_limit_s", s.time_limit_s, positive=True)
    s.wall_limit_s = r.number(t, w, "wall_limit_s", s.wall_limit_s, positive=True)
    if "residual_mean" in t:
        s.residual_mean = r.number(t, w, "residual_mean", positive=True)
    return s


def _cloth(r: _Reader, t: dict, w: str) -> ClothSpec:
    if not isinstance(t, dict):
        raise SandboxError(f"{r.source}: {w} must be a table")
    r.keys(t, w, {"name", "shape", "size_m", "outline_m", "edge_length_m", "mesher", "material",
                  "grain_deg", "origin_m", "rotation_deg", "velocity_m_s", "pins",
                  "mesh_lines_m"})  # fmt: skip
    name = r.string(t, w, "name", w)
    shape = r.choice(t, w, "shape", SHAPES, "rectangle")
    if shape == "rectangle":
        if "outline_m" in t:
            raise SandboxError(f"{r.source}: {w}: 'outline_m' is for shape = \"polygon\"")
        sx, sy = r.vector(t, w, "size_m", 2, None, positive=True)
        outline = [(0.0, 0.0), (sx, 0.0), (sx, sy), (0.0, sy)]
    else:
        if "size_m" in t:
            raise SandboxError(f"{r.source}: {w}: 'size_m' is for shape = \"rectangle\"")
        pts = t.get("outline_m")
        if not isinstance(pts, list) or len(pts) < 3:
            raise SandboxError(f"{r.source}: {w}.outline_m: a list of at least 3 [u, v] points")
        outline = [tuple(r.vector({"p": p}, f"{w}.outline_m[{i}]", "p", 2, None))
                   for i, p in enumerate(pts)]  # fmt: skip
    mesher = r.choice(t, w, "mesher", MESHERS, "irregular")
    if mesher == "grid" and shape != "rectangle":
        raise SandboxError(f'{r.source}: {w}: mesher = "grid" needs shape = "rectangle"')
    if "material" not in t:
        raise SandboxError(f"{r.source}: {w}: 'material' is missing (a preset name or a table)")
    c = ClothSpec(
        name=name,
        outline_m=outline,
        edge_length_m=r.number(t, w, "edge_length_m", None, positive=True),
        material=material_from_spec(t["material"], where=f"{r.source}: {w}.material"),
        mesher=mesher,
        grain_deg=r.number(t, w, "grain_deg", 0.0),
        origin_m=r.vector(t, w, "origin_m", 3, (0.0, 0.0, 0.0)),
        rotation_deg=r.vector(t, w, "rotation_deg", 3, (0.0, 0.0, 0.0)),
        velocity_m_s=r.vector(t, w, "velocity_m_s", 3, (0.0, 0.0, 0.0)),
        where=f"{r.source}: {w}",
    )
    pins = t.get("pins", [])
    if not isinstance(pins, list):
        raise SandboxError(f"{r.source}: {w}.pins must be a list of tables")
    c.pins = [_pin(r, p, f"{w}.pins[{i}]") for i, p in enumerate(pins)]
    _check_pins(c)
    lines = t.get("mesh_lines_m", [])
    if not isinstance(lines, list):
        raise SandboxError(f"{r.source}: {w}.mesh_lines_m must be a list of [[u0, v0], [u1, v1]]")
    for i, seg in enumerate(lines):
        if not isinstance(seg, list) or len(seg) != 2:
            raise SandboxError(f"{r.source}: {w}.mesh_lines_m[{i}] must be [[u0, v0], [u1, v1]]")
        a = r.vector({"p": seg[0]}, f"{w}.mesh_lines_m[{i}][0]", "p", 2, None)
        b = r.vector({"p": seg[1]}, f"{w}.mesh_lines_m[{i}][1]", "p", 2, None)
        c.mesh_lines_m.append((a, b))
    if c.mesh_lines_m and c.mesher == "grid":
        raise SandboxError(f'{r.source}: {w}: mesh_lines_m needs mesher = "irregular"')
    return c


def _collision(r: _Reader, t: dict) -> CollisionSpec:
    w = "[collision]"
    c = CollisionSpec()
    r.keys(t, w, set(c.__dataclass_fields__))
    c.thickness_m = r.number(t, w, "thickness_m", c.thickness_m, positive=True)
    c.friction_static = r.number(t, w, "friction_static", c.friction_static, minimum=0.0)
    c.friction_kinetic = r.number(t, w, "friction_kinetic", c.friction_kinetic, minimum=0.0)
    if "self_collision" in t:
        c.self_collision = r.boolean(t, w, "self_collision", False)
    c.body_faces = r.boolean(t, w, "body_faces", False)
    if c.friction_kinetic > c.friction_static:
        raise SandboxError(f"{r.source}: {w}: friction_kinetic must not exceed friction_static")
    return c


def _collider(r: _Reader, t, w: str) -> ColliderSpec:
    if not isinstance(t, dict):
        raise SandboxError(f"{r.source}: {w} must be a table")
    shape = r.choice(t, w, "shape", tuple(COLLIDER_KEYS), None)
    r.keys(t, w, {"name", "shape"} | COLLIDER_KEYS[shape])
    p: dict = {}
    if shape in ("sphere", "box", "cylinder"):
        p["center_m"] = r.vector(t, w, "center_m", 3, None)
    if shape in ("sphere", "cylinder"):
        p["radius_m"] = r.number(t, w, "radius_m", None, positive=True)
    if shape == "sphere":
        p["subdivisions"] = int(r.number(t, w, "subdivisions", 4, positive=True, integer=True))
    if shape == "cylinder":
        p["height_m"] = r.number(t, w, "height_m", None, positive=True)
    if shape == "box":
        p["size_m"] = r.vector(t, w, "size_m", 3, None, positive=True)
    if shape in ("box", "cylinder", "mesh"):
        p["rotation_deg"] = r.vector(t, w, "rotation_deg", 3, (0.0, 0.0, 0.0))
    if shape == "plane":
        p["point_m"] = r.vector(t, w, "point_m", 3, (0.0, 0.0, 0.0))
        p["normal"] = r.vector(t, w, "normal", 3, (0.0, 1.0, 0.0))
        p["size_m"] = r.number(t, w, "size_m", 10.0, positive=True)
    if shape == "mesh":
        path = r.string(t, w, "path", "")
        if not path:
            r.fail(w, "path", "is missing (a mesh file: OBJ, PLY, GLB, STL)")
        base = Path(r.source).parent if r.source not in ("<scene>",) else Path(".")
        p["path"] = str((base / path).resolve()) if not Path(path).is_absolute() else path
        if not Path(p["path"]).is_file():
            r.fail(w, "path", f"no such file: {p['path']}")
        p["scale"] = r.number(t, w, "scale", 1.0, positive=True)
        p["origin_m"] = r.vector(t, w, "origin_m", 3, (0.0, 0.0, 0.0))
    if shape == "mannequin":
        p["size"], p["measurements_cm"] = _mannequin(r, t, w)
    return ColliderSpec(name=r.string(t, w, "name", w), shape=shape, params=p,
                        where=f"{r.source}: {w}")  # fmt: skip


def _mannequin(r: _Reader, t: dict, w: str) -> tuple[int | None, dict]:
    """A mannequin collider's database size and its seven measurements [cm]: those given,
    the rest from the size (default 12); every value checked against the supported ranges."""
    from sandbox.mannequin.measurements import KEYS, load_size_table, validate

    size = t.get("size")
    sizes = {e.size: e for e in load_size_table()}
    if size is not None and (isinstance(size, bool) or not isinstance(size, int)):
        r.fail(w, "size", f"must be a size number from the database, got {size!r}")
    if size is not None and size not in sizes:
        r.fail(w, "size", f"{size} is not in the size database (sizes {list(sizes)})")
    m = t.get("measurements_cm", {})
    if not isinstance(m, dict):
        r.fail(w, "measurements_cm", "must be a table of measurements in cm")
    unknown = sorted(set(m) - set(KEYS))
    if unknown:
        r.fail(w, "measurements_cm", f"unknown key {unknown[0]!r} (known: {', '.join(KEYS)})")
    given = {k: r.number(m, f"{w} measurements_cm", k, positive=True) for k in m}
    if not given:
        return size, {}
    full = sizes[12 if size is None else size].measurements.replace(**given)
    names = {k: f"measurements_cm.{k}" for k in KEYS}
    try:
        validate(full, flag_names=names)
    except SandboxError as exc:
        raise SandboxError(f"{r.source}: {w}: {exc}") from None
    return size, full.to_dict()


def _seam(r: _Reader, t, w: str, cloths: dict) -> SeamSpec:
    if not isinstance(t, dict):
        raise SandboxError(f"{r.source}: {w} must be a table")
    r.keys(t, w, {"name", "a", "b", "direction", "stiffness_N_m"})
    sides = []
    for key in ("a", "b"):
        edges = t.get(key)
        if not isinstance(edges, list) or not edges:
            r.fail(w, key, 'must be a list of edges such as [{ cloth = "front", edge = 1 }]')
        side = []
        for i, e in enumerate(edges):
            we = f"{w}.{key}[{i}]"
            if not isinstance(e, dict):
                raise SandboxError(f"{r.source}: {we} must be a table")
            r.keys(e, we, {"cloth", "edge", "from_m", "to_m"})
            name = r.string(e, we, "cloth", "")
            if name not in cloths:
                r.fail(we, "cloth", f"no cloth named {name!r} (known: {', '.join(cloths)})")
            cloth = cloths[name]
            outline = cloth.outline_m
            if "edge" in e:
                k = e["edge"]
                if isinstance(k, bool) or not isinstance(k, int) or not 0 <= k < len(outline):
                    r.fail(we, "edge", f"must be an outline edge number 0..{len(outline) - 1}")
                a, b = outline[k], outline[(k + 1) % len(outline)]
                if _length(a, b) <= _same_point_m(cloth):
                    r.fail(we, "edge", f"{k} has zero length (corners {k} and "
                           f"{(k + 1) % len(outline)} are the same point, {list(a)})")  # fmt: skip
            else:
                a = r.vector(e, we, "from_m", 2, None)
                b = r.vector(e, we, "to_m", 2, None)
                problem = _seam_segment_problem(cloth, a, b)
                if problem:
                    raise SandboxError(f"{r.source}: {we}: from_m {list(a)} to_m {list(b)} "
                                       f"{problem}")  # fmt: skip
            side.append((name, tuple(a), tuple(b)))
        sides.append(side)
    k = t.get("stiffness_N_m")
    return SeamSpec(
        name=r.string(t, w, "name", w),
        side_a=sides[0],
        side_b=sides[1],
        direction=r.choice(t, w, "direction", ("auto", "same", "reverse"), "auto"),
        stiffness_N_m=None if k is None else r.number(t, w, "stiffness_N_m", None, True),
        where=f"{r.source}: {w}",
    )


def _length(a, b) -> float:
    return math.hypot(b[0] - a[0], b[1] - a[1])


def _same_point_m(c: ClothSpec) -> float:
    """Distance [m] under which two outline points are one (the mesher drops the second)."""
    from sandbox.pattern.mesh2d import DUPLICATE_TOLERANCE

    us, vs = [u for u, _ in c.outline_m], [v for _, v in c.outline_m]
    return DUPLICATE_TOLERANCE * max(max(us) - min(us), max(vs) - min(vs))


def _seam_segment_problem(c: ClothSpec, a, b) -> str | None:
    """Why a ``from_m``/``to_m`` seam edge would fail on the piece's mesh, or None.

    The edge must be a segment of the outline or of a mesh line (``mesh_lines_m``), and
    at least two of the points the mesher puts on those lines must lie on it: the corners
    and the points that cut each side into pieces at most ``edge_length_m`` long (the
    grid's columns and rows with ``mesher = "grid"``). Triangle keeps these points, so the
    built mesh has them, and the builder finds the seam's vertices
    (:func:`sandbox.sim.seams.edge_vertices`) with the tolerance used here.
    """
    length = _length(a, b)
    if length <= _same_point_m(c):
        return "has zero length"
    ax, ay, dx, dy = a[0], a[1], b[0] - a[0], b[1] - a[1]
    tol = 1e-7 * max(length, 1.0)  # distance to the line [m], as edge_vertices

    def off(p):  # distance from the seam's line [m]
        return abs((p[0] - ax) * dy - (p[1] - ay) * dx) / length

    def at(p):  # parameter along the seam: 0 at from_m, 1 at to_m
        return ((p[0] - ax) * dx + (p[1] - ay) * dy) / (length * length)

    n = len(c.outline_m)
    lines = [(c.outline_m[i], c.outline_m[(i + 1) % n]) for i in range(n)]
    lines += [(p, q) for p, q in c.mesh_lines_m]
    covered, points = [], []
    for p, q in lines:
        if off(p) > tol or off(q) > tol:
            continue  # not along the seam
        tp, tq = at(p), at(q)
        covered.append((min(tp, tq), max(tp, tq)))
        pieces = _pieces(_length(p, q), c)
        points += [tp + (tq - tp) * j / pieces for j in _on_seam(tp, tq, pieces)]
    reach = _covered_to(covered, tol / length)
    if reach < 1.0:
        u, v = ax + reach * dx, ay + reach * dy
        us, vs = [u for u, _ in c.outline_m], [v for _, v in c.outline_m]
        lines = " or mesh lines" if c.mesh_lines_m else ""
        return (f"does not lie on the outline{lines} of cloth {c.name!r} (first point off "
                f"it: ({u:.6g}, {v:.6g}) m; the outline spans u {min(us):g}..{max(us):g} m, "
                f"v {min(vs):g}..{max(vs):g} m)")  # fmt: skip
    points.sort()
    count = len(points) and 1 + sum(y - x > tol / length for x, y in pairwise(points))
    if count < 2:
        return (f"is shorter than the mesh's spacing along it: {count} mesh vertex lies on "
                f"it and a seam needs 2 or more (make it longer, or edge_length_m = "
                f"{c.edge_length_m:g} m smaller)")  # fmt: skip
    return None


def _pieces(length: float, c: ClothSpec) -> int:
    """Pieces the mesher cuts a side or mesh line of this length [m] into."""
    h = c.edge_length_m
    if c.mesher == "grid":  # sandbox.pattern.mesh2d.mesh_grid's columns and rows
        return max(1, round(length / h))
    return max(1, math.ceil(length / h - 1e-9))  # mesh2d.resample_outline


def _on_seam(tp: float, tq: float, pieces: int) -> list[int]:
    """Some j in 0..pieces whose points tp + (tq - tp) j / pieces lie on [0, 1] (the
    first two and the last: enough to tell one point from two), as edge_vertices sees
    them (1e-9 beyond either end)."""
    step = (tq - tp) / pieces
    if step == 0:
        return [0] if -1e-9 <= tp <= 1 + 1e-9 else []
    lo, hi = sorted(((-1e-9 - tp) / step, (1 + 1e-9 - tp) / step))
    first, last = max(0, math.ceil(lo - 1e-9)), min(pieces, math.floor(hi + 1e-9))
    return sorted({first, min(first + 1, last), last}) if first <= last else []


def _covered_to(intervals, eps: float) -> float:
    """How far along [0, 1] the intervals cover it from 0 without a gap (eps bridged)."""
    reach = 0.0
    for lo, hi in sorted(intervals):
        if lo > reach + eps:
            break
        reach = max(reach, hi)
    return 1.0 if reach >= 1.0 - eps else reach


def _pin(r: _Reader, t, w: str) -> PinSpec:
    if not isinstance(t, dict):
        raise SandboxError(f'{r.source}: {w} must be a table such as {{ side = "top" }}')
    r.keys(t, w, {"vertices", "region_m", "side", "corners"})
    if len(t) != 1:
        raise SandboxError(
            f"{r.source}: {w}: give exactly one of vertices, region_m, side, corners"
        )
    p = PinSpec(where=f"{r.source}: {w}")
    if "vertices" in t:
        v = t["vertices"]
        if not isinstance(v, list) or not all(isinstance(i, int) and not isinstance(i, bool)
                                              for i in v):  # fmt: skip
            raise SandboxError(f"{r.source}: {w}.vertices must be a list of integers")
        p.vertices = list(v)
    elif "region_m" in t:
        box = t["region_m"]
        if not isinstance(box, list) or len(box) != 2:
            raise SandboxError(f"{r.source}: {w}.region_m must be [[u_min, v_min], [u_max, v_max]]")
        lo = r.vector({"p": box[0]}, f"{w}.region_m[0]", "p", 2, None)
        hi = r.vector({"p": box[1]}, f"{w}.region_m[1]", "p", 2, None)
        p.region_m = (lo, hi)
    elif "side" in t:
        p.side = r.choice(t, w, "side", SIDES, None)
    else:
        p.corners = r.choice(t, w, "corners", SIDES + ("all",), None)
    return p


def _check_pins(c: ClothSpec) -> None:
    """What can be said of the pins before meshing: no negative vertex index, no empty or
    inverted box, no box beside the outline (indices past the mesh are found at meshing)."""
    us, vs = [u for u, _ in c.outline_m], [v for _, v in c.outline_m]
    for p in c.pins:
        if p.vertices is not None and any(i < 0 for i in p.vertices):
            bad = next(i for i in p.vertices if i < 0)
            raise SandboxError(f"{p.where}.vertices: index {bad} is negative (vertices are "
                               f"numbered from 0)")  # fmt: skip
        if p.region_m is None:
            continue
        (u0, v0), (u1, v1) = p.region_m
        if u0 > u1 or v0 > v1:
            raise SandboxError(f"{p.where}.region_m: must be [[u_min, v_min], [u_max, v_max]], "
                               f"got {[list(p.region_m[0]), list(p.region_m[1])]}")  # fmt: skip
        if u1 < min(us) or u0 > max(us) or v1 < min(vs) or v0 > max(vs):
            raise SandboxError(f"{p.where}.region_m: the box lies outside the piece (its "
                               f"outline spans u {min(us):g}..{max(us):g} m, v "
                               f"{min(vs):g}..{max(vs):g} m)")  # fmt: skip


class _Reader:
    """Typed access to TOML tables with errors that name the file, the entry and the key."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, where: str, key: str, msg: str):
        loc = f"{where} {key}" if where else key
        raise SandboxError(f"{self.source}: {loc.strip()}: {msg}")

    def keys(self, t, where: str, allowed: set[str]):
        if not isinstance(t, dict):
            raise SandboxError(f"{self.source}: {where or 'top level'} must be a table")
        unknown = sorted(set(t) - allowed)
        if unknown:
            raise SandboxError(
                f"{self.source}: {where or 'top level'}: unknown key "
                f"{', '.join(repr(k) for k in unknown)} (allowed: {', '.join(sorted(allowed))})"
            )

    def string(self, t, where, key, default):
        v = t.get(key, default)
        if not isinstance(v, str):
            self.fail(where, key, f"must be a string, got {v!r}")
        return v

    def boolean(self, t, where, key, default):
        v = t.get(key, default)
        if not isinstance(v, bool):
            self.fail(where, key, f"must be true or false, got {v!r}")
        return v

    def choice(self, t, where, key, options, default):
        v = t.get(key, default)
        if v not in options:
            self.fail(where, key, f"must be one of {', '.join(options)}, got {v!r}")
        return v

    def number(self, t, where, key, default=None, positive=False, minimum=None, integer=False):
        if key not in t and default is None:
            self.fail(where, key, "is missing")
        v = t.get(key, default)
        if isinstance(v, bool) or not isinstance(v, int | float):
            self.fail(where, key, f"must be a number, got {v!r}")
        if not math.isfinite(v):
            self.fail(where, key, f"must be finite, got {v!r}")
        if positive and v <= 0:
            self.fail(where, key, f"must be > 0, got {v!r}")
        if minimum is not None and v < minimum:
            self.fail(where, key, f"must be >= {minimum}, got {v!r}")
        if integer and v != int(v):
            self.fail(where, key, f"must be a whole number, got {v!r}")
        return float(v)

    def vector(self, t, where, key, n, default, positive=False):
        if key not in t and default is None:
            self.fail(where, key, "is missing")
        v = t.get(key, default)
        if not isinstance(v, list | tuple) or len(v) != n:
            self.fail(where, key, f"must be a list of {n} numbers, got {v!r}")
        return tuple(self.number({key: x}, where, key, positive=positive) for x in v)
