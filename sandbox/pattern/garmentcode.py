"""Import GarmentCode pattern specifications (``*_specification.json``) as sandbox patterns.

GarmentCode (Korosteleva and Sorkine-Hornung, 2023; also the older Garment-Pattern-Generator
datasets) writes a pattern as ``{"pattern": {"panels": {...}, "stitches": [...]},
"properties": {"units_in_meter": 100, "curvature_coords": "relative", ...}}``. A panel has
2D ``vertices``, an edge loop of ``{"endpoints": [i, j], "curvature": ...}`` and a 3D
``translation`` and ``rotation`` (XYZ Euler angles in degrees, R = Rz Ry Rx, world =
R [x, y, 0] + t). Curvature comes in three forms, all converted exactly:

* ``[t, o]`` (legacy): quadratic Bézier control point in the edge frame, start + t (end -
  start) + o perp(end - start) with perp(x, y) = (-y, x) (absolute panel coordinates when
  ``properties.curvature_coords`` is ``"absolute"``);
* ``{"type": "quadratic", "params": [[t, o]]}`` and ``{"type": "cubic", "params": [[t1, o1],
  [t2, o2]]}``: the same relative control points;
* ``{"type": "circle", "params": [radius, large_arc, right]}``: an SVG-style arc; ``right``
  = 1 when the arc bulges to the right of start -> end. Becomes our arc with sagitta
  ``±(r ∓ sqrt(r² - c²/4))``.

A stitch ``[{"panel", "edge"}, {"panel", "edge"}]`` becomes a seam with direction
"reverse" (GarmentCode sews the end of one edge to the start of the other), or "same"
when the stitch carries the "right_wrong" flag (a panel all of whose stitches do, a lapel, is
cut to end turned over: ``meta.turns_over``). Panels whose edge loop runs clockwise in
their own 2D frame (GarmentCode's back panels) are mirrored (x -> -x, rotation R -> R
diag(-1, 1, -1)): same 3D shape, but counter-clockwise seen from the outside as our format
requires. Lengths are written in centimetres.

``python -m sandbox.pattern.garmentcode IN.json OUT.json`` converts a file.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from sandbox.errors import SandboxError
from sandbox.pattern.curves import sample_curve
from sandbox.pattern.garmentcode_place import (
    MEAN_ALL,
    GarmentCodeLevels,
    arm_angle_from_pose,
    body_placements,
    head_length_from,
)
from sandbox.pattern.mesh2d import polygon_area
from sandbox.pattern.spec import (
    DEFAULT_FABRIC,
    FORMAT,
    Pattern,
    load_pattern,
    rotation_matrix_xyz_deg,
    save_pattern,
)

MIRROR = np.diag([-1.0, 1.0, -1.0])
#: how imported panels are placed: on the body's landmarks, or where GarmentCode put them
PLACEMENTS = ("body", "explicit")


def load_garmentcode(
    path: str | Path,
    *,
    fabric: str | dict = DEFAULT_FABRIC,
    placement: str = "body",
    levels: GarmentCodeLevels = MEAN_ALL,
) -> Pattern:
    """Read a GarmentCode specification JSON as a :class:`~sandbox.pattern.spec.Pattern`
    (``placement``, ``levels``: as :func:`garmentcode_to_dict`)."""
    path = Path(path)
    data = garmentcode_to_dict(_read_json(path), where=str(path), name=_name_from_path(path),
                               fabric=fabric, placement=placement, levels=levels)  # fmt: skip
    return load_pattern(data, where=f"{path} (converted from GarmentCode)")


def _read_json(path: Path):
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise SandboxError(f"{path}: cannot read the file ({exc.strerror})") from None
    except json.JSONDecodeError as exc:
        raise SandboxError(
            f"{path}: not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})"
        ) from None
    except UnicodeDecodeError as exc:
        raise SandboxError(f"{path}: not a UTF-8 text file ({exc.reason})") from None
    except (ValueError, RecursionError) as exc:  # a 5000-digit number, deep nesting
        raise SandboxError(f"{path}: cannot read the JSON ({exc})") from None


def _name_from_path(path: Path) -> str:
    name = path.stem.removesuffix("_specification")
    if name in ("specification", "template", "prediction"):
        name = path.parent.name or name
    return name or "garmentcode"


def _num_list(v, n: int, at: str) -> np.ndarray:
    ok = isinstance(v, list) and len(v) == n
    ok = ok and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)
    if not ok or not all(math.isfinite(float(x)) if abs(x) < 1e300 else False for x in v):
        raise SandboxError(f"{at} must be a list of {n} finite numbers, got {v!r}")
    return np.asarray(v, float)


def _rel_to_abs(p0: np.ndarray, p1: np.ndarray, rel) -> np.ndarray:
    """GarmentCode's edge frame: start + t (end - start) + o perp(end - start)."""
    d = p1 - p0
    return p0 + rel[0] * d + rel[1] * np.array([-d[1], d[0]])


def _euler_xyz_deg(r: np.ndarray) -> list[float]:
    """XYZ Euler angles [deg] with R = Rz Ry Rx (inverse of rotation_matrix_xyz_deg)."""
    b = math.atan2(-r[2, 0], math.hypot(r[0, 0], r[1, 0]))
    if math.hypot(r[0, 0], r[1, 0]) < 1e-12:  # gimbal lock: put everything in x
        a, c = math.atan2(-r[1, 2], r[1, 1]), 0.0
    else:
        a, c = math.atan2(r[2, 1], r[2, 2]), math.atan2(r[1, 0], r[0, 0])
    return [math.degrees(x) for x in (a, b, c)]


def _curve(edge: dict, p0, p1, absolute: bool, to_cm: float, at: str) -> dict | None:
    """Our curve table [cm] for a GarmentCode edge's curvature, or None (straight).

    ``p0``, ``p1`` are in cm already; ``to_cm`` scales the file's absolute lengths (circle
    radius, absolute control points).
    """
    c = edge.get("curvature")
    if c is None:
        return None
    if isinstance(c, list):  # legacy: one quadratic control point
        q = _num_list(c, 2, f"{at}: 'curvature'")
        return {
            "type": "quadratic",
            "control": (q if absolute else _rel_to_abs(p0, p1, q)).tolist(),
        }
    if not isinstance(c, dict) or "type" not in c or "params" not in c:
        raise SandboxError(f"{at}: 'curvature' must be [t, o] or {{'type', 'params'}}, got {c!r}")
    kind, params = c["type"], c["params"]
    if kind in ("quadratic", "cubic"):
        n = 1 if kind == "quadratic" else 2
        if (
            kind == "quadratic"
            and isinstance(params, list)
            and len(params) == 2
            and all(isinstance(x, (int, float)) for x in params)
        ):
            params = [params]  # tolerate a flat [t, o]
        if not isinstance(params, list) or len(params) != n:
            raise SandboxError(f"{at}: {kind} 'params' must be {n} point(s) [t, o], got {params!r}")
        pts = [_rel_to_abs(p0, p1, _num_list(q, 2, f"{at}: {kind} control")) for q in params]
        if kind == "quadratic":
            return {"type": "quadratic", "control": pts[0].tolist()}
        return {"type": "cubic", "controls": [q.tolist() for q in pts]}
    if kind == "circle":
        if not isinstance(params, list) or len(params) != 3:
            raise SandboxError(
                f"{at}: circle 'params' must be [radius, large_arc, right], got {params!r}"
            )
        radius, large, right = (_num_list([x], 1, f"{at}: circle params")[0] for x in params)
        radius *= to_cm
        chord = float(np.linalg.norm(p1 - p0))
        if radius < 0.5 * chord * (1 - 1e-6):
            raise SandboxError(
                f"{at}: circle radius {radius:g} is shorter than half the chord ({chord / 2:g})"
            )
        h = math.sqrt(max(radius * radius - 0.25 * chord * chord, 0.0))
        s = radius + h if large else radius - h
        return {"type": "arc", "sagitta": -s if right else s}
    raise SandboxError(
        f"{at}: unknown curvature type {kind!r} (GarmentCode uses quadratic, cubic, circle)"
    )


def garmentcode_to_dict(
    spec: dict, *, where: str = "<garmentcode>", name: str = "garmentcode",
    fabric: str | dict = DEFAULT_FABRIC, placement: str = "body",
    levels: GarmentCodeLevels = MEAN_ALL,
) -> dict:  # fmt: skip
    """Convert a parsed GarmentCode specification to a ``sandbox-pattern/1`` dict (in cm).

    ``placement``: ``"body"`` (default) places each panel by the landmarks of the body part
    and side GarmentCode laid it out on, at the same body level
    (:mod:`sandbox.pattern.garmentcode_place`, with GarmentCode's body ``levels``); its own
    translation and rotation are kept in the panel's ``meta.garmentcode_placement``.
    ``"explicit"`` keeps GarmentCode's translation and rotation as the placement.
    """
    if placement not in PLACEMENTS:
        raise SandboxError(f"{where}: placement {placement!r}: use one of "
                           + ", ".join(PLACEMENTS))  # fmt: skip
    if not isinstance(spec, dict) or not isinstance(spec.get("pattern"), dict):
        raise SandboxError(f"{where}: not a GarmentCode specification (no 'pattern' object)")
    pat = spec["pattern"]
    props = spec.get("properties")
    props = {} if props is None else props
    if not isinstance(props, dict):
        raise SandboxError(f"{where}: 'properties' must be an object")
    units_in_meter = props.get("units_in_meter", 100)
    if (
        isinstance(units_in_meter, bool)
        or not isinstance(units_in_meter, (int, float))
        or not (units_in_meter > 0)
    ):
        raise SandboxError(
            f"{where}: properties.units_in_meter must be > 0, got {units_in_meter!r}"
        )
    to_cm = 100.0 / float(units_in_meter)
    absolute = props.get("curvature_coords", "relative") == "absolute"
    normalize_translation = bool(props.get("normalize_panel_translation", False))
    panels_t = pat.get("panels")
    if not isinstance(panels_t, dict) or not panels_t:
        raise SandboxError(f"{where}: pattern.panels must be a non-empty object")
    listed = pat.get("panel_order")
    listed = listed if isinstance(listed, list) else []
    order = [p for p in listed if isinstance(p, str) and p in panels_t]
    order += [p for p in panels_t if p not in order]
    panels, edge_names = {}, {}
    for pname in order:
        panels[pname], edge_names[pname] = _panel(
            pname, panels_t[pname], f"{where}: panel {pname!r}", to_cm, absolute,
            normalize_translation,
        )  # fmt: skip
    seams = []
    stitches = pat.get("stitches")
    stitches = [] if stitches is None else stitches
    if not isinstance(stitches, list):
        raise SandboxError(f"{where}: pattern.stitches must be a list")
    for i, st in enumerate(stitches):
        at = f"{where}: stitch #{i}"
        if not isinstance(st, list) or len(st) < 2 or not all(isinstance(x, dict) for x in st[:2]):
            raise SandboxError(f"{at}: a stitch is [{{panel, edge}}, {{panel, edge}}, ...]")
        sides = []
        for side in st[:2]:
            pn, k = side.get("panel"), side.get("edge")
            if not isinstance(pn, str) or pn not in panels:
                raise SandboxError(f"{at}: unknown panel {pn!r}")
            if isinstance(k, bool) or not isinstance(k, int) or not 0 <= k < len(edge_names[pn]):
                raise SandboxError(f"{at}: panel {pn!r} has no edge {k!r}")
            sides.append([{"panel": pn, "edge": edge_names[pn][k]}])
        flags = [x for x in st[2:] if isinstance(x, str)]
        direction = "same" if "right_wrong" in flags else "reverse"
        seams.append({"a": sides[0], "b": sides[1], "direction": direction})
    flagged: dict[str, list[bool]] = {}
    for seam in seams:
        for side in (seam["a"], seam["b"]):
            flagged.setdefault(side[0]["panel"], []).append(seam["direction"] == "same")
    for pname, flags in flagged.items():
        if all(flags):  # every stitch right side to wrong side: cut to turn over (a lapel)
            panels[pname]["meta"]["turns_over"] = True
    meta = {
        "imported_from": "GarmentCode",
        "units_in_meter": units_in_meter,
        "placement": placement,
        # the arms the design was drafted for, from the vertical: drape poses the mannequin
        "arm_angle_deg": arm_angle_from_pose(levels.arm_pose_deg),
        # the body it was drafted on has a head (a hood rests on it): drape gives it one
        "head_length_cm": head_length_from(levels.head_cm),
    }
    if placement == "body":
        kept = []
        for pname, landmark in body_placements(panels, levels).items():
            if landmark is None:
                kept.append(pname)
                continue
            panels[pname]["meta"]["garmentcode_placement"] = panels[pname]["placement"]
            panels[pname]["placement"] = landmark
        if kept:
            meta["garmentcode_placement_kept"] = kept
    if spec.get("parameters"):
        meta["garmentcode_parameters"] = spec["parameters"]
    return {
        "format": FORMAT,
        "name": name,
        "units": "cm",
        "fabric": fabric,
        "panels": panels,
        "seams": seams,
        "meta": meta,
    }


def _panel(pname, t, at, to_cm, absolute, normalize_translation):
    if not isinstance(t, dict):
        raise SandboxError(f"{at}: a panel must be a JSON object")
    verts_t = t.get("vertices")
    if not isinstance(verts_t, list) or len(verts_t) < 2:
        raise SandboxError(f"{at}: 'vertices' must be a list of [x, y] points")
    v = np.array([_num_list(q, 2, f"{at}: vertex {i}") for i, q in enumerate(verts_t)]) * to_cm
    trans = _num_list(t.get("translation", [0, 0, 0]), 3, f"{at}: 'translation'") * to_cm
    rot = rotation_matrix_xyz_deg(_num_list(t.get("rotation", [0, 0, 0]), 3, f"{at}: 'rotation'"))
    if normalize_translation:  # as GarmentCode: centre the panel, move the offset into t
        mean = v.mean(axis=0)
        v = v - mean
        trans = trans + np.array([mean[0], mean[1], 0.0])
    edges_t = t.get("edges")
    if not isinstance(edges_t, list) or len(edges_t) < 2:
        raise SandboxError(f"{at}: 'edges' must be a list of edges")
    edges, names, outline = [], [], []
    for k, e in enumerate(edges_t):
        ea = f"{at}: edge #{k}"
        ends = e.get("endpoints") if isinstance(e, dict) else None
        if not (isinstance(ends, list) and len(ends) == 2 and all(
            isinstance(x, int) and not isinstance(x, bool) and 0 <= x < len(v) for x in ends
        )):  # fmt: skip
            raise SandboxError(
                f"{ea}: 'endpoints' must be two vertex indices in 0..{len(v) - 1}, got {ends!r}"
            )
        p0, p1 = v[ends[0]], v[ends[1]]
        if np.linalg.norm(p1 - p0) < 1e-9:
            raise SandboxError(f"{ea}: zero-length edge (vertices {ends[0]} and {ends[1]})")
        curve = _curve(e, p0, p1, absolute, to_cm, ea)
        name = f"e{k}"
        d = {"name": name, "from": ends[0], "to": ends[1]}
        if curve is not None:
            d["curve"] = curve
        edges.append(d)
        names.append(name)
        outline.append(_sample(p0, p1, curve)[:-1])
    mirror = polygon_area(np.vstack(outline)) < 0
    if mirror:  # clockwise in its own frame: look at it from the other side
        v = v * np.array([-1.0, 1.0])
        rot = rot @ MIRROR
        for d in edges:
            c = d.get("curve")
            if c is None:
                continue
            if c["type"] == "arc":
                c["sagitta"] = -c["sagitta"]
            elif c["type"] == "quadratic":
                c["control"][0] = -c["control"][0]
            else:
                for q in c["controls"]:
                    q[0] = -q[0]
    meta = {"garmentcode_mirrored": bool(mirror)}
    labels = {f"e{k}": e["label"] for k, e in enumerate(edges_t) if e.get("label")}
    if labels:
        meta["garmentcode_edge_labels"] = labels
    if isinstance(t.get("label"), str):
        meta["garmentcode_label"] = t["label"]
    panel = {
        "vertices": [[_round(x) for x in q] for q in v],
        "edges": edges,
        "grain": [0, 1],
        "placement": {
            "translation": [_round(x) for x in trans],
            "rotation_deg": [_round(x) for x in _euler_xyz_deg(rot)],
        },
        "meta": meta,
    }
    return panel, names


def _round(x: float) -> float:
    """Round away float noise (1e-9) and negative zeros."""
    return round(float(x), 9) + 0.0


def _sample(p0, p1, curve) -> np.ndarray:
    """A coarse polyline of an edge (for the orientation test)."""
    if curve is None:
        return np.array([p0, p1])
    h = float(np.linalg.norm(p1 - p0)) / 16
    if curve["type"] == "arc":
        return sample_curve("arc", p0, p1, h, sagitta=curve["sagitta"])
    controls = [curve["control"]] if curve["type"] == "quadratic" else curve["controls"]
    return sample_curve(curve["type"], p0, p1, h, controls=controls)


def main(argv: list[str] | None = None) -> int:
    """``python -m sandbox.pattern.garmentcode IN.json OUT.json [--fabric NAME]``."""
    ap = argparse.ArgumentParser(
        prog="python -m sandbox.pattern.garmentcode",
        description="Convert a GarmentCode pattern specification JSON to a sandbox pattern.",
    )
    ap.add_argument("input", help="GarmentCode *_specification.json")
    ap.add_argument("output", help="sandbox pattern JSON to write")
    ap.add_argument("--fabric", default=DEFAULT_FABRIC, help="fabric preset (default: cotton)")
    ap.add_argument(
        "--placement",
        choices=PLACEMENTS,
        default="body",
        help="body (default): each panel on the landmarks of the body part and "
        "side GarmentCode laid it out on, wrapped round the mannequin like the "
        "library's; explicit: GarmentCode's own translation and rotation",
    )
    ap.add_argument("--body", type=Path, default=None, metavar="YAML",
                    help="the GarmentCode body file the design was drafted on, for its "
                    "levels (default: GarmentCode's mean_all)")  # fmt: skip
    args = ap.parse_args(argv)
    try:
        from sandbox.pattern.garmentcode_body import load_garmentcode_levels
        from sandbox.preflight import check_output_file

        check_output_file(args.output, "OUTPUT")
        levels = MEAN_ALL if args.body is None else load_garmentcode_levels(args.body)
        pattern = load_garmentcode(args.input, fabric=args.fabric, placement=args.placement,
                                   levels=levels)  # fmt: skip
        out = save_pattern(pattern, args.output)
    except SandboxError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    mirrored = [n for n, p in pattern.panels.items() if p.meta.get("garmentcode_mirrored")]
    print(
        f"wrote {out}: {len(pattern.panels)} panels, {len(pattern.seams)} seams, "
        f"units cm (from units_in_meter = {pattern.meta.get('units_in_meter')})"
        + (f"; mirrored (clockwise in GarmentCode): {', '.join(mirrored)}" if mirrored else "")
    )
    kept = pattern.meta.get("garmentcode_placement_kept")
    if args.placement == "body":
        print(
            "placed on the body's landmarks"
            + (f"; GarmentCode's placement kept for {', '.join(kept)} (legs)" if kept else "")
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
