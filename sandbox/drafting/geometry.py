"""2D outline helpers for drafting: edges, mirrored half outlines, panel dicts (cm).

A drafted edge is a small dict ``{"name", "p0", "p1", "curve"}`` with end points (2,) [cm]
and ``curve`` None (straight) or one of the pattern format's curves with absolute control
points: ``{"type": "arc", "sagitta": s}``, ``{"type": "quadratic", "control": c}``,
``{"type": "cubic", "controls": [c1, c2]}``. Panels are drafted as a right half (x >= 0) and
mirrored about the centre line x = 0, which is how a pattern drafter works (the half block)
and keeps every whole panel exactly symmetric.
"""

from __future__ import annotations

import math

import numpy as np

from sandbox.pattern import curves

SIDE = "{s}"  # placeholder in half-outline edge names, replaced by the side's name


def P(x: float, y: float) -> np.ndarray:
    """A point (2,) [cm]."""
    return np.array([float(x), float(y)])


def line(name: str, p0, p1) -> dict:
    return {"name": name, "p0": np.asarray(p0, float), "p1": np.asarray(p1, float), "curve": None}


def arc(name: str, p0, p1, sagitta: float) -> dict:
    """Circular arc; ``sagitta`` > 0 bulges to the left of p0 -> p1 (pattern format rule)."""
    e = line(name, p0, p1)
    if abs(sagitta) > 1e-9:
        e["curve"] = {"type": "arc", "sagitta": float(sagitta)}
    return e


def quad(name: str, p0, c, p1) -> dict:
    e = line(name, p0, p1)
    e["curve"] = {"type": "quadratic", "control": np.asarray(c, float)}
    return e


def cubic(name: str, p0, c1, c2, p1) -> dict:
    e = line(name, p0, p1)
    e["curve"] = {"type": "cubic", "controls": [np.asarray(c1, float), np.asarray(c2, float)]}
    return e


def _kind_args(e: dict) -> tuple[str, dict]:
    c = e["curve"]
    if c is None:
        return "line", {}
    if c["type"] == "arc":
        return "arc", {"sagitta": c["sagitta"]}
    if c["type"] == "quadratic":
        return "quadratic", {"controls": [c["control"]]}
    return "cubic", {"controls": c["controls"]}


def length(e: dict) -> float:
    """Arc length of a drafted edge [cm]."""
    kind, kw = _kind_args(e)
    return curves.curve_length(kind, e["p0"], e["p1"], **kw)


def sample(e: dict, step: float = 0.5) -> np.ndarray:
    """Polyline (k+1, 2) [cm] along the edge, segments at most ``step`` long."""
    kind, kw = _kind_args(e)
    return curves.sample_curve(kind, e["p0"], e["p1"], step, **kw)


def transform(e: dict, fn, *, reverse: bool = False, name: str | None = None) -> dict:
    """Edge mapped by a point map ``fn`` ((2,) -> (2,)), optionally reversed.

    ``fn`` must be a similarity; ``orientation`` of arcs: a reflection flips the sagitta's
    sign and so does a reversal.
    """
    p0, p1 = fn(e["p0"]), fn(e["p1"])
    c = e["curve"]
    # does fn reflect? (sign of the determinant of its linear part)
    o = fn(np.zeros(2))
    ex, ey = fn(np.array([1.0, 0.0])) - o, fn(np.array([0.0, 1.0])) - o
    det = ex[0] * ey[1] - ex[1] * ey[0]
    flips = (det < 0) != reverse
    out = {"name": e["name"] if name is None else name, "curve": None}
    if reverse:
        p0, p1 = p1, p0
    out["p0"], out["p1"] = p0, p1
    if c is not None:
        if c["type"] == "arc":
            out["curve"] = {"type": "arc", "sagitta": -c["sagitta"] if flips else c["sagitta"]}
        elif c["type"] == "quadratic":
            out["curve"] = {"type": "quadratic", "control": fn(c["control"])}
        else:
            cs = [fn(q) for q in c["controls"]]
            out["curve"] = {"type": "cubic", "controls": cs[::-1] if reverse else cs}
    return out


def mirror_x(p: np.ndarray) -> np.ndarray:
    return np.array([-p[0], p[1]])


def rigid(src0, src1, dst0, dst1):
    """The rotation + translation taking src0 -> dst0 and the direction src0->src1 onto
    dst0->dst1 (lengths must agree; only the direction of dst1 is used)."""
    src0, src1, dst0, dst1 = (np.asarray(v, float) for v in (src0, src1, dst0, dst1))
    a = math.atan2(*(dst1 - dst0)[::-1]) - math.atan2(*(src1 - src0)[::-1])
    r = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    return lambda p: r @ (np.asarray(p, float) - src0) + dst0


def split_quadratic(p0, c, p1, t: float) -> tuple[tuple, tuple]:
    """De Casteljau split of a quadratic Bézier at t: ((p0, c0, m), (m, c1, p1))."""
    p0, c, p1 = (np.asarray(v, float) for v in (p0, c, p1))
    c0 = p0 + t * (c - p0)
    c1 = c + t * (p1 - c)
    m = c0 + t * (c1 - c0)
    return (p0, c0, m), (m, c1, p1)


def symmetric_outline(
    half: list[dict],
    *,
    bottom: list[dict] | dict | None,
    top: list[dict] | dict | None,
    pos: str,
    neg: str,
) -> list[dict]:
    """A whole symmetric panel outline (counter-clockwise) from its right half.

    ``half`` runs up the x > 0 side from the bottom corner to the top corner. ``bottom``
    is either one whole edge from the mirrored bottom corner to the bottom corner (a dict),
    or a list of half edges from the centre line (x = 0) to the bottom corner; ``top``
    likewise one whole edge from the top corner to its mirror, or half edges from the top
    corner to the centre line; None if ``half`` already starts/ends on the centre line.
    ``{s}`` in edge names becomes ``pos`` on the x > 0 side and ``neg`` on the mirrored side.
    Straight horizontal half edges that meet their mirror on the centre line are merged
    into one edge (``_{s}`` dropped from the name).
    """

    def named(es, side):
        return [dict(e, name=e["name"].replace(SIDE, side)) for e in es]

    def mirrored(es):  # mirror and reverse a chain
        return [transform(e, mirror_x, reverse=True) for e in es[::-1]]

    out: list[dict] = []
    if isinstance(bottom, dict):
        out.append(bottom)
    elif bottom:
        out += named(mirrored(bottom), neg) + named(bottom, pos)
    out += named(half, pos)
    if isinstance(top, dict):
        out.append(top)
    elif top:
        out += named(top, pos) + named(mirrored(top), neg)
    out += named(mirrored(half), neg)
    return _merge_centre(out, pos, neg)


def _merge_centre(es: list[dict], pos: str, neg: str) -> list[dict]:
    n = len(es)
    for k in range(n):
        a, b = es[k], es[(k + 1) % n]
        if (
            a["curve"] is None
            and b["curve"] is None
            and abs(a["p1"][0]) < 1e-9
            and abs(a["p0"][1] - a["p1"][1]) < 1e-9
            and abs(b["p0"][1] - b["p1"][1]) < 1e-9
        ):
            name = a["name"]
            for s in (pos, neg):
                name = name.replace("_" + s, "")
            merged = line(name, a["p0"], b["p1"])
            if k + 1 < n:
                return _merge_centre(es[:k] + [merged] + es[k + 2 :], pos, neg)
            return _merge_centre([merged] + es[1:k], pos, neg)
    return es


def panel_dict(edges: list[dict], *, grain=(0.0, 1.0), placement=None, meta=None) -> dict:
    """A pattern-format panel from a closed chain of drafted edges (cm, rounded to 1e-4)."""
    verts: list[np.ndarray] = []
    out_edges = []
    n = len(edges)
    for k, e in enumerate(edges):
        nxt = edges[(k + 1) % n]
        if np.linalg.norm(e["p1"] - nxt["p0"]) > 1e-6:
            raise ValueError(f"edge {e['name']!r} does not end where {nxt['name']!r} starts")
        verts.append(e["p0"])
    for k, e in enumerate(edges):
        d = {"name": e["name"], "from": k, "to": (k + 1) % n}
        c = e["curve"]
        if c is not None:
            if c["type"] == "arc":
                d["curve"] = {"type": "arc", "sagitta": _r(c["sagitta"])}
            elif c["type"] == "quadratic":
                d["curve"] = {"type": "quadratic", "control": _xy(c["control"])}
            else:
                d["curve"] = {"type": "cubic", "controls": [_xy(q) for q in c["controls"]]}
        out_edges.append(d)
    panel = {"vertices": [_xy(v) for v in verts], "edges": out_edges, "grain": list(grain)}
    if placement:
        panel["placement"] = placement
    if meta:
        panel["meta"] = meta
    return panel


def _r(v: float) -> float:
    r = round(float(v), 4)
    return 0.0 if r == 0 else r


def _xy(p) -> list[float]:
    return [_r(p[0]), _r(p[1])]


def edges_of(panel: dict) -> dict[str, dict]:
    """Drafted-edge dicts (name -> edge) back from a pattern-format panel."""
    v = [np.asarray(p, float) for p in panel["vertices"]]
    out = {}
    for d in panel["edges"]:
        e = line(d["name"], v[d["from"]], v[d["to"]])
        if "curve" in d:
            c = d["curve"]
            if c["type"] == "arc":
                e["curve"] = {"type": "arc", "sagitta": c["sagitta"]}
            elif c["type"] == "quadratic":
                e["curve"] = {"type": "quadratic", "control": np.asarray(c["control"], float)}
            else:
                e["curve"] = {
                    "type": "cubic",
                    "controls": [np.asarray(q, float) for q in c["controls"]],
                }
        out[d["name"]] = e
    return out


def outline_polyline(panel: dict, step: float = 0.5) -> np.ndarray:
    """Closed outline (n, 2) [cm] of a pattern-format panel (first point not repeated)."""
    es = list(edges_of(panel).values())
    return np.vstack([sample(e, step)[:-1] for e in es])


def signed_area(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def width_at(poly: np.ndarray, y: float) -> float:
    """Total length [cm] of the horizontal line at height y inside a closed polygon."""
    a, b = poly, np.roll(poly, -1, axis=0)
    ya, yb = a[:, 1], b[:, 1]
    hit = (ya <= y) != (yb <= y)
    t = (y - ya[hit]) / (yb[hit] - ya[hit])
    xs = np.sort(a[hit, 0] + t * (b[hit, 0] - a[hit, 0]))
    return float(np.sum(xs[1::2] - xs[0::2]))


def is_simple(poly: np.ndarray) -> bool:
    """True if the closed polyline has no two non-adjacent segments touching or crossing."""
    n = len(poly)
    a, b = poly, np.roll(poly, -1, axis=0)
    i, j = np.triu_indices(n, k=2)
    keep = ~((i == 0) & (j == n - 1))
    i, j = i[keep], j[keep]
    p, q, r, s = a[i], b[i], a[j], b[j]

    def cross(o, u, v):
        return (u[:, 0] - o[:, 0]) * (v[:, 1] - o[:, 1]) - (u[:, 1] - o[:, 1]) * (v[:, 0] - o[:, 0])

    d1, d2, d3, d4 = cross(r, s, p), cross(r, s, q), cross(p, q, r), cross(p, q, s)
    return not bool(np.any((d1 * d2 < 0) & (d3 * d4 < 0)))
