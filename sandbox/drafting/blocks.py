"""Drafting blocks (after Aldrich, Metric Pattern Cutting for Women's Wear): bodice, sleeve,
raglan, camisole, halter, skirt and circle skirt. All lengths in cm.

Every block is a function ``block(params, body, rules=DEFAULT_RULES) -> Draft`` taking the
garment's drafting parameters (``garments/<name>.json`` ``"params"``), the body's
:class:`~sandbox.drafting.body.BodyDims` and the drafting system's proportions
(:class:`~sandbox.drafting.torso.DraftRules`), and returning whole panels (the front spans
the full front, the back the full back; left and right halves are mirror images about the
centre line x = 0), seams and the designed girths.

Modules: :mod:`~sandbox.drafting.torso` (the :class:`~sandbox.drafting.torso.Draft`, side
seams, hems, girths), :mod:`~sandbox.drafting.bodice` (bodice, raglan, camisole, halter),
:mod:`~sandbox.drafting.sleeves` (set-in and raglan sleeves), :mod:`~sandbox.drafting.skirts`
(skirt, circle skirt); this module names them for ``garments/<name>.json`` ``"block"``.

Panel frames (see docs/garments.md): torso panels have y = 0 at the waist and y up; a
front panel is seen from the front, its x towards the body's left (+X); a back panel is seen
from behind, its x towards the body's right (-X). Sleeves have y = 0 at the underarm (biceps)
line, the cap top at (0, cap height) and x across the arm, seen from outside the arm: on the
right arm x points to the front, on the left arm to the back (in every panel x is the
viewer's right hand looking at the outside of the garment). Outlines are counter-clockwise
in these frames. Edge names say the body side: ``side_left`` is the left side seam of the
body on both the front and the back panel.

No darts in bodices (whole front/back panels cannot hold a fish-eye dart, and a side bust
dart would need its own seam): the bodice is Aldrich's dartless ("flat") block, shaped at
the side seams, with the bust allowance given as extra length at the centre-front hem.
Skirts keep one waist dart per half panel (a V notch in the waist edge, its legs sewn).
"""

from __future__ import annotations

from sandbox.drafting.bodice import bodice, camisole, halter, raglan
from sandbox.drafting.skirts import circle_skirt, skirt

BLOCKS = {
    "bodice": bodice,
    "raglan": raglan,
    "camisole": camisole,
    "halter": halter,
    "skirt": skirt,
    "circle_skirt": circle_skirt,
}
