"""Does a pattern close around the body? Its girth at the bust, waist and hip, before a drape.

A garment drafted for a smaller body (or a design drafted for another body than the
mannequin) cannot be sewn closed around it: the drape then ends with seams open and the
cloth strained, after minutes of simulation. This check measures the pattern instead, in
a second, before anything is meshed.

At each of the mannequin's three girth levels (the bust points, the front waist, the front
hip: heights y [m]) the panels that go around the torso are cut by the horizontal plane
y = level as they are placed (:mod:`sandbox.pattern.placement`): an explicit placement
(``translation``/``rotation_deg``) puts a panel point p at R [p, 0] + t, a landmark
placement on the torso puts panel height p_y at the landmark's height + (p_y − anchor_y).
The cut's length inside each panel outline (in the pattern, i.e. the cloth's own width at
that height) summed over the panels is the garment's girth there, and G is the largest
such girth within ``band_m`` of the level (a garment drafted for another body is placed a
few cm higher or lower than it will settle; for the waist, the narrowest level, this makes
the check lenient, never stricter). Panels on the arms or legs, and explicit panels tilted
sideways by more than ``max_tilt`` (sleeves), do not count.

A level where the girth falls under ``min_cover`` of the body's girth B anywhere in the band
is not one these panels close around (a skirt at the bust, a top whose hem is near the hip)
and is not judged. Elsewhere the garment fits if G ≥ B (1 − s), s the strain the fabric
reaches under the hoop tension ``tension_N_m`` in its softer direction (T / min(k_u, k_v)),
between ``min_stretch`` and ``max_stretch``. A garment short by more than
``refuse_margin_m`` is refused with both girths and the level; one short by less gets a
warning.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from sandbox.errors import SandboxError

LEVELS = (("bust", "bust_point_left", "bust_girth"), ("waist", "waist_front", "waist_girth"),
          ("hip", "hip_front", "hip_girth"))  # fmt: skip
"""(name, the mannequin landmark giving the height, the measurement giving the girth)."""


@dataclass(frozen=True)
class FitConfig:
    """Settings of the fit check (lengths in m, tension in N/m)."""

    enabled: bool = True
    tension_N_m: float = 5.0
    """Hoop tension a garment may hold around the body: the fabric's strain under it is the
    shortfall allowed (knits stretch 7-15 % under 5 N/m, cottons 0.1 %)."""
    min_stretch: float = 0.02
    """Shortfall always allowed (the mannequin's tape and the pattern's sampling)."""
    max_stretch: float = 0.3
    """Shortfall never allowed, whatever the fabric."""
    min_cover: float = 0.5
    """A level whose panels reach less than this fraction of the body's girth is not one
    the garment closes around, and is not judged."""
    band_m: float = 0.04
    """The garment's girth at a level is the largest within this distance of it: a garment
    placed for another body settles a few cm higher or lower (GarmentCode's bodices have
    their underarm 3-4 cm below the mannequin's, at its bust level)."""
    refuse_margin_m: float = 0.10
    """A garment short of fitting by more than this is refused; by less, a warning: the
    horizontal cut underestimates panels that are curved where they cross the level (a
    curved waistband laid flat, the arcs of a flared skirt)."""
    max_tilt: float = 0.35
    """An explicit panel whose x axis rises by more than this (sin of the angle) is not a
    torso panel (a sleeve)."""


@dataclass(frozen=True)
class LevelFit:
    """One level: its name, height [m], the garment's and the body's girth [m], and the
    shortfall allowed (a fraction). ``judged`` is False where the garment does not close
    around the body there."""

    name: str
    height_m: float
    garment_m: float
    body_m: float
    allowed: float
    judged: bool

    @property
    def shortfall_m(self) -> float:
        """How much more girth [m] the garment needs to fit here (0 if it fits or is not
        judged)."""
        if not self.judged:
            return 0.0
        return max(0.0, self.body_m * (1.0 - self.allowed) - self.garment_m)

    @property
    def fits(self) -> bool:
        return self.shortfall_m == 0.0

    def as_dict(self) -> dict:
        return {"level": self.name, "height_m": self.height_m, "garment_cm": self.garment_m * 100,
                "body_cm": self.body_m * 100, "allowed_stretch": self.allowed,
                "judged": self.judged, "fits": self.fits}  # fmt: skip


def allowed_stretch(material, config: FitConfig = FitConfig()) -> float:
    """The shortfall a fabric may take up by stretching (see the module docstring)."""
    k = min(material.stretch_u_N_m, material.stretch_v_N_m)
    s = config.tension_N_m / k if k > 0 else math.inf
    return float(min(max(s, config.min_stretch), config.max_stretch))


def pattern_fit(pattern, mannequin, material, config: FitConfig = FitConfig()) -> list[LevelFit]:
    """The garment's girth against the body's at the bust, waist and hip (module docstring)."""
    from sandbox.pattern.placement.place import prepare_body
    from sandbox.pattern.spec import rotation_matrix_xyz_deg

    lm = mannequin.landmarks
    girth_cm = mannequin.measurements_requested.to_dict()
    allowed = allowed_stretch(material, config)
    placer = None
    cuts = []  # per panel: (a (2,), c [m], outline (n, 2) [m]): height h cuts a·p = h - c
    for panel in pattern.panels.values():
        p, u = panel.placement, panel.units_to_m
        outline = panel.outline(0.01)
        if "translation" in p:
            r = rotation_matrix_xyz_deg(p.get("rotation_deg", (0.0, 0.0, 0.0)))
            a = r[1, :2]
            if np.linalg.norm(a) < 1e-9 or abs(r[1, 0]) > config.max_tilt:
                continue
            cuts.append((a, float(p["translation"][1]) * u, outline))
        elif p and p.get("body", "torso") == "torso" and "landmark" in p:
            placer = placer or prepare_body(mannequin)[0]
            base = float(placer.point(p["landmark"])[1])
            dy = float(p.get("offset", (0.0, 0.0, 0.0))[1]) * u
            cuts.append((np.array([0.0, 1.0]), base + dy - float(p["anchor"][1]) * u, outline))
    out = []
    for name, landmark, key in LEVELS:
        if landmark not in lm:
            continue
        h = float(lm[landmark][1])
        body = girth_cm[key] / 100.0
        around = [sum(_chord(outline, a, y - c) for a, c, outline in cuts)
                  for y in h + np.linspace(-config.band_m, config.band_m, 9)]  # fmt: skip
        garment = max(around)
        judged = min(around) >= config.min_cover * body  # round the body all through the band
        out.append(LevelFit(name, h, garment, body, allowed, judged))
    return out


def check_fit(pattern, mannequin, material, config: FitConfig = FitConfig()) -> list[LevelFit]:
    """:func:`pattern_fit`; SandboxError for a level short by more than
    ``refuse_margin_m``, a warning (logger ``sandbox.garment``) for one short by less."""
    levels = pattern_fit(pattern, mannequin, material, config)
    if not config.enabled:
        return levels
    for f in levels:
        if f.fits:
            continue
        text = (
            f"at the {f.name} ({f.height_m:.2f} m up) its panels go "
            f"{f.garment_m * 100:.1f} cm around, the body is {f.body_m * 100:.1f} cm, "
            f"and the fabric {material.name!r} takes up {f.allowed * 100:.0f} % at most"
        )
        if f.shortfall_m > config.refuse_margin_m:
            raise SandboxError(
                f"{pattern.source}: does not fit this body: {text} (a garment "
                "for a larger body, or --no-fit-check to drape it anyway)"
            )
        logging.getLogger("sandbox.garment").warning(
            "%s: may not fit this body: %s", pattern.source, text
        )
    return levels


def _chord(outline: np.ndarray, a: np.ndarray, c: float) -> float:
    """Length [m] of the line {p : a·p = c} inside the closed polygon ``outline`` (n, 2)
    (even-odd rule), for a unit-free direction ``a`` (2,) (normalised here)."""
    norm = float(np.linalg.norm(a))
    a, c = a / norm, c / norm
    f = outline @ a - c
    g = np.roll(f, -1)
    q = np.roll(outline, -1, axis=0)
    cross = (f < 0) != (g < 0)
    if not cross.any():
        return 0.0
    t = f[cross] / (f[cross] - g[cross])
    pts = outline[cross] + t[:, None] * (q[cross] - outline[cross])
    along = np.sort(pts @ np.array([-a[1], a[0]]))
    return float(np.sum(along[1::2] - along[0::2]))
