"""Validation of pattern files (:mod:`sandbox.pattern.spec`): a parsed JSON dict checked
key by key and turned into a :class:`~sandbox.pattern.spec.Pattern`, every problem a
:class:`~sandbox.errors.SandboxError` naming the file, the panel and the edge; and the
format's JSON Schema (``sandbox/data/pattern.schema.json``, draft 2020-12)."""

from __future__ import annotations

import copy
import json
import math
from functools import cache
from importlib import resources

import numpy as np

from sandbox.errors import SandboxError
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
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


class PatternReader:
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
