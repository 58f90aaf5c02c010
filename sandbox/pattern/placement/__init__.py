"""Place flat pattern panels around the mannequin (paper §2.3).

Two placement forms (docs/pattern_format.md):

* **explicit** ``{"translation": [x, y, z], "rotation_deg": [rx, ry, rz]}`` (file units):
  world = R [x, y, 0] + t, R = Rz Ry Rx; used as given (GarmentCode imports);
* **on the body** ``{"body", "side", "anchor", "landmark", "offset", "wrap", "clearance"}``.

Body placement. Each body part has an *axis*: the torso the vertical line through the
centre of the body section at the anchor height; an arm the line from the centre of its
armhole feature line to the wrist (the arm vertices farthest from the armhole); a leg the
line from the top of the leg to the ankle. Around the axis, angles run from the front
(θ = 0, world +Z projected) towards ``axis × front`` (the body's left for the torso), so
panel +x always runs in the direction of increasing angle, as the contract's
"counter-clockwise seen from outside" requires. Panel y runs along the axis (to the head or
to the shoulder); the anchor goes to the landmark's height along the axis and to the angle
of ``side`` (front 0, left, back, right; "outer" = away from the torso for a limb).

``wrap`` (default true) bends the panel around a **placement surface**: at each height
(1 cm rows), the convex hull of the body part's vertices in a band around that height,
offset outwards by the clearance (default 2 cm). Panel x is arc length along that curve,
so the panel starts unstretched across its width. If the panel is too wide for its angular
*sector* (the half-way lines to the panels on other sides of the same body part, less a gap
of ``side_gap_rad`` at each side; the whole turn less the gap for a panel alone), the
curve is offset further at that height so the panel fits: front and back panels never
overlap at the start and the seams pull them together. ``wrap: false`` places the panel
flat, facing ``side``, in front of the body part's extent in that direction plus the
clearance.

Finally every vertex closer to the body (any part, e.g. an arm next to the torso) than the
clearance is pushed out along the surface normal to the clearance distance, so nothing
starts inside the body, for every mannequin size.

Modules: :mod:`~sandbox.pattern.placement.config` (the settings, ``PlacementConfig``),
:mod:`~sandbox.pattern.placement.body` (axes, section hulls, push-out),
:mod:`~sandbox.pattern.placement.wrap` (wrapped and flat panels),
:mod:`~sandbox.pattern.placement.repair` (relaxation, lift over the bodice, untangling) and
:mod:`~sandbox.pattern.placement.place` (``place_panel``, ``place_pattern``).
"""
