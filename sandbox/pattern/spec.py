"""Pattern files (``"format": "sandbox-pattern/1"``): load, validate, save.

A pattern is JSON: panels (outline corners, a closed loop of named edges that may be
curved, a grain line, a placement) and seams (lists of panel edges sewn together). The
format is described in docs/pattern_format.md and by the JSON Schema
``sandbox/data/pattern.schema.json`` (draft 2020-12).

:func:`load_pattern` converts every length to metres, except in ``Panel.placement``, which
is kept exactly as in the file (file units) for round trips; ``Panel.placement_m`` is the
same placement with its lengths in metres (keys with an ``_m`` suffix). Every problem is a
:class:`~sandbox.errors.SandboxError` naming the file, the panel and the edge; the checks
are in :mod:`sandbox.pattern.reader`.
"""

from __future__ import annotations

import copy
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sandbox.atomic import write_text
from sandbox.errors import SandboxError
from sandbox.pattern import curves

FORMAT = "sandbox-pattern/1"
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


def load_pattern(source: str | Path | dict, *, where: str | None = None, limits=None) -> Pattern:
    """Load and validate a pattern from a JSON file (path) or an already parsed dict.

    ``where`` names the source in error messages (default: the path, or ``"<pattern>"``);
    ``limits`` a :class:`~sandbox.pattern.limits.PatternLimits` (default: the defaults).
    Raises SandboxError naming the file, the panel and the edge for any problem; logs a
    warning (logger ``sandbox.pattern``) for sizes and seams far from a garment's.
    """
    from sandbox.pattern.limits import DEFAULT_LIMITS
    from sandbox.pattern.reader import PatternReader  # it builds this module's classes

    limits = DEFAULT_LIMITS if limits is None else limits
    if isinstance(source, dict):
        data = source
        src = where or "<pattern>"
        default_name = "pattern"
    else:
        path = Path(source)
        src = where or str(path)
        default_name = path.stem.removesuffix(".pattern")
        try:
            size = path.stat().st_size
            if size > limits.max_file_bytes:
                raise SandboxError(
                    f"{src}: the file is {size:,} bytes, more than the limit of "
                    f"{limits.max_file_bytes:,} (PatternLimits.max_file_bytes)"
                )
            text = path.read_text(encoding="utf-8")
        except OSError as exc:
            raise SandboxError(f"{src}: cannot read the pattern file ({exc.strerror})") from None
        except UnicodeDecodeError as exc:
            raise SandboxError(f"{src}: not a UTF-8 text file ({exc.reason})") from None
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise SandboxError(
                f"{src}: not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})"
            ) from None
        except (ValueError, RecursionError) as exc:  # a 5000-digit number, deep nesting
            raise SandboxError(f"{src}: cannot read the JSON ({exc})") from None
    return PatternReader(src, limits).pattern(data, default_name)


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
