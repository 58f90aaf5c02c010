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
of :data:`SIDE_GAP_RAD` at each side; the whole turn less the gap for a panel alone), the
curve is offset further at that height so the panel fits: front and back panels never
overlap at the start and the seams pull them together. ``wrap: false`` places the panel
flat, facing ``side``, in front of the body part's extent in that direction plus the
clearance.

Finally every vertex closer to the body (any part, e.g. an arm next to the torso) than the
clearance is pushed out along the surface normal to the clearance distance, so nothing
starts inside the body, for every mannequin size.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from sandbox.collision.untangle import edge_length_pass, edge_lengths_setup, untangle_positions
from sandbox.errors import SandboxError
from sandbox.pattern.spec import rotation_matrix_xyz_deg

DEFAULT_CLEARANCE_M = 0.02
SIDE_GAP_RAD = 0.14
"""Angular gap left between the sectors of neighbouring panels (half on each side)."""
ROW_M = 0.01
"""Height spacing of the placement curves [m]; vertices in between are interpolated."""
OFFSET_DIRECTIONS = 48
FIT_MARGIN = 1.08
"""Extra offset is computed for a panel 8 % wider than it is (the offset curve's arc within
a sector grows a little slower than the circle estimate)."""
MAX_OFFSET_SLOPE = 0.5
"""Going down the axis (away from the head or the shoulder), the extra offset a row gets to
fit its sector shrinks by at most this much per metre: a flared panel (a circle skirt's
gore, whose hem centre hangs below its widest row) is placed as a cone instead of curling
back under itself towards the legs."""
SHRINK_SLOPE = 0.4
"""Going down the axis, the placement curve comes in towards the axis by at most this much
per metre, in every direction: a panel hangs from a bulge (buttocks, bust, the top of the
arm) instead of following the body in under it. Followed exactly, a 1 cm row step that
comes 1.5 cm in stretched the pencil skirt's back 78 % along its length at the start."""
RADIAL_SAMPLES = 120
"""Directions in which the curves are compared for :data:`SHRINK_SLOPE`."""
PUSH_ITERATIONS = 8
RELAX_ITERATIONS = 60
"""Jacobi passes that bring each placed panel's mesh edges back towards their pattern
lengths (:func:`relax_panel`) before a push-out ..."""
RELAX_ROUNDS = 3
"""... and how many times the two alternate."""
RELAX_HOLD = 0.03
"""Each pass also pulls every vertex this fraction of the way back to where the wrap put it,
so a panel keeps its place (its anchor on the landmark) while its strains relax."""
OVERLAP_MARGIN_M = 0.015
"""Limb panels (sleeve caps) above the underarm start at least this far outside the torso
panels, measured from the torso axis, so that they do not cut through the bodice."""
UNTANGLE_ROUNDS = 20
"""At most this many smoothing rounds of :func:`untangle` ..."""
UNTANGLE_RINGS = 2
"""... each over the vertices of the crossing triangles and this many rings around them
(smoothing and edge-length steps: :mod:`sandbox.collision.untangle`)."""
BODIES = ("torso", "arm_left", "arm_right", "leg_left", "leg_right")
_SIDE_DIRS = {"front": (0.0, 0.0, 1.0), "back": (0.0, 0.0, -1.0), "left": (1.0, 0.0, 0.0),
              "right": (-1.0, 0.0, 0.0)}  # fmt: skip


@dataclass
class BodyFrame:
    """Axis of a body part: origin (3,) [m], unit axis ``a`` (towards the head/shoulder),
    ``e1`` (front, ⟂ a) and ``e2 = a × e1``; heights are (p - origin)·a [m]."""

    body: str
    origin: np.ndarray
    a: np.ndarray
    e1: np.ndarray
    e2: np.ndarray

    def height(self, p) -> np.ndarray:
        return (np.asarray(p, float) - self.origin) @ self.a

    def angle_of(self, direction) -> float:
        d = np.asarray(direction, float)
        return math.atan2(float(d @ self.e2), float(d @ self.e1))

    def world(self, h, uw) -> np.ndarray:
        """World points (n, 3) from heights (n,) and plane coordinates (n, 2)."""
        h = np.asarray(h, float)
        return (self.origin + h[:, None] * self.a + uw[:, :1] * self.e1
                + uw[:, 1:2] * self.e2)  # fmt: skip


class _Curve:
    """A closed convex curve around the axis (CCW polygon in (e1, e2) coordinates)."""

    def __init__(self, poly: np.ndarray):
        self.p = poly
        q = np.roll(poly, -1, axis=0)
        self.d = q - poly
        self.seg = np.linalg.norm(self.d, axis=1)
        self.s = np.concatenate([[0.0], np.cumsum(self.seg)])
        self.length = float(self.s[-1])
        ang = np.arctan2(poly[:, 1], poly[:, 0])
        self.phi = ang[0] + np.concatenate([[0.0], np.cumsum(np.mod(np.diff(
            np.concatenate([ang, ang[:1]])), 2 * np.pi))])  # fmt: skip

    def arc_at_angle(self, theta: float) -> float:
        """Arc length [m] from vertex 0 to the point where the ray at ``theta`` meets it."""
        t = self.phi[0] + math.fmod(theta - self.phi[0], 2 * math.pi)
        if t < self.phi[0]:
            t += 2 * math.pi
        j = int(np.clip(np.searchsorted(self.phi, t, side="right") - 1, 0, len(self.p) - 1))
        r = np.array([math.cos(theta), math.sin(theta)])
        p, d = self.p[j], self.d[j]
        den = r[0] * d[1] - r[1] * d[0]
        u = 0.0 if abs(den) < 1e-15 else -(r[0] * p[1] - r[1] * p[0]) / den
        return float(self.s[j] + np.clip(u, 0.0, 1.0) * self.seg[j])

    def point_at_arc(self, s: np.ndarray) -> np.ndarray:
        s = np.mod(np.asarray(s, float), self.length)
        j = np.clip(np.searchsorted(self.s, s, side="right") - 1, 0, len(self.p) - 1)
        t = (s - self.s[j]) / np.maximum(self.seg[j], 1e-15)
        return self.p[j] + t[:, None] * self.d[j]


class PlacementBody:
    """A mannequin prepared for placement: part masks, axes, section hulls, push-out.

    ``mannequin`` needs ``vertices`` (n, 3) [m], ``triangles`` (m, 3), ``landmarks`` (name
    -> (3,) [m]) and optionally ``feature_lines`` (name -> (k, 3) [m]).
    """

    def __init__(self, mannequin):
        if isinstance(mannequin, PlacementBody):
            raise SandboxError("PlacementBody: already prepared")
        self.mannequin = mannequin
        self.vertices = np.asarray(mannequin.vertices, float)
        self.triangles = np.asarray(mannequin.triangles, np.int64)
        self.landmarks = {k: np.asarray(v, float) for k, v in mannequin.landmarks.items()}
        lines = getattr(mannequin, "feature_lines", None) or {}
        self.feature_lines = {k: np.asarray(v, float) for k, v in lines.items()}
        self.limbs = _limb_masks(mannequin, self.vertices, self.landmarks)
        arms = self.limbs["arm_left"] | self.limbs["arm_right"]
        x = self.vertices[:, 0]
        self.parts = {
            "torso": ~arms,
            "arm_left": self.limbs["arm_left"],
            "arm_right": self.limbs["arm_right"],
            # a leg and the half of the torso above it (trouser tops reach the waist)
            "leg_left": self.limbs["leg_left"] | (~arms & ~self.limbs["leg_right"] & (x >= 0)),
            "leg_right": self.limbs["leg_right"] | (~arms & ~self.limbs["leg_left"] & (x <= 0)),
        }
        self._frames: dict = {}
        self._bands: dict = {}
        self._curves: dict = {}
        self._scene = None

    # --- landmarks and axes ---------------------------------------------------------
    def point(self, name: str, *, where: str = "") -> np.ndarray:
        """A landmark (3,) [m], or the mean point of a feature line."""
        if name in self.landmarks:
            return self.landmarks[name]
        if name in self.feature_lines:
            line = self.feature_lines[name]
            if len(line) > 2 and np.allclose(line[0], line[-1]):
                line = line[:-1]
            return line.mean(axis=0)
        raise SandboxError(f"{where}the mannequin has no landmark or feature line {name!r}")

    def frame(self, body: str, at_height_y: float | None = None) -> BodyFrame:
        """The axis of a body part (the torso's through the section centre at ``y``)."""
        key = (body, None if at_height_y is None else round(float(at_height_y), 4))
        if key in self._frames:
            return self._frames[key]
        v = self.vertices
        if body == "torso":
            y = float(np.median(v[:, 1])) if at_height_y is None else float(at_height_y)
            a = np.array([0.0, 1.0, 0.0])
            sel = v[self.parts["torso"] & (np.abs(v[:, 1] - y) <= 0.02)]
            if len(sel) < 3:
                sel = v[self.parts["torso"]]
            c = _hull_centroid(sel[:, [0, 2]])
            origin = np.array([c[0], 0.0, c[1]])
        elif body in ("arm_left", "arm_right"):
            side = body.split("_")[1]
            limb = v[self.limbs[body]]
            if len(limb) < 3:
                raise SandboxError(f"the mannequin has no {body.replace('_', ' ')}")
            hole = f"armhole_{side}"
            top = self.point(hole) if hole in self.feature_lines else limb[np.argmax(limb[:, 1])]
            dist = np.linalg.norm(limb - top, axis=1)
            wrist = limb[dist >= dist.max() - 0.01].mean(axis=0)
            a = _unit(top - wrist)
            origin = top
        elif body in ("leg_left", "leg_right"):
            limb = v[self.limbs[body]]
            if len(limb) < 3:
                raise SandboxError(f"the mannequin has no {body.replace('_', ' ')}")
            top = limb[limb[:, 1] >= limb[:, 1].max() - 0.02].mean(axis=0)
            ankle = limb[limb[:, 1] <= limb[:, 1].min() + 0.01].mean(axis=0)
            a = _unit(top - ankle)
            origin = top
        else:
            raise SandboxError(f"unknown body part {body!r}; use one of {', '.join(BODIES)}")
        front = np.array([0.0, 0.0, 1.0])
        e1 = _unit(front - (front @ a) * a)
        frame = BodyFrame(body, origin, a, e1, np.cross(a, e1))
        self._frames[key] = frame
        return frame

    def side_angle(self, frame: BodyFrame, side: str) -> float:
        """Angle [rad] of a placement side around the body part's axis."""
        if side == "outer":
            side = {"left": "left", "right": "right"}.get(frame.body.rpartition("_")[2], "front")
        if side not in _SIDE_DIRS:
            raise SandboxError(f"unknown placement side {side!r}")
        return frame.angle_of(_SIDE_DIRS[side])

    # --- placement surfaces -----------------------------------------------------------
    def _part_data(self, frame: BodyFrame):
        key = (frame.body, tuple(np.round(frame.origin, 5)))
        if key not in self._bands:
            mask = self.parts[frame.body]
            p = self.vertices[mask] - frame.origin
            h = p @ frame.a
            uw = np.stack([p @ frame.e1, p @ frame.e2], axis=1)
            # band half-width: the longest edge along the axis, so every surface point at a
            # height lies in the hull of the vertices within the band
            tri = self.triangles[mask[self.triangles].all(axis=1)]
            hv = (self.vertices - frame.origin) @ frame.a
            dh = np.abs(hv[tri] - np.roll(hv[tri], 1, axis=1)).ravel()
            band = float(max(0.01, np.percentile(dh, 99.5))) if len(dh) else 0.03
            order = np.argsort(h)
            self._bands[key] = (h[order], uw[order], band)
        return self._bands[key]

    def section_points(self, frame: BodyFrame, h: float) -> np.ndarray:
        """Body-part points (k, 2) in (e1, e2) coordinates within a band around height h."""
        hs, uw, band = self._part_data(frame)
        h = float(np.clip(h, hs[0], hs[-1]))
        i0, i1 = np.searchsorted(hs, [h - band, h + band])
        if i1 - i0 < 3:  # outside the part: the nearest few vertices
            k = np.argsort(np.abs(hs - h))[:16]
            return uw[k]
        return uw[i0:i1]

    def curve(self, frame: BodyFrame, h: float, offset_m: float) -> _Curve:
        """The section hull at height h offset by ``offset_m``, containing the axis."""
        key = (frame.body, tuple(np.round(frame.origin, 6)), round(h, 6), round(offset_m, 6))
        if key not in self._curves:
            if len(self._curves) > 20000:
                self._curves.clear()
            self._curves[key] = self._curve(frame, h, offset_m)
        return self._curves[key]

    def _curve(self, frame: BodyFrame, h: float, offset_m: float) -> _Curve:
        pts = self.section_points(frame, h)
        ring = np.linspace(0, 2 * np.pi, OFFSET_DIRECTIONS, endpoint=False)
        disc = np.stack([np.cos(ring), np.sin(ring)], 1)
        hull = _hull_points(np.vstack([pts, 0.005 * disc]))
        # the polygon of samples of the disc lies inside the disc: scale up so that the
        # sampled offset curve is at least ``offset_m`` away everywhere
        r = offset_m / math.cos(math.pi / OFFSET_DIRECTIONS)
        grown = (hull[:, None, :] + r * disc[None]).reshape(-1, 2)
        return _Curve(_hull_points(grown))

    # --- push-out -----------------------------------------------------------------------
    def _raycasting(self):
        """The body's Open3D RaycastingScene (built once)."""
        import open3d as o3d

        if self._scene is None:
            self._scene = o3d.t.geometry.RaycastingScene()
            self._scene.add_triangles(
                o3d.core.Tensor(self.vertices.astype(np.float32)),
                o3d.core.Tensor(self.triangles.astype(np.uint32)),
            )
        return self._scene

    def surface_normals(self, x: np.ndarray) -> np.ndarray:
        """Outward unit normals (n, 3) of the body triangles closest to points ``x`` (n, 3) [m]."""
        import open3d as o3d

        x = np.asarray(x, np.float32).reshape(-1, 3)
        cp = self._raycasting().compute_closest_points(o3d.core.Tensor(x))
        return cp["primitive_normals"].numpy().astype(float)

    def push_out(self, x: np.ndarray, clearance_m: float) -> tuple[np.ndarray, int]:
        """Move points closer to the body than ``clearance_m`` out to that distance.

        Returns the new points (n, 3) and how many were moved.
        """
        import open3d as o3d

        self._raycasting()
        x = np.array(x, float)
        moved = np.zeros(len(x), bool)
        target = clearance_m * 1.02
        for _ in range(PUSH_ITERATIONS):
            q = o3d.core.Tensor(x.astype(np.float32))
            sd = self._scene.compute_signed_distance(q).numpy().astype(float)
            near = sd < clearance_m * 0.999
            if not near.any():
                break
            cp = self._scene.compute_closest_points(o3d.core.Tensor(x[near].astype(np.float32)))
            c = cp["points"].numpy().astype(float)
            nrm = cp["primitive_normals"].numpy().astype(float)
            d = x[near] - c
            dist = np.linalg.norm(d, axis=1)
            direction = np.where((sd[near] > 1e-5)[:, None], d / np.maximum(dist, 1e-12)[:, None],
                                 nrm)  # fmt: skip
            x[near] = c + target * direction
            moved[near] = True
        return x, int(moved.sum())


def place_panel(
    points_m,
    placement: dict,
    mannequin,
    units_to_m: float = 0.01,
    *,
    sector_rad: tuple[float, float] | None = None,
    axis_height_m: float | None = None,
    where: str = "",
) -> np.ndarray:
    """World positions (n, 3) [m] of a panel's mesh points.

    Args:
        points_m: (n, 2) panel coordinates [m].
        placement: the panel's placement table as in the pattern file (file units).
        mannequin: a :class:`~sandbox.mannequin.Mannequin` or a :class:`PlacementBody`.
        units_to_m: the pattern file's length unit [m].
        sector_rad: (before, after) angles [rad] the panel may use on each side of its
            ``side`` angle (default: the whole turn less :data:`SIDE_GAP_RAD`).
        axis_height_m: for the torso, the height [m] whose section centre fixes the axis
            (default: the landmark's height); panels of one garment share it.
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
    body = mannequin if isinstance(mannequin, PlacementBody) else PlacementBody(mannequin)
    part = placement.get("body", "torso")
    if part not in BODIES:
        raise SandboxError(f"{where}placement: unknown body {part!r}; use one of "
                           f"{', '.join(BODIES)}")  # fmt: skip
    landmark = body.point(placement["landmark"], where=where)
    anchor = np.asarray(placement["anchor"], float) * u
    offset = np.asarray(placement.get("offset", (0.0, 0.0, 0.0)), float) * u
    clearance = float(placement.get("clearance", DEFAULT_CLEARANCE_M / u)) * u
    frame = body.frame(part, landmark[1] if axis_height_m is None else axis_height_m)
    theta = body.side_angle(frame, placement["side"])
    s = pts[:, 0] - anchor[0]
    h = float(frame.height(landmark)) + pts[:, 1] - anchor[1]
    if placement.get("wrap", True):
        half = math.pi - SIDE_GAP_RAD / 2
        before, after = sector_rad if sector_rad is not None else (half, half)
        x = _wrap(body, frame, theta, s, h, clearance, before, after)
    else:
        x = _flat(body, frame, theta, s, h, clearance)
    x = x + offset
    x, _ = body.push_out(x, clearance)
    return x


def place_pattern(pattern, meshes: dict, mannequin) -> dict[str, np.ndarray]:
    """World positions (n, 3) [m] of every meshed panel of a pattern.

    Panels on the same body part share one axis (the torso's at the mean anchor height) and
    split the turn into sectors between their sides, so they do not overlap at the start.
    ``meshes``: panel name -> :class:`~sandbox.pattern.panel_mesh.PanelMesh`.
    """
    body = mannequin if isinstance(mannequin, PlacementBody) else PlacementBody(mannequin)
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
    angles = {}
    for part, names in by_part.items():
        frame = body.frame(part, heights[part])
        for n in names:
            angles[n] = body.side_angle(frame, pattern.panels[n].placement["side"])
    out = {}
    for name, panel in pattern.panels.items():
        p = panel.placement
        pts = meshes[name].points
        at = f"{where}panel {name!r}: "
        if "translation" in p:
            out[name] = place_panel(pts, p, body, panel.units_to_m, where=at)
            continue
        part = p.get("body", "torso")
        mine = angles[name]
        others = [angles[o] for o in by_part[part] if abs(_wrap_pi(angles[o] - mine)) > 1e-3]
        if others:
            after = min(np.mod(o - angles[name], 2 * np.pi) for o in others) / 2
            before = min(np.mod(angles[name] - o, 2 * np.pi) for o in others) / 2
            sector = (before - SIDE_GAP_RAD / 2, after - SIDE_GAP_RAD / 2)
        else:
            sector = None
        out[name] = place_panel(pts, p, body, panel.units_to_m, sector_rad=sector,
                                axis_height_m=heights[part], where=at)  # fmt: skip
    relaxed = {}
    for names in by_part.values():  # unstrain each wrapped panel, keep the clearance
        for name in names:
            x = out[name]
            for _ in range(RELAX_ROUNDS):
                x, _ = body.push_out(relax_panel(x, meshes[name].triangles, meshes[name].points),
                                     _clearance_m(pattern.panels[name]))  # fmt: skip
            relaxed[name] = x

    def assemble(chosen: set) -> tuple[dict, int]:
        """Positions with the chosen panels relaxed, sleeves lifted; and their crossings."""
        placed = {n: (relaxed[n] if n in chosen else x).copy() for n, x in out.items()}
        if "torso" in by_part:
            limbs = [n for part, names in by_part.items() if part != "torso" for n in names]
            _lift_over_torso(body, body.frame("torso", heights["torso"]), placed,
                             by_part["torso"], limbs, pattern)  # fmt: skip
        return placed, _crossings(placed, meshes)

    clearance = {n: _clearance_m(pattern.panels[n]) for n in out}

    def untangled(placed: dict, crossings: int) -> tuple[dict, int]:
        if not crossings:
            return placed, 0
        placed = untangle(placed, meshes, body, clearance)
        return placed, _crossings(placed, meshes)

    # every panel relaxed, then the crossings that made smoothed away ...
    best, crossings = untangled(*assemble(set(relaxed)))
    if not crossings:
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
    return greedy if c_greedy < crossings else best


def untangle(placed: dict, meshes: dict, body, clearance_m: dict,
             rounds: int | None = None) -> dict:  # fmt: skip
    """Placed panels with their start crossings smoothed away (the fewest crossings found).

    Pushing a fine mesh out of a crease (the armpit, where a sleeve cap meets the bodice)
    moves neighbouring vertices to different surfaces, and the panel folds through itself:
    a 1 cm T-shirt started with 74 crossing triangle pairs, and contact handling keeps a
    start crossing for good. :func:`sandbox.collision.untangle.untangle_positions` smooths
    the crossing triangles and :data:`UNTANGLE_RINGS` rings of neighbours and pushes them
    out to their panel's clearance again.

    Args:
        placed: panel name -> (n, 3) positions [m]. meshes: panel name -> mesh (its
            ``triangles``). body: :class:`PlacementBody`. clearance_m: panel name -> [m].
        rounds: at most this many rounds (default :data:`UNTANGLE_ROUNDS`).
    """
    names = list(placed)
    offsets = np.cumsum([0] + [len(placed[n]) for n in names])
    x = np.vstack([placed[n] for n in names]).astype(float)
    tri = np.vstack([np.asarray(meshes[n].triangles) + offsets[k] for k, n in enumerate(names)])
    uv = np.vstack([np.asarray(meshes[name].points, float) for name in names])

    def push_out(y, mask):
        y = y.copy()
        for p, name in enumerate(names):
            sl = slice(offsets[p], offsets[p + 1])
            if mask[sl].any():
                y[sl], _ = body.push_out(y[sl], clearance_m[name])
        return y

    best, _, _, _ = untangle_positions(
        x, tri, uv, push_out, rounds=UNTANGLE_ROUNDS if rounds is None else rounds,
        rings=UNTANGLE_RINGS)  # fmt: skip
    return {name: best[offsets[k] : offsets[k + 1]] for k, name in enumerate(names)}


def _clearance_m(panel) -> float:
    """A wrapped panel's clearance from the body [m] (its placement's, else the default)."""
    u = panel.units_to_m
    return float(panel.placement.get("clearance", DEFAULT_CLEARANCE_M / u)) * u


def start_stretches(meshes: dict, placed: dict) -> np.ndarray:
    """Principal stretches (triangles, 2) of every placed triangle against its pattern
    shape (largest first); ``meshes`` and ``placed`` as :func:`place_pattern`'s."""
    out = []
    for name, mesh in meshes.items():
        t, uv, x = mesh.triangles, mesh.points, placed[name]
        rest = np.stack([uv[t[:, 1]] - uv[t[:, 0]], uv[t[:, 2]] - uv[t[:, 0]]], 2)
        world = np.stack([x[t[:, 1]] - x[t[:, 0]], x[t[:, 2]] - x[t[:, 0]]], 2)
        out.append(np.linalg.svd(world @ np.linalg.inv(rest), compute_uv=False))
    return np.vstack(out)


def _crossings(placed: dict, meshes: dict) -> int:
    """Intersecting triangle pairs of all panels together (exact test)."""
    from sandbox.collision.metrics import count_intersecting_pairs

    names = list(placed)
    offsets = np.cumsum([0] + [len(placed[n]) for n in names])
    x = np.vstack([placed[n] for n in names])
    tri = np.vstack([meshes[n].triangles + offsets[k] for k, n in enumerate(names)])
    return count_intersecting_pairs(x, tri)


def relax_panel(x: np.ndarray, triangles: np.ndarray, rest_xy: np.ndarray,
                iterations: int = RELAX_ITERATIONS) -> np.ndarray:  # fmt: skip
    """Placed positions (n, 3) [m] moved so the mesh edges get back their pattern lengths.

    Wrapping rows of a panel around body sections of changing shape stretches it where the
    sections change fast (the pencil skirt's back at the hip: 35 % along its length, the
    T-shirt's sleeve at the armpit: 120 %). Started that way, the seam edges and those
    regions leap at tens of m/s in the first steps. Each Jacobi pass moves both ends of
    every edge half-way to its rest length (position-based, averaged per vertex) and pulls
    it :data:`RELAX_HOLD` of the way back to its placed position; the push-out after it
    restores the body clearance.
    """
    x0 = np.asarray(x, float)
    x = x0.copy()
    i, j, rest, count = edge_lengths_setup(triangles, rest_xy, len(x))
    for _ in range(iterations):
        x += edge_length_pass(x, i, j, rest, count)
        x += RELAX_HOLD * (x0 - x)
    return x


def _lift_over_torso(body, frame, out, torso_panels, limb_panels, pattern) -> None:
    """Move limb-panel vertices above the underarm that lie inside (or within the margin of)
    the torso panels radially outwards, about the torso axis, to the margin."""
    if not limb_panels or not torso_panels:
        return
    from scipy.spatial import cKDTree

    def cyl(x):
        p = x - frame.origin
        u, w = p @ frame.e1, p @ frame.e2
        return p @ frame.a, np.arctan2(w, u), np.hypot(u, w)

    h_t, th_t, r_t = cyl(np.vstack([out[n] for n in torso_panels]))
    scale = float(np.median(r_t))
    tree = cKDTree(np.stack([h_t, th_t * scale], 1))
    for name in limb_panels:
        part = pattern.panels[name].placement.get("body", "torso")
        side = part.rpartition("_")[2]
        key = f"underarm_point_{side}"
        if part.startswith("leg") or key not in body.landmarks:
            continue
        x = out[name]
        h, th, r = cyl(x)
        above = h >= frame.height(body.landmarks[key]) - 0.01
        if not above.any():
            continue
        idx = np.nonzero(above)[0]
        best = np.full(len(idx), -np.inf)
        for shift in (-2 * np.pi, 0.0, 2 * np.pi):  # angles wrap around
            d, j = tree.query(np.stack([h[idx], (th[idx] + shift) * scale], 1),
                              distance_upper_bound=0.03)  # fmt: skip
            ok = np.isfinite(d)
            best[ok] = np.maximum(best[ok], r_t[j[ok]])
        need = np.where(np.isfinite(best), best + OVERLAP_MARGIN_M - r[idx], 0.0)
        if not (need > 0).any():
            continue
        # one sideways shift per height row (rows move rigidly: no fold), growing upwards
        lo = frame.height(body.landmarks[key]) - 0.03
        rows = np.floor((h - lo) / ROW_M).astype(int)
        lift = np.zeros(rows.max() + 2)
        np.maximum.at(lift, rows[idx], np.maximum(need, 0.0))
        lift = np.maximum.accumulate(_dilate(lift, 2))
        hole = f"armhole_{side}"
        centre = body.point(hole) if hole in body.feature_lines else x.mean(axis=0)
        d = centre - frame.origin
        d = d - (d @ frame.a) * frame.a
        d = d / max(np.linalg.norm(d), 1e-9)
        ramp = np.clip((h - lo) / 0.03, 0.0, 1.0)
        shift = lift[np.clip(rows, 0, len(lift) - 1)] * ramp * (h >= lo)
        x = x + shift[:, None] * d[None, :] * 1.2
        x, _ = body.push_out(x, _clearance_m(pattern.panels[name]))
        out[name] = x


# --- wrapping -------------------------------------------------------------------------
def _wrap(body: PlacementBody, frame: BodyFrame, theta: float, s, h, clearance: float,
          before: float, after: float) -> np.ndarray:  # fmt: skip
    # rows on a fixed grid of heights (shared by all panels: the curves are cached)
    first, last = math.floor(float(h.min()) / ROW_M), math.ceil(float(h.max()) / ROW_M)
    last = max(last, first + 1)
    rows = ROW_M * np.arange(first, last + 1)
    nb, lo, step = len(rows), float(rows[0]), ROW_M
    # the panel's width either side of the anchor line, per row
    k = np.clip(np.rint((h - lo) / step).astype(int), 0, nb - 1)
    need_after = np.full(nb, -np.inf)
    need_before = np.full(nb, -np.inf)
    np.maximum.at(need_after, k, s)
    np.maximum.at(need_before, k, -s)
    for arr in (need_after, need_before):  # rows without a vertex: their neighbours
        good = np.isfinite(arr)
        arr[~good] = np.interp(rows[~good], rows[good], arr[good])
    need_after = _dilate(need_after * FIT_MARGIN, 2)
    need_before = _dilate(need_before * FIT_MARGIN, 2)
    curves, extras = [], np.zeros(nb)
    for j, hr in enumerate(rows):
        c = body.curve(frame, hr, clearance)
        extra = 0.0
        for _ in range(3):  # grow the offset until the row fits its sector
            s0 = c.arc_at_angle(theta)
            room_after = np.mod(c.arc_at_angle(theta + after) - s0, c.length)
            room_before = np.mod(s0 - c.arc_at_angle(theta - before), c.length)
            short = max(need_after[j] - room_after, need_before[j] - room_before)
            if short <= 1e-4:
                break
            extra += short / max(min(before, after), 0.2)
            c = body.curve(frame, hr, clearance + extra)
        curves.append(c)
        extras[j] = extra
    # below a wide row, no row falls back towards the body faster than MAX_OFFSET_SLOPE
    drop = rows[None, :] - rows[:, None]  # [j, k]: how far row k is above row j
    envelope = np.max(np.where(drop >= 0, extras[None, :] - MAX_OFFSET_SLOPE * drop, 0.0), axis=1)
    for j in np.nonzero(envelope > extras + 1e-4)[0]:
        curves[j] = body.curve(frame, rows[j], clearance + envelope[j])
    curves = _hang(curves)
    starts = [c.arc_at_angle(theta) for c in curves]
    f = np.clip((h - lo) / step, 0, nb - 1)
    k0 = np.minimum(np.floor(f).astype(int), nb - 2)
    w = (f - k0)[:, None]
    uw = np.zeros((len(h), 2))
    for j in np.unique(np.concatenate([k0, k0 + 1])):
        for sel, wt in ((k0 == j, 1.0 - w), (k0 + 1 == j, w)):
            if sel.any():
                uw[sel] += wt[sel] * curves[j].point_at_arc(starts[j] + s[sel])
    return frame.world(h, uw)


def _hang(curves: list[_Curve]) -> list[_Curve]:
    """Rows (bottom to top) whose curve comes in faster than :data:`SHRINK_SLOPE` below the
    rows above it, in any direction, pushed out to that slope (star-shaped polygons)."""
    phi = np.linspace(-math.pi, math.pi, RADIAL_SAMPLES, endpoint=False)
    ray = np.stack([np.cos(phi), np.sin(phi)], 1)
    radius = np.array([[float(np.linalg.norm(c.point_at_arc(np.array([c.arc_at_angle(a)]))[0]))
                        for a in phi] for c in curves])  # fmt: skip
    hung = radius.copy()
    for j in range(len(curves) - 2, -1, -1):
        hung[j] = np.maximum(radius[j], hung[j + 1] - SHRINK_SLOPE * ROW_M)
    out = list(curves)
    for j in np.nonzero((hung > radius + 1e-4).any(axis=1))[0]:
        out[j] = _Curve(hung[j][:, None] * ray)
    return out


def _flat(body: PlacementBody, frame: BodyFrame, theta: float, s, h, clearance: float):
    n2 = np.array([math.cos(theta), math.sin(theta)])
    hs, uw, band = body._part_data(frame)
    sel = (hs >= h.min() - band) & (hs <= h.max() + band)
    pts = uw[sel] if sel.sum() >= 3 else uw
    dist = float((pts @ n2).max()) + clearance
    t2 = np.array([-n2[1], n2[0]])  # direction of increasing angle
    plane = dist * n2[None, :] + s[:, None] * t2[None, :]
    return frame.world(h, plane)


# --- helpers --------------------------------------------------------------------------
def _limb_masks(mannequin, v: np.ndarray, lm: dict) -> dict[str, np.ndarray]:
    """Vertex masks of the arms and legs: from the template's grids, else by geometry."""
    n = len(v)
    masks = {k: np.zeros(n, bool) for k in ("arm_left", "arm_right", "leg_left", "leg_right")}
    try:
        from sandbox.mannequin.model import _structure

        res = getattr(mannequin, "resolution", None)
        t = _structure(res).template if res else None
    except Exception:  # noqa: BLE001 - any failure: fall back to geometry
        t = None
    if t is not None and t.n_vertices == n:
        grids = {"arm_left": t.arm_l_grid, "arm_right": t.arm_r_grid,
                 "leg_left": t.leg_l_grid, "leg_right": t.leg_r_grid}  # fmt: skip
        caps = dict(zip(("yoke", "arm_left", "arm_right", "leg_left", "leg_right"), t.caps,
                        strict=False))  # fmt: skip
        for k, g in grids.items():
            masks[k][np.asarray(g[1:]).ravel()] = True
            if k in caps:
                masks[k][np.asarray(caps[k][1])] = True
        return masks
    if "underarm_point_left" in lm and "shoulder_point_left" in lm:
        xa = abs(float(lm["underarm_point_left"][0])) + 0.005
        ya = float(lm["shoulder_point_left"][1])
        masks["arm_left"] = (v[:, 0] > xa) & (v[:, 1] < ya)
        masks["arm_right"] = (v[:, 0] < -xa) & (v[:, 1] < ya)
    if "crotch_point" in lm:
        yc = float(lm["crotch_point"][1])
        arms = masks["arm_left"] | masks["arm_right"]
        masks["leg_left"] = (v[:, 1] < yc) & (v[:, 0] > 0) & ~arms
        masks["leg_right"] = (v[:, 1] < yc) & (v[:, 0] < 0) & ~arms
    return masks


def _hull_points(p2: np.ndarray) -> np.ndarray:
    """Counter-clockwise convex hull polygon (k, 2) of 2D points."""
    try:
        return p2[ConvexHull(p2).vertices]
    except QhullError:
        lo, hi = p2.min(0) - 1e-3, p2.max(0) + 1e-3
        return np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])


def _hull_centroid(p2: np.ndarray) -> np.ndarray:
    poly = _hull_points(p2)
    x, y = poly[:, 0], poly[:, 1]
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    cross = x * y1 - x1 * y
    area = cross.sum() / 2
    if abs(area) < 1e-12:
        return p2.mean(axis=0)
    return np.array([((x + x1) * cross).sum(), ((y + y1) * cross).sum()]) / (6 * area)


def _dilate(a: np.ndarray, r: int) -> np.ndarray:
    out = a.copy()
    for k in range(1, r + 1):
        out[k:] = np.maximum(out[k:], a[:-k])
        out[:-k] = np.maximum(out[:-k], a[k:])
    return out


def _unit(v) -> np.ndarray:
    v = np.asarray(v, float)
    n = np.linalg.norm(v)
    if n < 1e-12:
        raise SandboxError("placement: degenerate body axis")
    return v / n


def _wrap_pi(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi
