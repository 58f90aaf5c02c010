"""A batch spec: the TOML file that names the garments, bodies, fabrics and settings of a batch.

``load_spec(path)`` reads and checks every key before anything starts (no Ray, no Taichi):
each problem is one :class:`~sandbox.errors.SandboxError` line naming the file, the key and
what is wrong. :func:`expand_tasks` turns a checked :class:`BatchSpec` into its tasks, the
product of the lists (garments × bodies × fabrics × mesh edges × integrators), each with a
stable id made of its inputs and a hash of every setting that shapes its outputs.

Units: the file gives the mesh edge in cm (``edge_cm``, as ``drape --edge-cm``), body
measurements in cm (as ``drape --bust`` and ``measurements.json``), times in s, lengths in
m; inside, everything is SI (:attr:`Task.edge_m`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from sandbox.batch.gates import GateThresholds, gates_from_table
from sandbox.errors import SandboxError
from sandbox.garment.config import (
    DRAPE_METHODS,
    DrapeConfig,
    config_dict,
    drape_config_from_dict,
    implicit_mesh_warning,
)
from sandbox.scene.spec import INTEGRATORS

OWN_FABRIC = "own"
"""The fabrics entry meaning: each garment's own fabric (the pattern's ``fabric``)."""

TOP_KEYS = {
    "name": "a label for the batch (text)",
    "garments": '"all", or a list of library names and pattern .json files',
    "bodies": "a table: sizes, measured, garmentcode, random",
    "fabrics": f'a list of presets or "{OWN_FABRIC}" (default ["{OWN_FABRIC}"])',
    "edge_cm": "mesh edge in cm, a number or a list",
    "integrator": "symplectic_euler or implicit_euler, or a list",
    "method": "coarse_to_fine or direct",
    "wall_limit_s": "wall-clock limit per task in s",
    "kill_after_s": "hard limit per task in s: the worker is killed",
    "retries": "how often a crashed worker's task is run again",
    "render": "front and back PNG per task (true/false)",
    "meshes": "garment.obj/.ply per task (true/false)",
    "body_mesh": "body.obj per task (true/false)",
    "float64": "double precision (true/false)",
    "threads_per_worker": "Taichi CPU threads per worker (1: bit-identical results)",
    "drape": "a table of DrapeConfig fields ([drape.sewing], [drape.repair], [drape.limits])",
    "gates": "a table of quality-gate thresholds",
}
"""Every key a batch spec may have at the top level, with what it takes."""

BODY_KEYS = ("sizes", "measured", "garmentcode", "random")
RANDOM_KEYS = ("count", "seed", "spread")
DEFAULT_WALL_LIMIT_S = 1800.0
"""Default wall-clock limit per task [s] (the drape's own ``DrapeConfig.wall_limit_s``)."""
DEFAULT_SPREAD = 0.05
"""Default relative spread of a random body's measurements around the interpolated size."""
MAX_SPREAD = 0.2
RANDOM_TRIES = 200
"""Draws per random body before giving up on finding one the mannequin supports."""


@dataclass(frozen=True)
class Body:
    """One body of a batch: a database ``size`` (UK 6-26) or a set of seven measurements
    [cm] (keys of :data:`sandbox.mannequin.measurements.KEYS`), resized from ``size``."""

    label: str
    """Short name used in task ids and the manifest (``size12``, ``rand7-003``, a user's)."""
    size: int | None
    """Database size the body starts from (None: the closest to the measurements)."""
    measurements_cm: tuple[tuple[str, float], ...] | None = None
    """Measurement name and value [cm], all seven, sorted by name; None: the database size."""
    kind: str = "size"
    """``size``, ``measured``, ``garmentcode`` or ``random``."""

    def measurements(self) -> dict[str, float] | None:
        return None if self.measurements_cm is None else dict(self.measurements_cm)


@dataclass(frozen=True)
class Garment:
    """One garment of a batch: a library name (drafted for each body) or a pattern file."""

    label: str
    """Library name, or the pattern file's name without ``.json``."""
    path: str | None = None
    """The pattern file (absolute), or None for a library garment."""
    pattern: str | None = field(default=None, compare=False, repr=False)
    """The pattern file's text (JSON), read once when the spec is loaded, so that workers
    on other machines need no shared file system."""

    def source_digest(self) -> str:
        if self.pattern is None:
            return f"library:{self.label}"
        return "file:" + hashlib.sha256(self.pattern.encode()).hexdigest()


@dataclass(frozen=True)
class BatchSpec:
    """A checked batch spec (see docs/batch.md for the file)."""

    path: Path
    name: str
    garments: tuple[Garment, ...]
    bodies: tuple[Body, ...]
    fabrics: tuple[str | None, ...]
    """Preset names; None: the garment's own fabric."""
    edges_m: tuple[float, ...]
    """Mesh edges [m]."""
    integrators: tuple[str, ...]
    config: DrapeConfig
    """The drape settings shared by every task (integrator set per task)."""
    gates: GateThresholds
    wall_limit_s: float = DEFAULT_WALL_LIMIT_S
    """Wall-clock limit of one task [s]: the drape stops there (the ``time_limit`` gate)."""
    kill_after_s: float = 2 * DEFAULT_WALL_LIMIT_S + 120.0
    """Hard wall-clock limit of one task [s]: past it the worker is killed, a new one is
    started and the task is marked failed (``time_limit``)."""
    retries: int = 2
    """A task whose worker crashed is run again at most this many times."""
    render: bool = True
    meshes: bool = True
    body_mesh: bool = False
    float64: bool = True
    threads_per_worker: int = 1
    warnings: tuple[str, ...] = ()

    @property
    def task_count(self) -> int:
        return (len(self.garments) * len(self.bodies) * len(self.fabrics) * len(self.edges_m)
                * len(self.integrators))  # fmt: skip


@dataclass(frozen=True)
class Task:
    """One drape of a batch: a garment on a body in a fabric at a mesh edge and integrator."""

    task_id: str
    """Folder name of the task: readable inputs and a hash of every setting (stable)."""
    index: int
    """Position in the spec's product order."""
    garment: Garment
    body: Body
    fabric: str | None
    edge_m: float
    """Mesh edge [m]."""
    integrator: str
    config: DrapeConfig
    """This task's drape settings (integrator, wall limit and acceptance filled in)."""
    gates: GateThresholds
    render: bool = True
    meshes: bool = True
    body_mesh: bool = False
    float64: bool = True
    kill_after_s: float = 2 * DEFAULT_WALL_LIMIT_S + 120.0

    def inputs(self) -> dict:
        """The task's inputs as plain JSON values (for plan.jsonl, metrics.json, manifest)."""
        return {
            "task_id": self.task_id,
            "index": self.index,
            "garment": self.garment.label,
            "pattern_file": self.garment.path,
            "body": self.body.label,
            "body_kind": self.body.kind,
            "size": self.body.size,
            "measurements_cm": self.body.measurements(),
            "fabric": self.fabric or OWN_FABRIC,
            "edge_m": self.edge_m,
            "integrator": self.integrator,
            "method": self.config.method,
            "wall_limit_s": self.config.wall_limit_s,
            "float64": self.float64,
        }


# --------------------------------------------------------------------------- reading
class _Where:
    """Builds the one-line messages: ``FILE: KEY: problem``."""

    def __init__(self, path: Path):
        self.path = path

    def error(self, key: str, problem: str) -> SandboxError:
        return SandboxError(f"{self.path}: {key}: {problem}")


def load_spec(path) -> BatchSpec:
    """Read and check a batch spec file (TOML). Raises SandboxError naming the file, the key
    and the problem for anything missing, unknown or out of range."""
    p = Path(path)
    if not p.is_file():
        raise SandboxError(f"{p}: no such batch spec file")
    try:
        table = tomllib.loads(p.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise SandboxError(f"{p}: not a TOML file ({exc})") from None
    except OSError as exc:
        raise SandboxError(f"{p}: cannot read it ({exc.strerror})") from None
    return spec_from_dict(table, p)


def spec_from_dict(table: dict, path) -> BatchSpec:
    """A checked :class:`BatchSpec` from a parsed TOML table; ``path`` names the file in
    messages and is where pattern files are found relative to."""
    p = Path(path)
    w = _Where(p)
    unknown = sorted(set(table) - set(TOP_KEYS))
    if unknown:
        raise w.error(unknown[0], f"unknown key; known keys: {', '.join(TOP_KEYS)}")
    for key in ("garments", "bodies"):
        if key not in table:
            raise w.error(key, f"missing; give {TOP_KEYS[key]}")
    name = table.get("name", p.stem)
    if not isinstance(name, str) or not name.strip():
        raise w.error("name", f"must be a non-empty text, got {name!r}")
    garments = _garments(table["garments"], w, p.parent)
    bodies = _bodies(table["bodies"], w)
    fabrics = _fabrics(table.get("fabrics", [OWN_FABRIC]), w)
    edges = tuple(e / 100.0 for e in _numbers(table.get("edge_cm", 3.0), "edge_cm", w))
    integrators = _texts(table.get("integrator", "symplectic_euler"), "integrator", w,
                         INTEGRATORS)  # fmt: skip
    method = table.get("method", "coarse_to_fine")
    if method not in DRAPE_METHODS:
        raise w.error("method", f"must be one of {', '.join(DRAPE_METHODS)}, got {method!r}")
    wall = _positive(table.get("wall_limit_s", DEFAULT_WALL_LIMIT_S), "wall_limit_s", w)
    kill = _positive(table.get("kill_after_s", 2.0 * wall + 120.0), "kill_after_s", w)
    if kill < wall:
        raise w.error("kill_after_s", f"{kill:g} s is shorter than wall_limit_s = {wall:g} s")
    retries = _whole(table.get("retries", 2), "retries", w, lowest=0)
    threads = _whole(table.get("threads_per_worker", 1), "threads_per_worker", w, lowest=1)
    defaults = {"render": True, "meshes": True, "body_mesh": False, "float64": True}
    flags = {k: _flag(table.get(k, d), k, w) for k, d in defaults.items()}
    gates = gates_from_table(table.get("gates", {}), f"{p}: gates")
    config = _drape_config(table.get("drape", {}), w, method=method, wall=wall, gates=gates)
    warnings = tuple(dict.fromkeys(m for i in integrators for e in edges
                                   if (m := implicit_mesh_warning(i, e))))  # fmt: skip
    return BatchSpec(path=p, name=name, garments=garments, bodies=bodies, fabrics=fabrics,
                     edges_m=edges, integrators=integrators, config=config, gates=gates,
                     wall_limit_s=wall, kill_after_s=kill, retries=retries,
                     threads_per_worker=threads, warnings=warnings, **flags)  # fmt: skip


def _list(value, key: str, w: _Where) -> list:
    items = value if isinstance(value, list) else [value]
    if not items:
        raise w.error(key, "an empty list")
    return items


def _numbers(value, key: str, w: _Where) -> tuple[float, ...]:
    out = []
    for i, v in enumerate(_list(value, key, w)):
        where = key if not isinstance(value, list) else f"{key}[{i}]"
        out.append(_positive(v, where, w))
    if len(set(out)) != len(out):
        raise w.error(key, f"a value is listed twice ({value!r})")
    return tuple(out)


def _texts(value, key: str, w: _Where, allowed) -> tuple[str, ...]:
    out = []
    for v in _list(value, key, w):
        if v not in allowed:
            raise w.error(key, f"{v!r} is not one of {', '.join(allowed)}")
        out.append(v)
    if len(set(out)) != len(out):
        raise w.error(key, f"a value is listed twice ({value!r})")
    return tuple(out)


def _positive(v, key: str, w: _Where) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float) or not (v > 0 and math.isfinite(v)):
        raise w.error(key, f"must be a positive number, got {v!r}")
    return float(v)


def _whole(v, key: str, w: _Where, *, lowest: int) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or v < lowest:
        raise w.error(key, f"must be a whole number >= {lowest}, got {v!r}")
    return v


def _flag(v, key: str, w: _Where) -> bool:
    if not isinstance(v, bool):
        raise w.error(key, f"must be true or false, got {v!r}")
    return v


def _garments(value, w: _Where, base: Path) -> tuple[Garment, ...]:
    from sandbox.garment import garment_names

    library = garment_names()
    if value == "all":
        return tuple(Garment(n) for n in library)
    out: list[Garment] = []
    for i, item in enumerate(_list(value, "garments", w)):
        key = f"garments[{i}]"
        if not isinstance(item, str) or not item:
            raise w.error(key, f"must be a garment name or a pattern .json file, got {item!r}")
        if item == "all":
            raise w.error(key, '"all" stands alone: garments = "all"')
        if item in library:
            out.append(Garment(item))
            continue
        path = Path(item) if Path(item).is_absolute() else base / item
        if path.suffix.lower() != ".json" and not path.exists():
            raise w.error(key, f"unknown garment {item!r}: not in the library "
                          f"({', '.join(library)}) and not a pattern .json file")  # fmt: skip
        out.append(_pattern_file(path, key, w))
    labels = [g.label for g in out]
    twice = sorted({x for x in labels if labels.count(x) > 1})
    if twice:
        raise w.error("garments", f"{twice[0]!r} is listed twice")
    return tuple(out)


def _pattern_file(path: Path, key: str, w: _Where) -> Garment:
    from sandbox.pattern.spec import load_pattern

    if not path.is_file():
        raise w.error(key, f"{path}: no such pattern file")
    try:
        text = path.read_text(encoding="utf-8")
        load_pattern(json.loads(text), where=str(path))
    except (OSError, UnicodeDecodeError) as exc:
        raise w.error(key, f"{path}: cannot read it ({exc})") from None
    except json.JSONDecodeError as exc:
        raise w.error(key, f"{path}: not JSON ({exc})") from None
    except SandboxError as exc:
        raise w.error(key, str(exc)) from None
    return Garment(path.stem, str(path.resolve()), text)


def _fabrics(value, w: _Where) -> tuple[str | None, ...]:
    from sandbox.sim.materials import get_material

    out: list[str | None] = []
    for i, item in enumerate(_list(value, "fabrics", w)):
        key = f"fabrics[{i}]" if isinstance(value, list) else "fabrics"
        if not isinstance(item, str):
            raise w.error(key, f'must be a preset name or "{OWN_FABRIC}", got {item!r}')
        if item == OWN_FABRIC:
            out.append(None)
            continue
        try:
            out.append(get_material(item).name)
        except SandboxError as exc:
            raise w.error(key, str(exc)) from None
    if len(set(out)) != len(out):
        raise w.error("fabrics", f"a fabric is listed twice ({value!r})")
    return tuple(out)


def _drape_config(table, w: _Where, *, method: str, wall: float,
                  gates: GateThresholds) -> DrapeConfig:  # fmt: skip
    if not isinstance(table, dict):
        raise w.error("drape", f"must be a table of DrapeConfig fields, got {table!r}")
    moved = {"integrator": "the top-level integrator", "method": "the top-level method",
             "wall_limit_s": "the top-level wall_limit_s",
             "acceptance": "the [gates] table"}  # fmt: skip
    for key, instead in moved.items():
        if key in table:
            raise w.error(f"drape.{key}", f"set by {instead} in a batch spec")
    config = drape_config_from_dict(table, f"{w.path}: drape")
    return dataclasses.replace(config, method=method, wall_limit_s=wall,
                               acceptance=gates.acceptance())  # fmt: skip


# ---------------------------------------------------------------------------- bodies
def _bodies(table, w: _Where) -> tuple[Body, ...]:
    if not isinstance(table, dict):
        raise w.error("bodies", "must be a table with sizes, measured, garmentcode and/or random")
    unknown = sorted(set(table) - set(BODY_KEYS))
    if unknown:
        raise w.error(f"bodies.{unknown[0]}", f"unknown key; known: {', '.join(BODY_KEYS)}")
    out: list[Body] = []
    if "sizes" in table:
        out += _sizes(table["sizes"], w)
    if "measured" in table:
        out += _measured(table["measured"], w)
    if "garmentcode" in table:
        out += _garmentcode(table["garmentcode"], w)
    if "random" in table:
        out += _random(table["random"], w)
    if not out:
        raise w.error("bodies", "no body: give sizes, measured, garmentcode and/or random")
    labels = [b.label for b in out]
    twice = sorted({x for x in labels if labels.count(x) > 1})
    if twice:
        raise w.error("bodies", f"two bodies are called {twice[0]!r}")
    return tuple(out)


def _database_sizes() -> list[int]:
    from sandbox.mannequin.measurements import load_size_table

    return [e.size for e in load_size_table()]


def _sizes(value, w: _Where) -> list[Body]:
    sizes = _database_sizes()
    out = []
    for i, s in enumerate(_list(value, "bodies.sizes", w)):
        if isinstance(s, bool) or not isinstance(s, int) or s not in sizes:
            raise w.error(f"bodies.sizes[{i}]", f"{s!r} is not a database size "
                          f"({', '.join(map(str, sizes))})")  # fmt: skip
        out.append(Body(f"size{s}", s))
    return out


def _measured(value, w: _Where) -> list[Body]:
    from sandbox.mannequin.measurements import KEYS, size_entry, validate

    if not isinstance(value, list) or not value or not all(isinstance(t, dict) for t in value):
        raise w.error("bodies.measured", "must be an array of tables ([[bodies.measured]])")
    sizes = _database_sizes()
    out = []
    for i, t in enumerate(value):
        key = f"bodies.measured[{i}]"
        unknown = sorted(set(t) - set(KEYS) - {"label", "size"})
        if unknown:
            raise w.error(f"{key}.{unknown[0]}", f"unknown key; known: label, size, "
                          f"{', '.join(KEYS)} (cm)")  # fmt: skip
        label = t.get("label", f"measured{i}")
        if not isinstance(label, str) or not re.fullmatch(r"[A-Za-z0-9._-]+", label):
            raise w.error(f"{key}.label", f"must be letters, digits, '.', '_' or '-', got "
                          f"{label!r}")  # fmt: skip
        size = t.get("size", 12)
        if isinstance(size, bool) or not isinstance(size, int) or size not in sizes:
            raise w.error(f"{key}.size", f"{size!r} is not a database size")
        given = {}
        for k in KEYS:
            if k in t:
                given[k] = _positive(t[k], f"{key}.{k}", w)
        if not given:
            raise w.error(key, f"no measurement; give some of {', '.join(KEYS)} (cm), or use "
                          "bodies.sizes")  # fmt: skip
        m = size_entry(size).measurements.replace(**given)
        try:
            validate(m)
        except SandboxError as exc:
            raise w.error(key, str(exc)) from None
        out.append(Body(label, size, tuple(sorted(m.to_dict().items())), "measured"))
    return out


def _garmentcode(value, w: _Where) -> list[Body]:
    """GarmentCode body files (relative to the spec), mapped as ``drape --garmentcode-body``
    maps them; labelled by the file's name."""
    from sandbox.pattern.garmentcode_body import load_garmentcode_body

    out = []
    for i, f in enumerate(_list(value, "bodies.garmentcode", w)):
        key = f"bodies.garmentcode[{i}]"
        if not isinstance(f, str):
            raise w.error(key, f"must be a body file's path, got {f!r}")
        path = Path(f) if Path(f).is_absolute() else Path(w.path).parent / f
        try:
            body = load_garmentcode_body(path)
        except SandboxError as exc:
            raise w.error(key, str(exc)) from None
        label = re.sub(r"[^A-Za-z0-9._-]", "_", path.stem)
        out.append(Body(label, body.size, tuple(sorted(body.measurements.items())),
                        "garmentcode"))  # fmt: skip
    return out


def _random(table, w: _Where) -> list[Body]:
    if not isinstance(table, dict):
        raise w.error("bodies.random", "must be a table: count, seed, spread")
    unknown = sorted(set(table) - set(RANDOM_KEYS))
    if unknown:
        raise w.error(f"bodies.random.{unknown[0]}", f"unknown key; known: "
                      f"{', '.join(RANDOM_KEYS)}")  # fmt: skip
    for k in ("count", "seed"):
        if k not in table:
            raise w.error(f"bodies.random.{k}", "missing")
    count = _whole(table["count"], "bodies.random.count", w, lowest=1)
    seed = _whole(table["seed"], "bodies.random.seed", w, lowest=0)
    spread = table.get("spread", DEFAULT_SPREAD)
    if (
        isinstance(spread, bool)
        or not isinstance(spread, int | float)
        or not (0 <= spread <= MAX_SPREAD)
    ):
        raise w.error("bodies.random.spread", f"must be a number in 0-{MAX_SPREAD:g}, got "
                      f"{spread!r}")  # fmt: skip
    try:
        drawn = random_bodies(count, seed, float(spread))
    except SandboxError as exc:
        raise w.error("bodies.random", str(exc)) from None
    return drawn


def random_bodies(count: int, seed: int, spread: float = DEFAULT_SPREAD) -> list[Body]:
    """``count`` bodies drawn from ``seed`` (the same every time), each within the supported
    range of every measurement and free of the mannequin's contradictions.

    A draw picks a point uniformly between the smallest and the largest database size,
    interpolates the seven measurements of the two sizes around it, multiplies each by a
    factor uniform in 1 ± ``spread`` and keeps the body if
    :func:`sandbox.mannequin.measurements.validate` accepts it (else draws again). Values
    are rounded to 0.1 cm. The body's ``size`` is the database size the draw is closest to.
    """
    import numpy as np

    from sandbox.mannequin.measurements import (
        KEYS,
        SUPPORTED_RANGE_CM,
        Measurements,
        load_size_table,
        validate,
    )

    table = load_size_table()
    base = np.array([[getattr(e.measurements, k) for k in KEYS] for e in table])
    lo = np.array([SUPPORTED_RANGE_CM[k][0] for k in KEYS])
    hi = np.array([SUPPORTED_RANGE_CM[k][1] for k in KEYS])
    rng = np.random.default_rng(seed)
    out = []
    for i in range(count):
        for _ in range(RANDOM_TRIES):
            t = rng.uniform(0.0, len(table) - 1.0)
            k = min(int(t), len(table) - 2)
            values = base[k] + (t - k) * (base[k + 1] - base[k])
            values = values * (1.0 + rng.uniform(-spread, spread, len(KEYS)))
            values = np.round(np.clip(values, lo, hi), 1)
            m = Measurements(**{key: float(v) for key, v in zip(KEYS, values, strict=True)})
            try:
                validate(m)
            except SandboxError:
                continue
            size = table[int(round(t))].size
            out.append(Body(f"rand{seed}-{i:03d}", size, tuple(sorted(m.to_dict().items())),
                            "random"))  # fmt: skip
            break
        else:
            raise SandboxError(f"no supported body in {RANDOM_TRIES} draws (spread {spread:g})")
    return out


# ----------------------------------------------------------------------------- tasks
def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("_") or "x"


def task_digest(garment: Garment, body: Body, fabric, edge_m: float, integrator: str,
                config: DrapeConfig, spec: BatchSpec) -> str:  # fmt: skip
    """Hash (12 hex digits) of everything that shapes a task's outputs: garment source,
    body, fabric, mesh edge, integrator, every drape setting (gates included: they are the
    drape's acceptance), precision and which files are written."""
    data = {
        "garment": garment.source_digest(),
        "body": [body.size, body.measurements_cm],
        "fabric": fabric,
        "edge_m": edge_m,
        "integrator": integrator,
        "config": config_dict(config),
        "gates": dataclasses.asdict(spec.gates),
        "float64": spec.float64,
        "files": [spec.render, spec.meshes, spec.body_mesh],
    }
    text = json.dumps(data, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def expand_tasks(spec: BatchSpec) -> list[Task]:
    """The batch's tasks in product order: garments, then bodies, fabrics, edges,
    integrators (the last varies fastest)."""
    tasks = []
    for garment in spec.garments:
        for body in spec.bodies:
            for fabric in spec.fabrics:
                for edge in spec.edges_m:
                    for integrator in spec.integrators:
                        config = dataclasses.replace(spec.config, integrator=integrator)
                        digest = task_digest(garment, body, fabric, edge, integrator, config,
                                             spec)  # fmt: skip
                        short = "ie" if integrator == "implicit_euler" else "se"
                        task_id = _slug(f"{garment.label}__{body.label}__{fabric or OWN_FABRIC}"
                                        f"__{edge * 100:g}cm__{short}__{digest}")  # fmt: skip
                        tasks.append(Task(task_id=task_id, index=len(tasks), garment=garment,
                                          body=body, fabric=fabric, edge_m=edge,
                                          integrator=integrator, config=config,
                                          gates=spec.gates, render=spec.render,
                                          meshes=spec.meshes, body_mesh=spec.body_mesh,
                                          float64=spec.float64,
                                          kill_after_s=spec.kill_after_s))  # fmt: skip
    return tasks
