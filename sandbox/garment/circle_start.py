"""The start shape of a circle skirt: a cone from the waist, its extra width in folds.

A circle skirt's gores are sectors of one circle whose inner arc is the waist. Wrapped row
by row around the hips (:func:`~sandbox.pattern.placement.place.place_pattern`) a full
circle becomes a wide cone that reaches the hanging arms, because each row is about twice
as long as the body's section below the waist. Here the skirt starts on a cone of
half-angle α from the waist instead (a half circle fits that cone exactly at α = 30°), and
each row's length beyond the cone's circumference goes into ``folds`` radial folds: at
distance s from the waist along the cone, the row lies on the closed curve

    R(θ) = R₀(s) + A(s) cos(k θ),   R₀(s) = r_w + s sin α,   height y_w − s cos α

about the torso's axis, with A chosen so that the curve is as long as the pattern's row
(2π f ρ for a skirt of fullness f, ρ = r + s the row's radius in the pattern). The troughs
are at the sides (k ≡ 2 mod 4), where the arms hang. A vertex goes to the point of its
row's curve at the same fraction of the length as its angle in the pattern, so the rows
keep their lengths; each gore keeps a small gap at its sides that sewing closes. The
panels are then relaxed and pushed out of the body as the wrap's are
(:func:`~sandbox.pattern.placement.repair.relax_panel`).

A drafted circle skirt marks its gores with ``meta["circle"]`` (:func:`circle_gores`):
the circle's centre in panel coordinates, the waist radius and the gore's angle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sandbox.errors import SandboxError


@dataclass(frozen=True)
class CircleStart:
    """How a circle skirt starts (lengths in m, angles in degrees)."""

    cone_half_angle_deg: float = 30.0
    """α: the cone the skirt starts on; at 30° a half circle fits it without folds, and a
    full circle's hem (knee length) stays 24 cm inside the hanging hands."""
    folds: int = 10
    """k: folds around the skirt, troughs at the sides (k ≡ 2 mod 4); a silk circle skirt
    hangs in about ten."""
    seam_gap_m: float = 0.01
    """Arc left open at each side of a gore (the seams close it)."""
    relax_rounds: int = 3
    """Rounds of relaxation and push-out after the folds are laid, as the wrap's."""


DEFAULT_CIRCLE_START = CircleStart()


def circle_gores(pattern) -> dict | None:
    """panel name -> its ``meta["circle"]`` when every panel of ``pattern`` is a circle
    skirt gore and the skirt is fuller than a half circle (which fits the cone without
    folds, so the wrap places it as well), else None."""
    out = {n: p.meta.get("circle") for n, p in pattern.panels.items()}
    if not out or not all(isinstance(c, dict) for c in out.values()):
        return None
    return out if max(float(c["fullness"]) for c in out.values()) > 0.5 + 1e-9 else None


def fold_amplitude(length_m: np.ndarray, r0_m: np.ndarray, k: int) -> np.ndarray:
    """A [m] such that R(θ) = R₀ + A cos(kθ) is ``length_m`` long (0 where the circle of
    radius R₀ is already as long), at most 0.9 R₀."""
    theta = np.linspace(0.0, 2.0 * math.pi, 721)

    def length(a):
        r = r0_m[:, None] + a[:, None] * np.cos(k * theta)
        dr = -a[:, None] * k * np.sin(k * theta)
        return np.trapezoid(np.hypot(r, dr), theta, axis=1)

    lo, hi = np.zeros_like(r0_m), 0.9 * r0_m
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        short = length(mid) < length_m
        lo, hi = np.where(short, mid, lo), np.where(short, hi, mid)
    return np.where(length_m > 2.0 * math.pi * r0_m, 0.5 * (lo + hi), 0.0)


def _curve_points(r0: float, a: float, k: int, phase: float, t: np.ndarray) -> np.ndarray:
    """Points (len(t), 2) at arc-length fractions t ∈ [0, 1) of R(θ) = R₀ + A cos(kθ + phase),
    as R (cos θ, sin θ) in the torso frame's (front, left) plane."""
    theta = np.linspace(0.0, 2.0 * math.pi, 2881)
    r = r0 + a * np.cos(k * theta + phase)
    seg = np.hypot(np.diff(r), 0.5 * (r[1:] + r[:-1]) * np.diff(theta))
    s = np.concatenate([[0.0], np.cumsum(seg)])
    th = np.interp(np.mod(t, 1.0) * s[-1], s, theta)
    rr = r0 + a * np.cos(k * th + phase)
    return np.stack([rr * np.cos(th), rr * np.sin(th)], axis=1)


def place_circle_skirt(pattern, meshes: dict, body, start: CircleStart = DEFAULT_CIRCLE_START):
    """Start positions {panel name: (n, 3) [m]} of a circle skirt's gores (module docstring).

    ``pattern``: a loaded Pattern whose panels all carry ``meta["circle"]``
    (:func:`circle_gores`); ``meshes``: panel name -> PanelMesh; ``body``: the
    :class:`~sandbox.pattern.placement.body.PlacementBody`.
    """
    from sandbox.pattern.placement.repair import panel_clearance_m, relax_panel

    gores = circle_gores(pattern)
    if gores is None:
        raise SandboxError(f"{pattern.source}: not a circle skirt (meta 'circle' on every panel)")
    if start.folds % 4 != 2:
        raise SandboxError(
            f"circle start: {start.folds} folds; need k ≡ 2 mod 4 (troughs at the sides)"
        )
    alpha = math.radians(start.cone_half_angle_deg)
    y_w = float(body.landmarks["waist_front"][1])
    frame = body.frame("torso", y_w)
    out = {}
    for name, c in gores.items():
        panel, mesh = pattern.panels[name], meshes[name]
        u = panel.units_to_m
        full = float(c["fullness"])
        r_w = float(c["waist_radius"]) * u  # the pattern's waist radius
        d = np.asarray(mesh.points, float) - np.asarray(c["centre"], float) * u
        rho = np.hypot(d[:, 0], d[:, 1])
        psi = np.arctan2(d[:, 0], -d[:, 1])  # angle in the gore, 0 at its centre line
        s = np.maximum(rho - r_w, 0.0)
        theta_g = body.side_angle(frame, c["side"])
        r0 = full * r_w + s * math.sin(alpha)
        length = 2.0 * math.pi * full * rho
        amp = fold_amplitude(length, r0, start.folds)
        half = 0.25 * math.pi  # each gore's quarter of the turn ...
        gap = np.minimum(start.seam_gap_m / np.maximum(length, 1e-9), 0.02)  # ... less the gap
        t = (theta_g + np.clip(psi / full, -half, half) * (1.0 - 8.0 * gap)) / (2.0 * math.pi)
        uw = np.vstack([_curve_points(r0[i], amp[i], start.folds, 0.0, t[i : i + 1])
                        for i in range(len(rho))])  # fmt: skip
        x = frame.world(frame.height([0.0, y_w, 0.0]) - s * math.cos(alpha), uw)
        keep = panel_clearance_m(panel, body.config)
        for _ in range(start.relax_rounds):
            x, _ = body.push_out(relax_panel(x, mesh.triangles, mesh.points, body.config), keep)
        out[name] = x
    return out
