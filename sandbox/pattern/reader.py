"""Validation of pattern files (:mod:`sandbox.pattern.spec`): a parsed JSON dict checked
key by key and turned into a :class:`~sandbox.pattern.spec.Pattern`, every problem a
:class:`~sandbox.errors.SandboxError` naming the file, the panel and the edge; and the
format's JSON Schema (``sandbox/data/pattern.schema.json``, draft 2020-12)."""

from __future__ import annotations

import copy
import json
import logging
import math
from collections import Counter
from functools import cache
from importlib import resources

import numpy as np

from sandbox.errors import SandboxError
from sandbox.pattern.crossing import (
    OutlineTooIntricate,
    crossing_point,
    first_crossing,
    on_one_line,
)
from sandbox.pattern.limits import DEFAULT_LIMITS, PatternLimits
from sandbox.pattern.mesh2d import polygon_area
from sandbox.pattern.spec import (
    BODIES,
    BODY_PLACEMENT_KEYS,
    CURVE_KEYS,
    DEFAULT_FABRIC,
    DEFAULT_GRAIN,
    DEFAULT_MESH_EDGE_M,
    DIRECTIONS,
    EDGE_KEYS,
    EXPLICIT_PLACEMENT_KEYS,
    FEATURE_LINE_PREFIXES,
    FEATURE_LINES,
    FORMAT,
    LANDMARKS,
    PANEL_KEYS,
    SEAM_KEYS,
    SIDES,
    TOP_KEYS,
    UNITS_TO_M,
    Edge,
    Panel,
    Pattern,
    SeamSpec,
)

log = logging.getLogger("sandbox.pattern")

SCHEMA_FILE = "pattern.schema.json"
MIN_EDGE_M = 1e-6
_CHECK_SEGMENTS = 24  # polyline pieces per curved edge for the self-intersection test


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
    if not isinstance(v, (int, float)) or isinstance(v, bool):
        return False
    try:
        return math.isfinite(v)
    except OverflowError:  # an integer too large for a float
        return False


class PatternReader:
    """Validation with messages that name the file, the panel and the edge."""

    def __init__(self, src: str, limits: PatternLimits = DEFAULT_LIMITS):
        self.src = src
        self.limits = limits
        self.extent_m: dict[str, float] = {}  # panel name -> largest side of its box

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
        self.plausible_sizes(units)
        self.plausible_seams(seams, panels)
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
        most = self.limits.max_panel_vertices
        if len(verts) > most:
            self.fail(f"{at}: {len(verts):,} vertices, more than the limit of {most:,} "
                      "(PatternLimits.max_panel_vertices)")  # fmt: skip
        vm = np.array([self.point(v, f"{at}: vertex {i}") for i, v in enumerate(verts)]) * u
        self.coordinates(at, "vertex", vm, u)
        edges_t = t["edges"]
        if not isinstance(edges_t, list) or len(edges_t) < 2:
            self.fail(f"{at}: 'edges' must be a list of at least 2 edges")
        if len(edges_t) > most:
            self.fail(f"{at}: {len(edges_t):,} edges, more than the limit of {most:,} "
                      "(PatternLimits.max_panel_vertices)")  # fmt: skip
        edges = [self.edge(at, k, e, vm, u) for k, e in enumerate(edges_t)]
        dup = sorted(n for n, c in Counter(e.name for e in edges).items() if c > 1)
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
            self.coordinates(ea, f"{kind} control point", ctrl, u)
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
        seen = {s for s, c in Counter(starts).items() if c > 1}
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
        if on_one_line(poly, scale):
            self.fail(f"{at}: the outline has zero area (its corners are on one line)")
        try:
            hit = first_crossing(poly, scale)
        except OutlineTooIntricate as exc:
            self.fail(f"{at}: {exc}")
        if hit is not None:
            self.fail(f"{at}: {crossing_message(p, poly, owner, hit)}")
        if abs(area) < 1e-9 * scale * scale:
            self.fail(f"{at}: the outline has zero area")
        self.extent_m[p.name] = scale
        if area < 0:
            self.fail(
                f"{at}: the outline runs clockwise; list the vertices and edges "
                "counter-clockwise as seen from the outside of the garment (right side of the "
                "fabric, y towards the head)"
            )

    def coordinates(self, at: str, what: str, xy_m: np.ndarray, u: float):
        far = np.abs(xy_m).max(axis=1) > self.limits.max_coordinate_m if len(xy_m) else []
        if np.any(far):
            i = int(np.argmax(far))
            self.fail(
                f"{at}: {what} {i} {[float(f'{v:.6g}') for v in xy_m[i] / u]} lies more than "
                f"{self.limits.max_coordinate_m:g} m from the origin "
                "(PatternLimits.max_coordinate_m): draw panels around their own origin"
            )

    def plausible_sizes(self, units: str):
        """Refuse panels no garment has (they would exhaust memory when meshed); warn about
        a pattern too small for a body. Both are most often a wrong ``units``."""
        lim = self.limits
        for name, ext in self.extent_m.items():
            if ext > lim.max_panel_extent_m:
                self.fail(
                    f"panel {name!r} is {_length(ext)} across, larger than the "
                    f"{_length(lim.max_panel_extent_m)} any garment panel needs "
                    f"(PatternLimits.max_panel_extent_m){_units_hint(ext, units)}"
                )
        if not self.extent_m:
            return
        name, ext = max(self.extent_m.items(), key=lambda kv: kv[1])
        if ext < lim.min_pattern_extent_m:
            log.warning(
                "%s: the largest panel, %r, is only %s across: small for a garment%s",
                self.src, name, _length(ext), _units_hint(ext, units),
            )  # fmt: skip
            return
        for name, ext in self.extent_m.items():
            if ext < lim.min_panel_extent_m:
                log.warning("%s: panel %r is only %s across (units %r)", self.src, name,
                            _length(ext), units)  # fmt: skip

    def plausible_seams(self, seams: list[SeamSpec], panels: dict[str, Panel]):
        """Warn about seams whose sides differ by much more than ease or gathers do."""
        lim = self.limits
        for i, s in enumerate(seams):
            la, lb = (sum(panels[pn].edges[k].length_m for pn, k in side)
                      for side in (s.side_a, s.side_b))  # fmt: skip
            diff = abs(la - lb)
            if diff > lim.seam_mismatch_m and diff > lim.seam_mismatch_ratio * max(la, lb):
                names = [" + ".join(f"{pn}.{panels[pn].edges[k].name}" for pn, k in side)
                         for side in (s.side_a, s.side_b)]  # fmt: skip
                log.warning(
                    "%s: seam #%d%s: side a (%s) is %s long, side b (%s) %s: they differ by "
                    "%s (more than %s and %.0f %%; ease is usually a few cm): check the "
                    "seam's edges and the units",
                    self.src, i, f" ({s.name!r})" if s.name else "", names[0], _length(la),
                    names[1], _length(lb), _length(diff), _length(lim.seam_mismatch_m),
                    100 * lim.seam_mismatch_ratio,
                )  # fmt: skip

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


def crossing_message(p: Panel, poly: np.ndarray, owner: np.ndarray, hit) -> str:
    """The message "edge 'a' (#0) crosses edge 'b' (#2) at (x, y) cm: self-intersecting
    outline" for segments ``hit`` of the polyline ``poly`` [m] (segment k on edge owner[k])."""
    i, j = hit
    x, y = np.round(crossing_point(poly, i, j) / p.units_to_m, 6) + 0.0
    unit = next((k for k, v in UNITS_TO_M.items() if v == p.units_to_m), "file units")
    ki, kj = int(owner[i]), int(owner[j])
    ei, ej = p.edges[ki], p.edges[kj]
    what = "crosses itself" if ki == kj else f"crosses edge {ej.name!r} (#{kj})"
    return f"edge {ei.name!r} (#{ki}) {what} at ({x:.4g}, {y:.4g}) {unit}: self-intersecting " \
        "outline"  # fmt: skip


def _length(m: float) -> str:
    """A length [m] in the unit that reads best: '60 m', '6 cm', '3.5 mm'."""
    if m >= 1.0:
        return f"{m:.3g} m"
    if m >= 0.01:
        return f"{m * 100:.3g} cm"
    return f"{m * 1000:.3g} mm"


def _units_hint(extent_m: float, units: str) -> str:
    """'; the file says "units": "m": are its numbers in cm?' when another unit gives the
    panel a garment's size (15 cm to 2.5 m), else ''."""
    scale = UNITS_TO_M[units]
    for alt, alt_scale in UNITS_TO_M.items():
        if alt != units and 0.15 <= extent_m / scale * alt_scale <= 2.5:
            return (f'; the file says "units": "{units}": are its numbers in {alt} '
                    f'("units": "{alt}")?')  # fmt: skip
    return f' (the file says "units": "{units}")'
