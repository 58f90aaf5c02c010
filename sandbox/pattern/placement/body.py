"""A mannequin prepared for placement: body-part axes, section hulls and the push-out."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from sandbox.errors import SandboxError
from sandbox.pattern.placement.config import DEFAULT_PLACEMENT, PlacementConfig
from sandbox.pattern.spec import BODIES

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


class Curve:
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
        return float(self.arcs_at_angles(np.array([theta], float))[0])

    def arcs_at_angles(self, theta: np.ndarray) -> np.ndarray:
        """:meth:`arc_at_angle` for an array of angles (k,) [rad]: arc lengths (k,) [m]."""
        theta = np.asarray(theta, float)
        t = self.phi[0] + np.fmod(theta - self.phi[0], 2 * np.pi)
        t = np.where(t < self.phi[0], t + 2 * np.pi, t)
        j = np.clip(np.searchsorted(self.phi, t, side="right") - 1, 0, len(self.p) - 1)
        r0, r1 = np.cos(theta), np.sin(theta)
        p, d = self.p[j], self.d[j]
        den = r0 * d[:, 1] - r1 * d[:, 0]
        flat = np.abs(den) < 1e-15
        u = np.where(flat, 0.0, -(r0 * p[:, 1] - r1 * p[:, 0]) / np.where(flat, 1.0, den))
        return self.s[j] + np.clip(u, 0.0, 1.0) * self.seg[j]

    def point_at_arc(self, s: np.ndarray) -> np.ndarray:
        s = np.mod(np.asarray(s, float), self.length)
        j = np.clip(np.searchsorted(self.s, s, side="right") - 1, 0, len(self.p) - 1)
        t = (s - self.s[j]) / np.maximum(self.seg[j], 1e-15)
        return self.p[j] + t[:, None] * self.d[j]


class PlacementBody:
    """A mannequin prepared for placement: part masks, axes, section hulls, push-out.

    ``mannequin`` needs ``vertices`` (n, 3) [m], ``triangles`` (m, 3), ``landmarks`` (name
    -> (3,) [m]) and optionally ``feature_lines`` (name -> (k, 3) [m]). ``config`` holds
    the settings of the section hulls and the push-out (and, unless a placement is given
    another, of the panels placed on this body).
    """

    def __init__(self, mannequin, config: PlacementConfig = DEFAULT_PLACEMENT):
        if isinstance(mannequin, PlacementBody):
            raise SandboxError("PlacementBody: already prepared")
        self.config = config
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
    def part_data(self, frame: BodyFrame):
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
        hs, uw, band = self.part_data(frame)
        h = float(np.clip(h, hs[0], hs[-1]))
        i0, i1 = np.searchsorted(hs, [h - band, h + band])
        if i1 - i0 < 3:  # outside the part: the nearest few vertices
            k = np.argsort(np.abs(hs - h))[:16]
            return uw[k]
        return uw[i0:i1]

    def curve(self, frame: BodyFrame, h: float, offset_m: float) -> Curve:
        """The section hull at height h offset by ``offset_m``, containing the axis."""
        key = (frame.body, tuple(np.round(frame.origin, 6)), round(h, 6), round(offset_m, 6))
        if key not in self._curves:
            if len(self._curves) > 20000:
                self._curves.clear()
            self._curves[key] = self._curve(frame, h, offset_m)
        return self._curves[key]

    def _curve(self, frame: BodyFrame, h: float, offset_m: float) -> Curve:
        pts = self.section_points(frame, h)
        ring = np.linspace(0, 2 * np.pi, self.config.offset_directions, endpoint=False)
        disc = np.stack([np.cos(ring), np.sin(ring)], 1)
        hull = _hull_points(np.vstack([pts, 0.005 * disc]))
        # the polygon of samples of the disc lies inside the disc: scale up so that the
        # sampled offset curve is at least ``offset_m`` away everywhere
        r = offset_m / math.cos(math.pi / self.config.offset_directions)
        grown = (hull[:, None, :] + r * disc[None]).reshape(-1, 2)
        return Curve(_hull_points(grown))

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

    def distance(self, x: np.ndarray) -> np.ndarray:
        """Unsigned distance (n,) [m] from points ``x`` (n, 3) [m] to the body's surface."""
        import open3d as o3d

        x = np.asarray(x, np.float32).reshape(-1, 3)
        return self._raycasting().compute_distance(o3d.core.Tensor(x)).numpy().astype(float)

    def push_out(self, x: np.ndarray, clearance_m: float) -> tuple[np.ndarray, int]:
        """Move points closer to the body than ``clearance_m`` out to that distance.

        Returns the new points (n, 3) and how many were moved.
        """
        import open3d as o3d

        self._raycasting()
        x = np.array(x, float)
        moved = np.zeros(len(x), bool)
        target = clearance_m * 1.02
        for _ in range(self.config.push_iterations):
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
    if t is not None and (t.n_vertices == n or getattr(mannequin, "head_length_cm", None)):
        # (a head's vertices follow the template's: torso)
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
