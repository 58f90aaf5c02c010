"""Panels placed around the mannequin: one panel (:func:`place_panel`) or a whole pattern
(:func:`place_pattern`); the placement forms are described in :mod:`sandbox.pattern.placement`.
"""

from __future__ import annotations

import math

import numpy as np

from sandbox.errors import SandboxError
from sandbox.pattern.placement.body import PlacementBody
from sandbox.pattern.placement.config import DEFAULT_PLACEMENT, PlacementConfig
from sandbox.pattern.placement.repair import (
    crossings,
    lift_over_torso,
    panel_clearance_m,
    relax_panel,
    untangle,
)
from sandbox.pattern.placement.wrap import flat_panel, wrap_panel
from sandbox.pattern.spec import BODIES, rotation_matrix_xyz_deg


def prepare_body(mannequin, config: PlacementConfig | None = None):
    """(:class:`PlacementBody`, settings) for placing panels on ``mannequin``.

    A mannequin is prepared with ``config`` (default: :data:`DEFAULT_PLACEMENT`). A prepared
    body is used as it is, with its own settings unless ``config`` is given; its section
    hulls and push-out follow its own ``offset_directions`` and ``push_iterations``, so a
    ``config`` that differs in those is an error.
    """
    if not isinstance(mannequin, PlacementBody):
        body = PlacementBody(mannequin, DEFAULT_PLACEMENT if config is None else config)
        return body, body.config
    if config is None:
        return mannequin, mannequin.config
    own = mannequin.config
    if (config.offset_directions, config.push_iterations) != (
        own.offset_directions,
        own.push_iterations,
    ):
        raise SandboxError(
            "placement: the PlacementBody was prepared with other offset_directions or "
            "push_iterations than the config given; prepare it with that config"
        )
    return mannequin, config


def place_panel(
    points_m,
    placement: dict,
    mannequin,
    units_to_m: float = 0.01,
    *,
    sector_rad: tuple[float, float] | None = None,
    axis_height_m: float | None = None,
    where: str = "",
    config: PlacementConfig | None = None,
) -> np.ndarray:
    """World positions (n, 3) [m] of a panel's mesh points.

    Args:
        points_m: (n, 2) panel coordinates [m].
        placement: the panel's placement table as in the pattern file (file units).
        mannequin: a :class:`~sandbox.mannequin.Mannequin` or a :class:`PlacementBody`.
        units_to_m: the pattern file's length unit [m].
        sector_rad: (before, after) angles [rad] the panel may use on each side of its
            ``side`` angle (default: the whole turn less ``config.side_gap_rad``).
        axis_height_m: for the torso, the height [m] whose section centre fixes the axis
            (default: the landmark's height); panels of one garment share it.
        config: the placement settings (default: the body's, see :func:`prepare_body`).
    """
    pts = np.asarray(points_m, float)
    if pts.ndim != 2 or pts.shape[1] != 2 or not np.all(np.isfinite(pts)):
        raise SandboxError(f"{where}panel points must be finite with shape (n, 2)")
    if not placement:
        raise SandboxError(f"{where}the panel has no placement")
    u = float(units_to_m)
    if "translation" in placement:
        rot = rotation_matrix_xyz_deg(placement.get("rotation_deg", (0.0, 0.0, 0.0)))
        p3 = np.column_stack([pts, np.zeros(len(pts))])
        return p3 @ rot.T + np.asarray(placement["translation"], float) * u
    body, cfg = prepare_body(mannequin, config)
    part = placement.get("body", "torso")
    if part not in BODIES:
        raise SandboxError(f"{where}placement: unknown body {part!r}; use one of "
                           f"{', '.join(BODIES)}")  # fmt: skip
    landmark = body.point(placement["landmark"], where=where)
    anchor = np.asarray(placement["anchor"], float) * u
    offset = np.asarray(placement.get("offset", (0.0, 0.0, 0.0)), float) * u
    clearance = float(placement.get("clearance", cfg.clearance_m / u)) * u
    frame = body.frame(part, landmark[1] if axis_height_m is None else axis_height_m)
    theta = body.side_angle(frame, placement["side"])
    s = pts[:, 0] - anchor[0]
    h = float(frame.height(landmark)) + pts[:, 1] - anchor[1]
    if placement.get("wrap", True):
        half = math.pi - cfg.side_gap_rad / 2
        before, after = sector_rad if sector_rad is not None else (half, half)
        x = wrap_panel(body, frame, theta, s, h, clearance, before, after)
    else:
        x = flat_panel(body, frame, theta, s, h, clearance)
    x = x + offset
    x, _ = body.push_out(x, clearance)
    return x


def place_pattern(pattern, meshes: dict, mannequin,
                  config: PlacementConfig | None = None) -> dict[str, np.ndarray]:  # fmt: skip
    """World positions (n, 3) [m] of every meshed panel of a pattern.

    Panels on the same body part share one axis (the torso's at the mean anchor height) and
    split the turn into sectors between their sides, so they do not overlap at the start.
    Each wrapped panel is then relaxed, sleeves are lifted over the bodice and crossings are
    untangled (:mod:`sandbox.pattern.placement.repair`).

    Args:
        pattern: a :class:`~sandbox.pattern.spec.Pattern`.
        meshes: panel name -> :class:`~sandbox.pattern.panel_mesh.PanelMesh`.
        mannequin: a :class:`~sandbox.mannequin.Mannequin` or a :class:`PlacementBody`.
        config: the placement settings (default: the body's, see :func:`prepare_body`).
    """
    body, cfg = prepare_body(mannequin, config)
    where = f"{pattern.source}: "
    by_part: dict[str, list[str]] = {}
    for name, panel in pattern.panels.items():
        p = panel.placement
        if not p:
            raise SandboxError(f"{where}panel {name!r} has no placement")
        if "translation" not in p:
            by_part.setdefault(p.get("body", "torso"), []).append(name)
    heights = {
        part: float(
            np.mean([body.point(pattern.panels[n].placement["landmark"])[1] for n in names])
        )  # fmt: skip
        for part, names in by_part.items()
    }
    angles, spans = {}, {}
    for part, names in by_part.items():
        frame = body.frame(part, heights[part])
        for n in names:
            p = pattern.panels[n].placement
            angles[n] = body.side_angle(frame, p["side"])
            y = (body.point(p["landmark"])[1] + meshes[n].points[:, 1]
                 - float(p["anchor"][1]) * pattern.panels[n].units_to_m)  # fmt: skip
            spans[n] = (float(y.min()), float(y.max()))
    out = {}
    for name, panel in pattern.panels.items():
        p = panel.placement
        pts = meshes[name].points
        at = f"{where}panel {name!r}: "
        if "translation" in p:
            out[name] = place_panel(pts, p, body, panel.units_to_m, where=at, config=cfg)
            continue
        part = p.get("body", "torso")
        mine = angles[name]
        others = [angles[o] for o in by_part[part]
                  if abs(_wrap_pi(angles[o] - mine)) > 1e-3
                  and _side_by_side(spans[name], spans[o], cfg)]  # fmt: skip
        if others:
            after = min(np.mod(o - angles[name], 2 * np.pi) for o in others) / 2
            before = min(np.mod(angles[name] - o, 2 * np.pi) for o in others) / 2
            sector = (before - cfg.side_gap_rad / 2, after - cfg.side_gap_rad / 2)
        else:
            sector = None
        out[name] = place_panel(pts, p, body, panel.units_to_m, sector_rad=sector,
                                axis_height_m=heights[part], where=at, config=cfg)  # fmt: skip
    relaxed = {}
    for names in by_part.values():  # unstrain each wrapped panel, keep the clearance
        for name in names:
            x, mesh = out[name], meshes[name]
            keep = panel_clearance_m(pattern.panels[name], cfg)
            for _ in range(cfg.relax_rounds):
                x, _ = body.push_out(relax_panel(x, mesh.triangles, mesh.points, cfg), keep)
            relaxed[name] = x

    def assemble(chosen: set) -> tuple[dict, int]:
        """Positions with the chosen panels relaxed, sleeves lifted; and their crossings."""
        placed = {n: (relaxed[n] if n in chosen else x).copy() for n, x in out.items()}
        if "torso" in by_part:
            limbs = [n for part, names in by_part.items() if part != "torso" for n in names]
            lift_over_torso(body, body.frame("torso", heights["torso"]), placed,
                            by_part["torso"], limbs, pattern)  # fmt: skip
        return placed, crossings(placed, meshes)

    clearance = {n: panel_clearance_m(pattern.panels[n], cfg) for n in out}

    def untangled(placed: dict, count: int) -> tuple[dict, int]:
        if not count:
            return placed, 0
        placed = untangle(placed, meshes, body, clearance, cfg)
        return placed, crossings(placed, meshes)

    # every panel relaxed, then the crossings that made smoothed away ...
    best, count = untangled(*assemble(set(relaxed)))
    if not count:
        return best
    # ... else, as a relaxed panel can slide into its neighbour (a sleeve into the bodice),
    # each panel's relaxation kept only if the garment does not start with more crossings
    chosen: set = set()
    greedy, c_greedy = assemble(chosen)
    for name in relaxed:
        trial, c = assemble(chosen | {name})
        if c <= c_greedy:
            chosen, greedy, c_greedy = chosen | {name}, trial, c
    greedy, c_greedy = untangled(greedy, c_greedy)
    return greedy if c_greedy < count else best


def _side_by_side(a: tuple[float, float], b: tuple[float, float], cfg: PlacementConfig) -> bool:
    """Whether two panels' height spans (lo, hi) [m] overlap by more than
    ``cfg.sector_overlap`` of the shorter one: only such panels share the turn round the
    body between them (a hood above a bodice, or a bodice above a skirt, has the whole turn
    at its own height)."""
    overlap = min(a[1], b[1]) - max(a[0], b[0])
    return overlap > cfg.sector_overlap * min(a[1] - a[0], b[1] - b[0])


def _wrap_pi(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi
