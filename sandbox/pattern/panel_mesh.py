"""Mesh pattern panels and resolve seams to mesh vertices (paper §2.1 grids, §2.4 seams).

Each edge of a panel is sampled evenly by arc length (no segment longer than the target
edge length; graded towards much shorter neighbouring edges); the samples are the panel's
whole boundary. A constrained quality Delaunay
triangulation (Shewchuk's Triangle, switch ``Y``: no Steiner point on the boundary) fills
the inside, so the vertices of every edge are known exactly: ``edge_vertices[k]`` lists them
from the edge's start to its end, corners shared with the neighbouring edges.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass

import numpy as np

from sandbox.errors import SandboxError
from sandbox.pattern import curves
from sandbox.pattern.crossing import OutlineTooIntricate, first_crossing
from sandbox.pattern.limits import DEFAULT_LIMITS, PatternLimits
from sandbox.pattern.mesh2d import (
    DUPLICATE_TOLERANCE,
    check_mesh_size,
    estimate_vertex_count,
    min_angle_deg,
    morton_order,
    orient_ccw,
    polygon_area,
    triangulate,
)
from sandbox.pattern.reader import crossing_message
from sandbox.pattern.spec import Panel, Pattern, load_pattern

DEFAULT_EDGE_M = 0.01
GRADING = 0.2
GRADE_BELOW = 0.6
#: the two sides of a seam are sampled alike when their lengths differ by at most this
#: fraction (a longer side is gathered: its own even sampling is kept)
MATCH_LENGTHS = 0.1
"""Boundary segments grow by at most this fraction per segment away from a tiny edge."""
COLLAPSE_BELOW = 0.2
"""An outline edge shorter than this fraction of the mesh edge is not resolved by the mesh:
its two corners are one vertex, at its middle (:func:`collapsed_edges`)."""
MIN_ANGLE_DEG = 28.0
"""Requested minimum angle; Triangle reaches it except next to sharper outline corners."""


@dataclass
class PanelMesh:
    """A meshed panel, in panel coordinates.

    ``points`` (n, 2) [m]; ``triangles`` (m, 3) int64, counter-clockwise; ``edge_vertices``
    one int64 array per panel edge: vertex indices along the edge from its start to its end;
    ``boundary`` (b,) the boundary loop (counter-clockwise); ``grain_rad`` the warp angle
    from the panel x axis [rad] (``ModelBuilder.add_cloth(grain_rad=...)``).
    """

    name: str
    points: np.ndarray
    triangles: np.ndarray
    edge_vertices: list[np.ndarray]
    edge_names: list[str]
    boundary: np.ndarray
    grain_rad: float

    def edge(self, name: str) -> np.ndarray:
        """Vertex indices along the edge called ``name``."""
        return self.edge_vertices[self.edge_names.index(name)]


def mesh_panel(
    panel: Panel,
    edge_length_m: float = DEFAULT_EDGE_M,
    *,
    min_angle_deg: float = MIN_ANGLE_DEG,
    where: str | None = None,
    limits: PatternLimits = DEFAULT_LIMITS,
    samples: list[np.ndarray] | None = None,
) -> PanelMesh:
    """Irregular quality mesh of a panel with its edges resolved to vertices.

    Args:
        panel: a loaded panel (:func:`sandbox.pattern.spec.load_pattern`).
        edge_length_m: target edge length [m]; boundary segments are at most this long and
            triangles at most about the area of an equilateral triangle of this side.
        min_angle_deg: Triangle's minimum angle (quality) constraint.
        where: names the panel in error messages.
        limits: :class:`~sandbox.pattern.limits.PatternLimits`; a mesh estimated over
            ``max_mesh_vertices`` is refused before anything is sampled.
        samples: the boundary samples of each edge (:func:`_sample_edges`' form), when the
            pattern chose them (:func:`mesh_pattern` matches the two sides of a seam).

    The sampled boundary is checked before Triangle sees it (finite, no repeated point, no
    self-crossing); every failure is a SandboxError naming ``where`` and the edges.
    """
    where = where or f"panel {panel.name!r}"
    if not (edge_length_m > 0 and math.isfinite(edge_length_m)):
        raise SandboxError(f"{where}: edge length must be a positive number, got {edge_length_m}")
    vertices = panel_vertex_estimate(panel, edge_length_m, where)
    check_mesh_size(vertices, limits.max_mesh_vertices, where,
                    f"a {edge_length_m * 100:g} cm mesh of this panel")  # fmt: skip
    if samples is None:
        samples = _sample_edges(panel, edge_length_m)
    collapsed = collapsed_edges(panel, edge_length_m)
    samples = _merge_collapsed(samples, collapsed)
    # a collapsed edge adds no boundary point: its one vertex is the next edge's start
    counts = [0 if c else len(s) - 1 for s, c in zip(samples, collapsed, strict=True)]
    boundary = np.vstack([s[:n] for s, n in zip(samples, counts, strict=True)])
    nb = len(boundary)
    owner = np.repeat(np.arange(len(samples)), counts)
    _check_boundary(panel, boundary, owner, where)
    starts = np.cumsum([0] + counts)
    edge_vertices = []
    for k, s in enumerate(samples):
        idx = (starts[k] + np.arange(len(s))) % nb
        idx[-1] = starts[k + 1] % nb
        edge_vertices.append(idx.astype(np.int64))
    segments = np.stack([np.arange(nb), (np.arange(nb) + 1) % nb], axis=1)
    max_area = math.sqrt(3.0) / 4.0 * edge_length_m**2 * 1.4
    switches = f"pq{min_angle_deg:g}a{np.format_float_positional(max_area, trim='-')}YQ"
    out = triangulate({"vertices": boundary, "segments": segments}, switches, where)
    pts, tris = out["vertices"], out["triangles"]
    if len(pts) < nb or not np.array_equal(pts[:nb], boundary):
        raise SandboxError(f"{where}: the mesher moved the boundary points")
    seg_out = np.sort(np.asarray(out.get("segments", segments)), axis=1)
    if len(seg_out) != nb:  # 'Y' forbids splitting boundary segments: must hold
        raise SandboxError(f"{where}: the mesher split a boundary segment")
    used = np.zeros(len(pts), bool)
    used[tris.ravel()] = True
    if not used.all():  # points Triangle did not use (duplicates): drop them
        keep = np.nonzero(used)[0]
        if not used[:nb].all():
            raise SandboxError(f"{where}: a boundary point belongs to no triangle")
        remap = -np.ones(len(pts), np.int64)
        remap[keep] = np.arange(len(keep))
        pts, tris = pts[keep], remap[tris]
    tris = orient_ccw(pts, tris)
    order = morton_order(pts)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    tris = rank[tris]
    tris = tris[np.argsort(tris.min(axis=1), kind="stable")]
    return PanelMesh(
        name=panel.name,
        points=pts[order],
        triangles=tris,
        edge_vertices=[rank[ev] for ev in edge_vertices],
        edge_names=[e.name for e in panel.edges],
        boundary=rank[np.arange(nb)],
        grain_rad=panel.grain_rad,
    )


def panel_vertex_estimate(panel: Panel, edge_length_m: float, where: str) -> float:
    """About how many vertices a mesh of ``edge_length_m`` [m] of the panel has (from its
    area and outline length; inf when that overflows), before anything is sampled."""
    lengths = [e.length_m for e in panel.edges]
    if not all(math.isfinite(v) for v in lengths):
        raise SandboxError(f"{where}: an edge has no finite length")
    coarse = np.vstack([e.sample(max(v, 1e-300) / 24 * (1 + 1e-9))[:-1]
                        for e, v in zip(panel.edges, lengths, strict=True)])  # fmt: skip
    return estimate_vertex_count(polygon_area(coarse), sum(lengths), edge_length_m)


def _check_boundary(panel: Panel, boundary: np.ndarray, owner: np.ndarray, where: str):
    """What Triangle needs of the sampled boundary (n, 2) [m] (segment k on edge owner[k]):
    finite, no point repeated, no self-crossing; a SandboxError naming the edges otherwise."""
    if not np.all(np.isfinite(boundary)):
        raise SandboxError(f"{where}: the outline has a NaN or infinite coordinate")
    scale = float(np.ptp(boundary, axis=0).max())
    gap = np.linalg.norm(np.roll(boundary, -1, axis=0) - boundary, axis=1)
    short = gap <= DUPLICATE_TOLERANCE * scale
    if np.any(short):
        k = int(np.argmax(short))
        e = panel.edges[owner[k]]
        raise SandboxError(
            f"{where}: edge {e.name!r} (#{owner[k]}) has two boundary samples at the same point "
            f"({_cm(boundary[k])}); remove the repeated corner or the zero-length edge"
        )
    try:
        hit = first_crossing(boundary, scale)
    except OutlineTooIntricate as exc:
        raise SandboxError(f"{where}: {exc}") from None
    if hit is not None:
        raise SandboxError(f"{where}: {crossing_message(panel, boundary, owner, hit)}")


def _cm(xy) -> str:
    return f"{xy[0] * 100:.4g}, {xy[1] * 100:.4g} cm"


def collapsed_edges(panel: Panel, h: float) -> list[bool]:
    """For each edge of a panel: True where it is shorter than COLLAPSE_BELOW times the mesh
    edge ``h`` [m] (GarmentCode's outlines have edges of 1-2 mm where its stitches split an
    edge). Such an edge would take a fan of millimetre triangles to mesh at the minimum
    angle, each far lighter and stiffer than the rest (they set the explicit step); instead
    its two corners are one mesh vertex, at its middle (:func:`_merge_collapsed`): the
    outline moves by half the edge's length. A seam along it still sews that vertex. None
    of an outline's edges collapse if all of them would."""
    short = [e.length_m < COLLAPSE_BELOW * h for e in panel.edges]
    return [False] * len(short) if all(short) else short


def _merge_collapsed(samples: list[np.ndarray], collapsed: list[bool]) -> list[np.ndarray]:
    """The edge samples with each run of collapsed edges (:func:`collapsed_edges`) turned
    into one point, the middle between the run's two end corners: the run's edges become
    that point twice, and the edges before and after it end and start there. The middle,
    not an end, so that the two sides of a seam across such edges meet where they did."""
    out = [np.array(q, float, copy=True) for q in samples]
    n = len(out)
    if not any(collapsed):
        return out
    first = next(k for k in range(n) if not collapsed[k])  # runs start after a kept edge
    k = first
    for _ in range(n):
        k = (k + 1) % n
        if not collapsed[k] or collapsed[(k - 1) % n]:
            continue
        run = [k]
        while collapsed[(run[-1] + 1) % n]:
            run.append((run[-1] + 1) % n)
        mid = 0.5 * (out[run[0]][0] + out[run[-1]][-1])
        for j in run:
            out[j] = np.stack([mid, mid])
        out[(run[0] - 1) % n][-1] = mid
        out[(run[-1] + 1) % n][0] = mid
    return out


def _sample_edges(panel: Panel, h: float) -> list[np.ndarray]:
    """Boundary samples of every edge of one panel (:func:`_sample_panels`, no seams)."""
    return _sample_panels({panel.name: panel}, h, {})[panel.name]


def _sample_panels(panels: dict, h: float, partners: dict) -> dict[str, list[np.ndarray]]:
    """Boundary samples of every edge of every panel [m]: even by arc length (``Edge.sample``),
    except that an edge whose neighbour ends in a segment shorter than GRADE_BELOW times its
    own spacing is graded towards it (growth GRADING per segment), so tiny edges (GarmentCode
    has some under 1 mm) keep the mesh quality although no boundary segment may be split.

    ``partners``: (panel, edge) -> (panel, edge, reversed) for the two sides of a seam that
    are sampled alike (:func:`_seam_partners`): both at the same fractions of their lengths,
    spaced everywhere by the finer of their two gradings, so the seam's springs join
    coincident points.
    """
    out = {name: [e.sample(h) for e in p.edges] for name, p in panels.items()}
    collapsed = {name: collapsed_edges(p, h) for name, p in panels.items()}
    for _ in range(4):  # grading changes end segments, which may call for more grading
        size = {}  # (panel, edge) -> (even spacing, start target, end target) [m]
        for name, p in panels.items():
            q, n, gone = out[name], len(p.edges), collapsed[name]
            for k, e in enumerate(p.edges):
                even = e.length_m / max(1, math.ceil(e.length_m / h - 1e-9))
                before, after = (k - 1) % n, (k + 1) % n
                while gone[before] and before != k:  # graded towards a real neighbour only
                    before = (before - 1) % n
                while gone[after] and after != k:
                    after = (after + 1) % n
                start = float(np.linalg.norm(q[before][-1] - q[before][-2]))
                end = float(np.linalg.norm(q[after][1] - q[after][0]))
                size[name, k] = (even, start if start < GRADE_BELOW * even else np.inf,
                                 end if end < GRADE_BELOW * even else np.inf)  # fmt: skip
        changed = False
        for (name, k), (even, start, end) in size.items():
            e = panels[name].edges[k]
            if (name, k) in partners:
                other, j, rev = partners[name, k]
                if (other, j) < (name, k):
                    continue  # sampled with its partner
                e2 = panels[other].edges[j]
                f = _graded_fractions([(e.length_m, even, start, end, False),
                                       (e2.length_m, *size[other, j], rev)])  # fmt: skip
                f2 = 1.0 - f[::-1] if rev else f
                new = {(name, k): _points_at_fractions(e, f),
                       (other, j): _points_at_fractions(e2, f2)}  # fmt: skip
            elif np.isinf(start) and np.isinf(end):
                continue
            else:
                new = {(name, k): curves.sample_curve_graded(
                    e.kind, e.p0_m, e.p1_m, h, start, end, growth=GRADING,
                    sagitta=e.sagitta_m, controls=e.controls_m)}  # fmt: skip
            for (pn, pk), q in new.items():
                old = out[pn][pk]
                changed = changed or len(q) != len(old) or not np.allclose(q, old)
                out[pn][pk] = q
        if not changed:
            break
    return out


def _graded_fractions(sides) -> np.ndarray:
    """Fractions of [0, 1] for edges sampled alike: ``sides`` lists (length, even spacing,
    start target, end target, reversed) [m]; the spacing at u is the smallest over the
    sides of :func:`curves.sample_curve_graded`'s min(even, start + GRADING s, end + GRADING
    (L - s)), as a fraction of each side's length; points at equal steps of ∫ du / spacing."""
    u = np.linspace(0.0, 1.0, 4097)
    size = np.full_like(u, np.inf)
    for length, even, start, end, rev in sides:
        s = (1.0 - u if rev else u) * length  # arc length from the side's own start
        side = np.minimum(even, np.minimum(start + GRADING * s, end + GRADING * (length - s)))
        size = np.minimum(size, side / length)
    inv = 1.0 / size
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (inv[1:] + inv[:-1]) * np.diff(u))])
    n = max(1, math.ceil(cum[-1] - 1e-9))
    f = np.interp(np.linspace(0.0, cum[-1], n + 1), cum, u)
    f[0], f[-1] = 0.0, 1.0
    return f


def _points_at_fractions(edge, f: np.ndarray) -> np.ndarray:
    """Points (len(f), 2) [m] at fractions ``f`` of an edge's arc length, exact corners."""
    pts = curves.points_at_lengths(edge.kind, edge.p0_m, edge.p1_m, f * edge.length_m,
                                   sagitta=edge.sagitta_m, controls=edge.controls_m)  # fmt: skip
    pts[0], pts[-1] = edge.p0_m, edge.p1_m
    return pts


def mesh_pattern(
    pattern: Pattern, edge_length_m: float | None = None, *, limits: PatternLimits = DEFAULT_LIMITS
) -> dict[str, PanelMesh]:
    """:func:`mesh_panel` for every panel; the target edge defaults to the file's mesh_edge.

    The whole pattern's mesh is estimated first and refused (SandboxError) above
    ``limits.max_mesh_vertices``, before any panel is meshed.
    """
    h = pattern.mesh_edge_m if edge_length_m is None else edge_length_m
    if not (h > 0 and math.isfinite(h)):
        raise SandboxError(f"{pattern.source}: edge length must be a positive number, got {h}")
    total = sum(panel_vertex_estimate(p, h, f"{pattern.source}: panel {name!r}")
                for name, p in pattern.panels.items())  # fmt: skip
    check_mesh_size(total, limits.max_mesh_vertices, pattern.source,
                    f"a {h * 100:g} cm mesh of the {len(pattern.panels)} panels")  # fmt: skip
    samples = _sample_panels(pattern.panels, h, _seam_partners(pattern, h))
    return {
        name: mesh_panel(
            p, h, where=f"{pattern.source}: panel {name!r}", limits=limits, samples=samples[name]
        )  # fmt: skip
        for name, p in pattern.panels.items()
    }


def _seam_partners(pattern: Pattern, h: float) -> dict:
    """The seams whose two sides are sampled alike (:func:`_sample_panels`), as
    (panel, edge) -> (panel, edge, reversed) both ways.

    Each side is graded towards its own short neighbours, so a seam between two equal
    edges may be sampled differently on its two sides (GarmentCode's side seams next to its
    1-8 mm edges). Its springs then join a point to the two nearest on the other side, with
    rest lengths of up to half a segment: such a pair holds the point on the line's length
    but hardly across it, and a seam pressed between arm and body opens by millimetres.
    Sampled alike: a seam of one edge a side, sides within MATCH_LENGTHS of each other in
    length, direction given (``"same"`` or ``"reverse"``: an ``"auto"`` seam's pairing is
    known only once placed), and sampled differently on their own.
    """
    alone = _sample_panels(pattern.panels, h, {})
    out = {}
    for seam in pattern.seams:
        if len(seam.side_a) != 1 or len(seam.side_b) != 1 or seam.direction == "auto":
            continue
        (pa, ka), (pb, kb) = seam.side_a[0], seam.side_b[0]
        la = pattern.panels[pa].edges[ka].length_m
        lb = pattern.panels[pb].edges[kb].length_m
        if (pa, ka) == (pb, kb) or abs(la - lb) > MATCH_LENGTHS * max(la, lb):
            continue
        rev = seam.direction == "reverse"
        fa, fb = _fractions(alone[pa][ka]), _fractions(alone[pb][kb])
        if len(fa) == len(fb) and np.allclose(fa, 1.0 - fb[::-1] if rev else fb, atol=1e-6):
            continue
        out[pa, ka] = (pb, kb, rev)
        out[pb, kb] = (pa, ka, rev)
    return out


def _fractions(q: np.ndarray) -> np.ndarray:
    """Cumulative chord length of a polyline as fractions of its total, from 0 to 1."""
    c = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
    return c / c[-1]


def _chain(pattern: Pattern, side: list[tuple[str, int]]) -> list[bool]:
    """For each edge of a seam side: True to run it backwards (end -> start).

    Consecutive edges of the same panel that share a corner are chained through it (each
    one runs away from the previous one); other edges keep their from -> to direction.
    """
    flip = [False] * len(side)
    ends = [(pattern.panels[p].edges[k].start, pattern.panels[p].edges[k].end) for p, k in side]
    if len(side) >= 2 and side[0][0] == side[1][0]:
        s0, e0 = ends[0]
        if s0 in ends[1] and e0 not in ends[1]:
            flip[0] = True
    for j in range(1, len(side)):
        if side[j][0] != side[j - 1][0]:
            continue
        prev_end = ends[j - 1][0] if flip[j - 1] else ends[j - 1][1]
        s, e = ends[j]
        if e == prev_end and s != prev_end:
            flip[j] = True
    return flip


def pattern_seam_sides(
    pattern: Pattern, meshes: dict[str, PanelMesh], piece_index: dict[str, int]
) -> list[dict]:
    """Every seam of the pattern as keyword arguments of ``ModelBuilder.add_seam``.

    Args:
        pattern: the loaded pattern.
        meshes: panel name -> :class:`PanelMesh` (as from :func:`mesh_pattern`).
        piece_index: panel name -> the piece index ``ModelBuilder.add_cloth`` returned.

    Returns a list of dicts with ``side_a`` and ``side_b`` (lists of ``(piece index, local
    vertex indices along the edge in order)``), ``direction``, ``stiffness_N_m`` and
    ``where``, so ``builder.add_seam(**s)`` sews it. Several edges on one side form one
    line in the order given; consecutive edges of one panel that share a corner are chained
    through it.
    """
    out = []
    for i, s in enumerate(pattern.seams):
        where = f"{pattern.source}: seam #{i}" + (f" ({s.name!r})" if s.name else "")
        sides = []
        for side in (s.side_a, s.side_b):
            entries = []
            for (pname, k), back in zip(side, _chain(pattern, side), strict=True):
                if pname not in meshes or pname not in piece_index:
                    raise SandboxError(f"{where}: panel {pname!r} has no mesh or no piece index")
                idx = meshes[pname].edge_vertices[k]
                entries.append((int(piece_index[pname]), idx[::-1].copy() if back else idx))
            sides.append(entries)
        out.append(
            dict(
                side_a=sides[0],
                side_b=sides[1],
                direction=s.direction,
                stiffness_N_m=s.stiffness_N_m,
                where=where,
            )
        )
    return out


def main(argv: list[str] | None = None) -> int:
    """``python -m sandbox.pattern.panel_mesh PATTERN.json ... [--edge-cm H]``: check patterns.

    Loads (validates) each file, meshes every panel and prints vertex and triangle counts,
    the smallest angle, and each seam's two side lengths. Exit status 2 on the first error.
    """
    ap = argparse.ArgumentParser(
        prog="python -m sandbox.pattern.panel_mesh",
        description="Validate and mesh sandbox pattern files; print panels and seams.",
    )
    ap.add_argument("patterns", nargs="+", help="sandbox-pattern/1 JSON files")
    ap.add_argument("--edge-cm", type=float, default=None, help="target edge [cm] (file's)")
    args = ap.parse_args(argv)
    for path in args.patterns:
        try:
            pattern = load_pattern(path)
            h = None if args.edge_cm is None else args.edge_cm / 100.0
            meshes = mesh_pattern(pattern, h)
        except SandboxError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        h = pattern.mesh_edge_m if h is None else h
        print(f"{path}: {pattern.name!r}, fabric {pattern.fabric!r}, mesh edge {h * 100:g} cm")
        for name, m in meshes.items():
            print(
                f"  panel {name}: {len(m.points)} vertices, {len(m.triangles)} triangles, "
                f"min angle {min_angle_deg(m.points, m.triangles):.1f} deg, "
                f"grain {math.degrees(m.grain_rad):.0f} deg"
            )
        for i, (s, (la, lb)) in enumerate(zip(pattern.seams, pattern.seam_lengths_m(),
                                              strict=True)):  # fmt: skip
            sides = [" + ".join(f"{p}.{pattern.panels[p].edges[k].name}" for p, k in side)
                     for side in (s.side_a, s.side_b)]  # fmt: skip
            print(
                f"  seam {i}{' ' + s.name if s.name else ''}: {sides[0]} {la * 100:.1f} cm "
                f"<-> {sides[1]} {lb * 100:.1f} cm ({s.direction}, "
                f"difference {(lb - la) * 100:+.1f} cm)"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
