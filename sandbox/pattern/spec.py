"""Pattern files (``"format": "sandbox-pattern/1"``): load, validate, save.

A pattern is JSON: panels (outline corners, a closed loop of named edges that may be
curved, a grain line, a placement) and seams (lists of panel edges sewn together). The
format is described in docs/pattern_format.md and by the JSON Schema
``sandbox/data/pattern.schema.json`` (draft 2020-12).

:func:`load_pattern` converts every length to metres, except in ``Panel.placement``, which
is kept exactly as in the file (file units) for round trips; ``Panel.placement_m`` is the
same placement with its lengths in metres (keys with an ``_m`` suffix). Every problem is a
:class:`~sandbox.errors.SandboxError` naming the file, the panel and the edge.
"""

from __future__ import annotations

import copy
import json
import math
import re
from dataclasses import dataclass, field
from functools import cache
from importlib import resources
from pathlib import Path

import numpy as np

from sandbox.atomic import write_text
from sandbox.errors import SandboxError
from sandbox.pattern import curves
from sandbox.pattern.mesh2d import polygon_area

FORMAT = "sandbox-pattern/1"
SCHEMA_FILE = "pattern.schema.json"
UNITS_TO_M = {"cm": 0.01, "mm": 0.001, "m": 1.0}
DEFAULT_MESH_EDGE_M = 0.01
DEFAULT_FABRIC = "cotton"
DEFAULT_GRAIN = (0.0, 1.0)
DIRECTIONS = ("auto", "same", "reverse")
BODIES = ("torso", "arm_left", "arm_right", "leg_left", "leg_right")
SIDES = ("front", "back", "left", "right", "outer")
LANDMARKS = (
    "front_neck_point",
    "back_neck_point",
    "side_neck_point_left",
    "side_neck_point_right",
    "shoulder_point_left",
    "shoulder_point_right",
    "front_armhole_point_left",
    "front_armhole_point_right",
    "back_armhole_point_left",
    "back_armhole_point_right",
    "underarm_point_left",
    "underarm_point_right",
    "bust_point_left",
    "bust_point_right",
    "waist_front",
    "waist_back",
    "hip_front",
    "hip_back",
    "crotch_point",
)
FEATURE_LINES = ("neck_base", "bust_girth", "waist_girth", "hip_girth", "centre_front",
                 "centre_back")  # fmt: skip
FEATURE_LINE_PREFIXES = ("shoulder_line_", "armhole_", "princess_front_", "princess_back_",
                         "side_seam_")  # fmt: skip
CURVE_KEYS = {"line": (), "arc": ("sagitta",), "quadratic": ("control",), "cubic": ("controls",)}
TOP_KEYS = ("format", "name", "description", "units", "fabric", "mesh_edge", "panels", "seams",
            "meta")  # fmt: skip
PANEL_KEYS = ("vertices", "edges", "grain", "placement", "meta")
EDGE_KEYS = ("name", "from", "to", "curve")
SEAM_KEYS = ("name", "a", "b", "direction", "stiffness_N_m")
BODY_PLACEMENT_KEYS = ("body", "side", "anchor", "landmark", "offset", "wrap", "clearance")
EXPLICIT_PLACEMENT_KEYS = ("translation", "rotation_deg")
MIN_EDGE_M = 1e-6
_CHECK_SEGMENTS = 24  # polyline pieces per curved edge for the self-intersection test


@dataclass
class Edge:
    """One edge of a panel outline, from vertex ``start`` to vertex ``end``.

    ``kind`` is "line", "arc", "quadratic" or "cubic"; ``sagitta_m`` [m] is used by arcs
    (positive = the arc bulges to the left of start -> end), ``controls_m`` (c, 2) [m] are the
    Bézier control points in panel coordinates (c = 0, 1 or 2). ``p0_m``, ``p1_m`` (2,) [m]
    are copies of the end points (``Panel.sync_edges()`` refreshes them after an edit).
    """

    name: str
    start: int
    end: int
    kind: str
    p0_m: np.ndarray
    p1_m: np.ndarray
    sagitta_m: float = 0.0
    controls_m: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))

    @property
    def length_m(self) -> float:
        """Arc length [m]."""
        return curves.edge_length(self)

    def sample(self, max_segment_m: float) -> np.ndarray:
        """Polyline (k+1, 2) [m] from start to end, evenly spaced by arc length."""
        return curves.sample_edge(self, max_segment_m)


@dataclass
class Panel:
    """A flat pattern piece.

    ``vertices_m`` (k, 2) [m] counter-clockwise seen from the outside; ``grain`` (2,) unit
    warp direction; ``placement`` the raw placement table as in the file (file units, may be
    empty), ``units_to_m`` the file's scale; ``placement_m`` the placement in metres.
    """

    name: str
    vertices_m: np.ndarray
    edges: list[Edge]
    grain: np.ndarray
    placement: dict
    units_to_m: float = 0.01
    meta: dict = field(default_factory=dict)

    @property
    def grain_rad(self) -> float:
        """Angle of the warp from the panel's x axis [rad] (ModelBuilder.add_cloth grain_rad)."""
        return math.atan2(float(self.grain[1]), float(self.grain[0]))

    @property
    def placement_m(self) -> dict:
        """The placement with lengths in metres.

        Body form: ``body`` (default "torso"), ``side``, ``landmark``, ``anchor_m`` (2,),
        ``offset_m`` (3,) (default 0), ``clearance_m`` (default 0.02), ``wrap`` (default
        True, the placer's default). Explicit form:
        ``translation_m`` (3,), ``rotation_deg`` (3,) (default 0). Empty if no placement.
        """
        p, u = self.placement, self.units_to_m
        if not p:
            return {}
        if "translation" in p:
            return {
                "translation_m": np.asarray(p["translation"], float) * u,
                "rotation_deg": np.asarray(p.get("rotation_deg", (0.0, 0.0, 0.0)), float),
            }
        out = {
            "body": p.get("body", "torso"),
            "side": p["side"],
            "landmark": p["landmark"],
            "anchor_m": np.asarray(p["anchor"], float) * u,
            "offset_m": np.asarray(p.get("offset", (0.0, 0.0, 0.0)), float) * u,
            "clearance_m": float(p["clearance"]) * u if "clearance" in p else 0.02,
        }
        out["wrap"] = bool(p.get("wrap", True))
        return out

    def edge_index(self, ref, *, where: str = "") -> int:
        """Index of an edge given by name (str) or index (int)."""
        if isinstance(ref, bool) or not isinstance(ref, (int, str)):
            raise SandboxError(f"{where}edge must be a name or an index, got {ref!r}")
        if isinstance(ref, int):
            if not 0 <= ref < len(self.edges):
                raise SandboxError(
                    f"{where}panel {self.name!r} has no edge number {ref} "
                    f"(it has {len(self.edges)} edges, 0..{len(self.edges) - 1})"
                )
            return ref
        for k, e in enumerate(self.edges):
            if e.name == ref:
                return k
        raise SandboxError(
            f"{where}panel {self.name!r} has no edge named {ref!r}; "
            f"its edges: {', '.join(e.name for e in self.edges)}"
        )

    def sync_edges(self) -> None:
        """Copy ``vertices_m`` into the edges' end points (after editing the vertices)."""
        for e in self.edges:
            e.p0_m = self.vertices_m[e.start].copy()
            e.p1_m = self.vertices_m[e.end].copy()

    def outline(self, max_segment_m: float) -> np.ndarray:
        """Closed boundary polyline (n, 2) [m] (first point not repeated)."""
        return np.vstack([e.sample(max_segment_m)[:-1] for e in self.edges])


@dataclass
class SeamSpec:
    """A seam: two lists of ``(panel name, edge index)``, each sewn as one continuous line.

    ``direction`` is "auto" (paper Fig. 5a), "same" or "reverse"; ``stiffness_N_m`` None =
    the builder's default.
    """

    side_a: list[tuple[str, int]]
    side_b: list[tuple[str, int]]
    direction: str = "auto"
    stiffness_N_m: float | None = None
    name: str = ""


@dataclass
class Pattern:
    """A loaded, validated pattern; lengths in metres (see the module docstring)."""

    name: str
    units_to_m: float
    fabric: str | dict
    mesh_edge_m: float
    panels: dict[str, Panel]
    seams: list[SeamSpec]
    source: str = "<pattern>"
    units: str = "cm"
    description: str = ""
    meta: dict = field(default_factory=dict)

    def seam_lengths_m(self) -> list[tuple[float, float]]:
        """Arc lengths [m] of the two sides of every seam (a mismatch is ease or a mistake)."""
        return [
            tuple(sum(self.panels[p].edges[k].length_m for p, k in side) for side in
                  (s.side_a, s.side_b))
            for s in self.seams
        ]  # fmt: skip

    def to_dict(self) -> dict:
        """The pattern as a ``sandbox-pattern/1`` JSON document (in its own units)."""
        u = self.units_to_m

        def xy(p):
            return [_clean(float(v) / u) for v in p]

        out: dict = {"format": FORMAT, "name": self.name}
        if self.description:
            out["description"] = self.description
        out["units"] = self.units
        out["fabric"] = copy.deepcopy(self.fabric)
        out["mesh_edge"] = _clean(self.mesh_edge_m / u)
        panels = {}
        for pname, p in self.panels.items():
            edges = []
            for e in p.edges:
                d = {"name": e.name, "from": e.start, "to": e.end}
                if e.kind == "arc":
                    d["curve"] = {"type": "arc", "sagitta": _clean(e.sagitta_m / u)}
                elif e.kind == "quadratic":
                    d["curve"] = {"type": "quadratic", "control": xy(e.controls_m[0])}
                elif e.kind == "cubic":
                    d["curve"] = {"type": "cubic", "controls": [xy(c) for c in e.controls_m]}
                edges.append(d)
            pd = {
                "vertices": [xy(v) for v in p.vertices_m],
                "edges": edges,
                "grain": [_clean(float(g)) for g in p.grain],
            }
            if p.placement:
                pd["placement"] = copy.deepcopy(p.placement)
            if p.meta:
                pd["meta"] = copy.deepcopy(p.meta)
            panels[pname] = pd
        out["panels"] = panels
        seams = []
        for s in self.seams:
            d = {}
            if s.name:
                d["name"] = s.name
            for key, side in (("a", s.side_a), ("b", s.side_b)):
                d[key] = [{"panel": pn, "edge": self.panels[pn].edges[k].name} for pn, k in side]
            d["direction"] = s.direction
            if s.stiffness_N_m is not None:
                d["stiffness_N_m"] = s.stiffness_N_m
            seams.append(d)
        out["seams"] = seams
        if self.meta:
            out["meta"] = copy.deepcopy(self.meta)
        return out


def _clean(v: float) -> float | int:
    """Round away float noise from unit conversion (1e-9 file units)."""
    r = round(v, 9)
    return int(r) if r == int(r) and abs(r) < 1e15 else r


def rotation_matrix_xyz_deg(angles_deg) -> np.ndarray:
    """R = Rz Ry Rx (3, 3) for XYZ Euler angles [deg] (GarmentCode's and scene files' rule)."""
    rx, ry, rz = (math.radians(float(a)) for a in angles_deg)
    cx, sx, cy, sy, cz, sz = math.cos(rx), math.sin(rx), math.cos(ry), math.sin(ry), \
        math.cos(rz), math.sin(rz)  # fmt: skip
    r_x = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    r_y = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    r_z = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return r_z @ r_y @ r_x


# --------------------------------------------------------------------------------------
# Loading


def load_pattern(source: str | Path | dict, *, where: str | None = None) -> Pattern:
    """Load and validate a pattern from a JSON file (path) or an already parsed dict.

    ``where`` names the source in error messages (default: the path, or ``"<pattern>"``).
    Raises SandboxError naming the file, the panel and the edge for any problem.
    """
    if isinstance(source, dict):
        data = source
        src = where or "<pattern>"
        default_name = "pattern"
    else:
        path = Path(source)
        src = where or str(path)
        default_name = path.stem.removesuffix(".pattern")
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as exc:
            raise SandboxError(f"{src}: cannot read the pattern file ({exc.strerror})") from None
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise SandboxError(
                f"{src}: not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})"
            ) from None
    return _Reader(src).pattern(data, default_name)


def save_pattern(pattern: Pattern | dict, path: str | Path) -> Path:
    """Write a pattern (a :class:`Pattern` or a file dict) as JSON, atomically.

    The pattern is validated first (a dict is loaded with :func:`load_pattern`), so a
    written file always loads again. Returns the path.
    """
    path = Path(path)
    if isinstance(pattern, Pattern):
        data = pattern.to_dict()
    elif isinstance(pattern, dict):
        data = pattern
    else:
        raise SandboxError(f"{path}: save_pattern needs a Pattern or a dict, got {type(pattern)}")
    load_pattern(data, where=f"{path} (before saving)")
    return write_text(path, pattern_json(data))


_NUM = r"-?\d[\d.eE+-]*"
_NUMBER_LIST = re.compile(rf"\[\n\s*({_NUM}(?:,\n\s*{_NUM})*)\n\s*\]")


def pattern_json(data: dict) -> str:
    """JSON text of a pattern dict: indented, but points and vectors on one line.

    Only lists that json.dumps spread over several lines are joined; strings never hold a
    raw newline, so their content is untouched.
    """
    text = json.dumps(data, indent=2, ensure_ascii=False)
    join = lambda m: "[" + ", ".join(re.split(r",\n\s*", m.group(1))) + "]"  # noqa: E731
    return _NUMBER_LIST.sub(join, text) + "\n"


@cache
def pattern_schema() -> dict:
    """The JSON Schema of the format (draft 2020-12), from sandbox/data/pattern.schema.json."""
    ref = resources.files("sandbox") / "data" / SCHEMA_FILE
    return json.loads(ref.read_text(encoding="utf-8"))


def schema_errors(data) -> list[str]:
    """Messages (JSON path: problem) of every JSON Schema violation of ``data``."""
    import jsonschema

    validator = jsonschema.Draft202012Validator(pattern_schema())
    out = []
    for err in sorted(validator.iter_errors(data), key=lambda e: list(map(str, e.path))):
        path = "".join(f"[{p!r}]" if isinstance(p, str) else f"[{p}]" for p in err.path)
        out.append(f"{path or '(top level)'}: {err.message}")
    return out


def _is_num(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


class _Reader:
    """Validation with messages that name the file, the panel and the edge."""

    def __init__(self, src: str):
        self.src = src

    def fail(self, msg: str):
        raise SandboxError(f"{self.src}: {msg}")

    def keys(self, t, at: str, allowed, required=()):
        if not isinstance(t, dict):
            self.fail(f"{at} must be a JSON object, got {type(t).__name__}")
        unknown = [k for k in t if k not in allowed]
        if unknown:
            s = "s" if len(unknown) > 1 else ""
            self.fail(
                f"{at}: unknown key{s} {', '.join(repr(k) for k in unknown)}; "
                f"allowed: {', '.join(allowed)}"
            )
        for k in required:
            if k not in t:
                self.fail(f"{at}: {k!r} is missing")

    def point(self, v, at: str, n: int = 2) -> np.ndarray:
        if not (isinstance(v, list) and len(v) == n and all(_is_num(x) for x in v)):
            self.fail(f"{at} must be a list of {n} finite numbers, got {v!r}")
        return np.asarray(v, float)

    # ---------------------------------------------------------------------------------
    def pattern(self, data, default_name: str) -> Pattern:
        if not isinstance(data, dict):
            self.fail(f"a pattern file is a JSON object, got {type(data).__name__}")
        if "format" not in data and "pattern" in data:
            self.fail(
                "this looks like a GarmentCode specification, not a sandbox pattern; convert it "
                "with `python -m sandbox.pattern.garmentcode IN.json OUT.json` "
                "(or sandbox.pattern.garmentcode.load_garmentcode)"
            )
        self.keys(data, "top level", TOP_KEYS, required=("format", "panels"))
        if data["format"] != FORMAT:
            self.fail(f"'format' must be {FORMAT!r}, got {data['format']!r}")
        name = data.get("name", default_name)
        if not isinstance(name, str) or not name:
            self.fail(f"'name' must be a non-empty string, got {name!r}")
        description = data.get("description", "")
        if not isinstance(description, str):
            self.fail("'description' must be a string")
        units = data.get("units", "cm")
        if not isinstance(units, str) or units not in UNITS_TO_M:
            self.fail(f"unknown units {units!r}; use one of {', '.join(UNITS_TO_M)}")
        u = UNITS_TO_M[units]
        fabric = data.get("fabric", DEFAULT_FABRIC)
        from sandbox.sim.materials import material_from_spec

        material_from_spec(fabric, where=f"{self.src}: fabric")
        mesh_edge_m = DEFAULT_MESH_EDGE_M
        if "mesh_edge" in data:
            if not _is_num(data["mesh_edge"]) or data["mesh_edge"] <= 0:
                self.fail(f"'mesh_edge' must be a positive number, got {data['mesh_edge']!r}")
            mesh_edge_m = data["mesh_edge"] * u
        meta = data.get("meta", {})
        if not isinstance(meta, dict):
            self.fail("'meta' must be a JSON object")
        panels_t = data["panels"]
        if not isinstance(panels_t, dict) or not panels_t:
            self.fail("'panels' must be a non-empty object {name: panel}")
        panels = {pn: self.panel(pn, pt, u) for pn, pt in panels_t.items()}
        seams_t = data.get("seams", [])
        if not isinstance(seams_t, list):
            self.fail("'seams' must be a list")
        seams = [self.seam(i, s, panels) for i, s in enumerate(seams_t)]
        self.sewn_once(seams, panels)
        errors = schema_errors(data)
        if errors:  # our checks above catch the common mistakes; this is the backstop
            self.fail(f"does not match the pattern schema: {errors[0]}")
        return Pattern(
            name=name,
            units_to_m=u,
            fabric=copy.deepcopy(fabric),
            mesh_edge_m=float(mesh_edge_m),
            panels=panels,
            seams=seams,
            source=self.src,
            units=units,
            description=description,
            meta=copy.deepcopy(meta),
        )

    def panel(self, pname, t, u: float) -> Panel:
        at = f"panel {pname!r}"
        self.keys(t, at, PANEL_KEYS, required=("vertices", "edges"))
        verts = t["vertices"]
        if not isinstance(verts, list) or len(verts) < 2:
            self.fail(f"{at}: 'vertices' must be a list of at least 2 points [x, y]")
        vm = np.array([self.point(v, f"{at}: vertex {i}") for i, v in enumerate(verts)]) * u
        edges_t = t["edges"]
        if not isinstance(edges_t, list) or len(edges_t) < 2:
            self.fail(f"{at}: 'edges' must be a list of at least 2 edges")
        edges = [self.edge(at, k, e, vm, u) for k, e in enumerate(edges_t)]
        names = [e.name for e in edges]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            self.fail(f"{at}: edge name {dup[0]!r} is used by more than one edge")
        self.loop(at, edges, len(vm))
        grain = np.asarray(DEFAULT_GRAIN, float)
        if "grain" in t:
            grain = self.point(t["grain"], f"{at}: 'grain'")
            if np.linalg.norm(grain) < 1e-12:
                self.fail(f"{at}: 'grain' must be a non-zero direction [x, y]")
        grain = grain / np.linalg.norm(grain)
        placement = self.placement(at, t.get("placement", {}))
        meta = t.get("meta", {})
        if not isinstance(meta, dict):
            self.fail(f"{at}: 'meta' must be a JSON object")
        panel = Panel(pname, vm, edges, grain, copy.deepcopy(placement), u, copy.deepcopy(meta))
        self.geometry(at, panel)
        return panel

    def edge(self, at: str, k: int, t, vm: np.ndarray, u: float) -> Edge:
        name = t.get("name", f"edge{k}") if isinstance(t, dict) else None
        ea = f"{at}: edge {name!r} (#{k})" if isinstance(name, str) else f"{at}: edge #{k}"
        self.keys(t, ea, EDGE_KEYS, required=("from", "to"))
        if not isinstance(name, str) or not name:
            self.fail(f"{ea}: 'name' must be a non-empty string, got {name!r}")
        ends = []
        for key in ("from", "to"):
            v = t[key]
            if isinstance(v, bool) or not isinstance(v, int):
                self.fail(f"{ea}: {key!r} must be a vertex index (integer), got {v!r}")
            if not 0 <= v < len(vm):
                self.fail(
                    f"{ea}: {key!r} = {v} is out of range; the panel has {len(vm)} vertices "
                    f"(0..{len(vm) - 1})"
                )
            ends.append(v)
        a, b = ends
        p0, p1 = vm[a], vm[b]
        if a == b or np.linalg.norm(p1 - p0) < MIN_EDGE_M:
            self.fail(f"{ea}: zero-length edge (vertices {a} and {b} coincide)")
        kind, sag, ctrl = "line", 0.0, np.zeros((0, 2))
        if "curve" in t:
            c = t["curve"]
            if not isinstance(c, dict) or "type" not in c:
                self.fail(f"{ea}: 'curve' must be an object with a 'type'")
            kind = c["type"]
            if not isinstance(kind, str) or kind not in CURVE_KEYS:
                self.fail(f"{ea}: unknown curve type {kind!r}; use one of {', '.join(CURVE_KEYS)}")
            self.keys(c, f"{ea}: {kind} curve", ("type", *CURVE_KEYS[kind]), CURVE_KEYS[kind])
            if kind == "arc":
                if not _is_num(c["sagitta"]):
                    self.fail(f"{ea}: arc 'sagitta' must be a finite number, got {c['sagitta']!r}")
                sag = float(c["sagitta"]) * u
            elif kind == "quadratic":
                ctrl = self.point(c["control"], f"{ea}: quadratic 'control'")[None, :] * u
            elif kind == "cubic":
                cs = c["controls"]
                if not isinstance(cs, list) or len(cs) != 2:
                    self.fail(f"{ea}: cubic 'controls' must be two points [[x, y], [x, y]]")
                ctrl = np.array([self.point(q, f"{ea}: cubic control {i}") for i, q in
                                 enumerate(cs)]) * u  # fmt: skip
        return Edge(name, a, b, kind, p0.copy(), p1.copy(), sag, ctrl)

    def loop(self, at: str, edges: list[Edge], nv: int):
        for k, e in enumerate(edges):
            nxt = edges[(k + 1) % len(edges)]
            if e.end != nxt.start:
                what = "does not close the loop" if k == len(edges) - 1 else "is not consecutive"
                self.fail(
                    f"{at}: edge {e.name!r} (#{k}) ends at vertex {e.end} but the next edge "
                    f"{nxt.name!r} (#{(k + 1) % len(edges)}) starts at vertex {nxt.start}: the "
                    f"edge loop {what} (edge k+1 must start where edge k ends)"
                )
        starts = [e.start for e in edges]
        seen = {s for s in starts if starts.count(s) > 1}
        if seen:
            self.fail(f"{at}: the edge loop passes vertex {min(seen)} more than once")
        unused = sorted(set(range(nv)) - set(starts))
        if unused:
            self.fail(f"{at}: vertex {unused[0]} is not on the edge loop (every vertex must be)")

    def geometry(self, at: str, p: Panel):
        scale = float(np.ptp(p.vertices_m, axis=0).max())
        pts, owner = [], []
        for k, e in enumerate(p.edges):
            if e.kind == "arc" and abs(e.sagitta_m) > 1e3 * np.linalg.norm(e.p1_m - e.p0_m):
                self.fail(
                    f"{at}: edge {e.name!r} (#{k}): arc sagitta {e.sagitta_m / p.units_to_m:g} "
                    "is more than 1000 chords: not a usable arc"
                )
            n = 1 if e.kind == "line" or (e.kind == "arc" and e.sagitta_m == 0) else _CHECK_SEGMENTS
            length = e.length_m
            if not math.isfinite(length) or length < MIN_EDGE_M:
                self.fail(f"{at}: edge {e.name!r} (#{k}): zero-length edge")
            q = e.sample(length / n * (1 + 1e-9))
            pts.append(q[:-1])
            owner += [k] * (len(q) - 1)
            scale = max(scale, float(np.ptp(q, axis=0).max()))
        poly = np.vstack(pts)
        owner = np.asarray(owner)
        area = polygon_area(poly)
        if abs(area) < 1e-9 * scale * scale:
            self.fail(f"{at}: the outline has zero area")
        hit = _first_crossing(poly, scale)
        if hit is not None:
            i, j = hit
            ei, ej = p.edges[owner[i]], p.edges[owner[j]]
            if owner[i] == owner[j]:
                self.fail(f"{at}: edge {ei.name!r} (#{owner[i]}) crosses itself: self-intersecting "
                          "outline")  # fmt: skip
            self.fail(
                f"{at}: edge {ei.name!r} (#{owner[i]}) crosses edge {ej.name!r} (#{owner[j]}): "
                "self-intersecting outline"
            )
        if area < 0:
            self.fail(
                f"{at}: the outline runs clockwise; list the vertices and edges "
                "counter-clockwise as seen from the outside of the garment (right side of the "
                "fabric, y towards the head)"
            )

    def placement(self, at: str, t) -> dict:
        pa = f"{at}: placement"
        if not isinstance(t, dict):
            self.fail(f"{pa} must be a JSON object")
        if not t:
            return t
        if "translation" in t or "rotation_deg" in t:
            self.keys(t, f"{pa} (explicit form)", EXPLICIT_PLACEMENT_KEYS, ("translation",))
            self.point(t["translation"], f"{pa}: 'translation'", 3)
            if "rotation_deg" in t:
                self.point(t["rotation_deg"], f"{pa}: 'rotation_deg'", 3)
            return t
        self.keys(t, f"{pa} (body form)", BODY_PLACEMENT_KEYS, ("side", "anchor", "landmark"))
        if t.get("body", "torso") not in BODIES:
            self.fail(f"{pa}: unknown body {t['body']!r}; use one of {', '.join(BODIES)}")
        if t["side"] not in SIDES:
            self.fail(f"{pa}: unknown side {t['side']!r}; use one of {', '.join(SIDES)}")
        self.point(t["anchor"], f"{pa}: 'anchor'")
        lm = t["landmark"]
        if not isinstance(lm, str) or not (
            lm in LANDMARKS or lm in FEATURE_LINES or lm.startswith(FEATURE_LINE_PREFIXES)
        ):
            self.fail(
                f"{pa}: unknown landmark {lm!r}; known landmarks: {', '.join(LANDMARKS)} "
                f"(or a feature line: {', '.join(FEATURE_LINES)}, "
                f"{', '.join(p + '*' for p in FEATURE_LINE_PREFIXES)})"
            )
        if "offset" in t:
            self.point(t["offset"], f"{pa}: 'offset'", 3)
        if "wrap" in t and not isinstance(t["wrap"], bool):
            self.fail(f"{pa}: 'wrap' must be true or false, got {t['wrap']!r}")
        if "clearance" in t and (not _is_num(t["clearance"]) or t["clearance"] < 0):
            self.fail(f"{pa}: 'clearance' must be a number >= 0, got {t['clearance']!r}")
        return t

    def seam(self, i: int, t, panels: dict[str, Panel]) -> SeamSpec:
        name = t.get("name", "") if isinstance(t, dict) else ""
        sa = f"seam #{i}" + (f" ({name!r})" if name else "")
        self.keys(t, sa, SEAM_KEYS, required=("a", "b"))
        if not isinstance(name, str):
            self.fail(f"{sa}: 'name' must be a string")
        sides = []
        for key in ("a", "b"):
            side = t[key]
            if not isinstance(side, list) or not side:
                self.fail(f"{sa}: {key!r} must be a non-empty list of {{panel, edge}}")
            refs = []
            for j, r in enumerate(side):
                ra = f"{sa}: {key}[{j}]"
                self.keys(r, ra, ("panel", "edge"), ("panel", "edge"))
                pn = r["panel"]
                if not isinstance(pn, str) or pn not in panels:
                    self.fail(f"{ra}: unknown panel {pn!r}; panels: {', '.join(panels)}")
                refs.append((pn, panels[pn].edge_index(r["edge"], where=f"{self.src}: {ra}: ")))
            sides.append(refs)
        direction = t.get("direction", "auto")
        if direction not in DIRECTIONS:
            self.fail(f"{sa}: 'direction' must be auto, same or reverse, got {direction!r}")
        k = t.get("stiffness_N_m")
        if k is not None and (not _is_num(k) or k <= 0):
            self.fail(f"{sa}: 'stiffness_N_m' must be a positive number, got {k!r}")
        return SeamSpec(sides[0], sides[1], direction, None if k is None else float(k), name)

    def sewn_once(self, seams: list[SeamSpec], panels: dict[str, Panel]):
        used: dict[tuple[str, int], int] = {}
        for i, s in enumerate(seams):
            for ref in (*s.side_a, *s.side_b):
                if ref in used:
                    pn, k = ref
                    en = panels[pn].edges[k].name
                    other = "in the same seam" if used[ref] == i else f"in seam #{used[ref]}"
                    self.fail(
                        f"seam #{i}: panel {pn!r}: edge {en!r} (#{k}) is sewn twice "
                        f"(also {other}); an edge belongs to at most one seam"
                    )
                used[ref] = i


def _first_crossing(poly: np.ndarray, scale: float) -> tuple[int, int] | None:
    """First pair of segments (i < j) of a closed polyline that touch or cross, or None.

    Segment i runs from poly[i] to poly[i+1]. Neighbouring segments share an end point and
    only count when they fold back onto each other.
    """
    n = len(poly)
    a, b = poly, np.roll(poly, -1, axis=0)
    eps = 1e-10 * scale * scale

    def cross(o, p, q):
        return (p[..., 0] - o[..., 0]) * (q[..., 1] - o[..., 1]) - (p[..., 1] - o[..., 1]) * (
            q[..., 0] - o[..., 0]
        )

    i, j = np.triu_indices(n, k=1)
    adjacent = (j == i + 1) | ((i == 0) & (j == n - 1))
    # neighbours: fold-back (collinear, opposite directions)
    ia, ja = i[adjacent], j[adjacent]
    da, db = b[ia] - a[ia], b[ja] - a[ja]
    fold = (np.abs(da[:, 0] * db[:, 1] - da[:, 1] * db[:, 0]) <= eps) & (
        np.sum(da * db, axis=1) < 0
    )
    if np.any(fold):
        k = int(np.argmax(fold))
        return int(ia[k]), int(ja[k])
    i, j = i[~adjacent], j[~adjacent]
    p, q, r, s = a[i], b[i], a[j], b[j]
    d1, d2 = cross(r, s, p), cross(r, s, q)
    d3, d4 = cross(p, q, r), cross(p, q, s)
    proper = (d1 * d2 < 0) & (d3 * d4 < 0)

    def on_seg(o, e, x, d):  # x collinear with o-e and inside its box
        lo, hi = np.minimum(o, e) - 1e-12 * scale, np.maximum(o, e) + 1e-12 * scale
        inside = np.all((x >= lo) & (x <= hi), axis=1)
        return (np.abs(d) <= eps) & inside

    touch = on_seg(r, s, p, d1) | on_seg(r, s, q, d2) | on_seg(p, q, r, d3) | on_seg(p, q, s, d4)
    bad = proper | touch
    if np.any(bad):
        k = int(np.argmax(bad))
        return int(i[k]), int(j[k])
    return None
