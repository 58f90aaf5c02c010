"""Body queries for the contact measures: distance, inside/outside and signed distance of
points against a body mesh, how deep cloth sits inside it, and body vertices showing through
the cloth.

The queries run on Open3D's ``RaycastingScene`` (Embree BVH, float32): distances from
``compute_distance``; inside/outside from the *winding number along rays*: every ray
crossing is signed by the face normal and summed, and a point is inside if the sum is at
least one, by majority over five fixed ray directions. Unlike ray parity
(``compute_occupancy``, trimesh ``contains``) this stays right where a closed body overlaps
itself, e.g. one assembled from overlapping parts (the union is inside); on a body without
self-intersections (the project's mannequin) both agree. See ``docs/collision_metrics.md``.
"""

from __future__ import annotations

import numpy as np

from sandbox.collision.mesh_checks import edge_report, mesh_arrays, points_array
from sandbox.errors import SandboxError

RAY_MERGE_REL = 1e-6  # ray hits closer than this x body bbox diagonal are one crossing

# Fixed ray directions for the winding-number vote: no component near 0 or equal to another,
# so no ray runs along an axis, a coordinate plane or a diagonal of a lattice.
_RAY_DIRECTIONS = np.array(
    [
        [0.4313, 0.6129, 0.6620],
        [-0.7189, 0.2943, 0.6297],
        [0.5407, -0.7822, 0.3093],
        [-0.3366, -0.4527, -0.8257],
        [0.8138, 0.2286, -0.5343],
    ]
)
_RAY_DIRECTIONS /= np.linalg.norm(_RAY_DIRECTIONS, axis=1, keepdims=True)


class BodyProbe:
    """Distance, inside/outside and signed distance of points against a body mesh.

    Build with :func:`body_inside_check`. ``distance`` works on any triangle mesh;
    ``inside`` and ``signed_distance`` need a closed mesh (every edge shared by exactly two
    triangles walking it in opposite directions) and raise :class:`SandboxError` otherwise.

    Attributes: ``name``, ``vertices`` (m, 3) float64, ``triangles`` (k, 3) int64,
    ``closed`` (bool), ``problems`` (:func:`edge_report`), ``inward`` (the faces pointed
    inwards and were taken reversed; the inside test does not depend on it).
    """

    def __init__(self, vertices, triangles, *, name: str = "body"):
        import open3d as o3d  # heavy import, only where a body is probed

        what = f"body {name!r}"
        v, t = mesh_arrays(vertices, triangles, what)
        if len(t) == 0:
            raise SandboxError(f"{what}: the mesh has no triangles")
        self.name = name
        self.vertices = v
        self.triangles = t
        self.problems = edge_report(t, len(v))
        self.closed = not any(self.problems.values())
        used = v[np.unique(t)]
        lo, hi = used.min(0), used.max(0)
        self._center = 0.5 * (lo + hi)  # float32 precision is relative to this
        self._size = float(np.linalg.norm(hi - lo)) or 1.0
        a, b, c = (v[t[:, k]] - self._center for k in range(3))
        normal = np.cross(b - a, c - a)
        self.inward = bool(np.einsum("ij,ij->", a, normal) < 0)  # 6 x signed volume
        self._normal = -normal if self.inward else normal  # outward, not normalised
        self._o3d = o3d
        self._scene = o3d.t.geometry.RaycastingScene()
        self._scene.add_triangles(
            o3d.core.Tensor(np.ascontiguousarray(v - self._center, dtype=np.float32)),
            o3d.core.Tensor(np.ascontiguousarray(t, dtype=np.uint32)),
        )

    def __repr__(self) -> str:
        state = "closed" if self.closed else "open"
        return f"BodyProbe({self.name!r}, {len(self.triangles)} triangles, {state})"

    def _query(self, points) -> np.ndarray:
        p = points_array(points, f"body {self.name!r}")
        return np.ascontiguousarray(p - self._center, dtype=np.float32)

    def _require_closed(self) -> None:
        if self.closed:
            return
        labels = {
            "boundary_edges": "boundary edges (used by one triangle)",
            "nonmanifold_edges": "non-manifold edges (used by more than two triangles)",
            "misoriented_edges": "inconsistently oriented edges",
            "degenerate_triangles": "triangles with a repeated vertex",
        }
        found = ", ".join(f"{n} {labels[k]}" for k, n in self.problems.items() if n)
        raise SandboxError(
            f"body {self.name!r}: the inside test needs a closed mesh (every edge shared by "
            f"exactly two consistently oriented triangles), but this one has {found}; "
            "distance() still works on it"
        )

    def distance(self, points) -> np.ndarray:
        """Unsigned distance [m] from each point to the nearest body triangle, (n,) float64.

        Works on open meshes too. Accuracy: float32 on coordinates relative to the body's
        centre, about 1e-7 of the body size.
        """
        q = self._query(points)
        if len(q) == 0:
            return np.zeros(0)
        d = self._scene.compute_distance(self._o3d.core.Tensor(q)).numpy()
        return d.astype(np.float64)

    def inside(self, points) -> np.ndarray:
        """True where a point is inside the closed body, (n,) bool.

        Winding number along rays: crossings signed by the outward normal (+1 leaving),
        hits closer than 1e-6 body diagonals merged into one (a ray through an edge or a
        vertex), inside if the sum is >= 1; majority vote of five fixed directions. Points
        on the surface (closer than float32 precision) may go either way.
        """
        self._require_closed()
        q = self._query(points)
        n = len(q)
        if n == 0:
            return np.zeros(0, bool)
        merge = RAY_MERGE_REL * self._size
        votes = np.zeros(n, np.int64)
        for d in _RAY_DIRECTIONS:
            rays = np.empty((n, 6), np.float32)
            rays[:, :3] = q
            rays[:, 3:] = d
            hits = self._scene.list_intersections(self._o3d.core.Tensor(rays))
            ray = hits["ray_ids"].numpy().astype(np.int64)
            if len(ray) == 0:
                continue
            t_hit = hits["t_hit"].numpy().astype(np.float64)
            prim = hits["primitive_ids"].numpy().astype(np.int64)
            sign = np.sign(self._normal[prim] @ d)
            order = np.lexsort((t_hit, ray))
            ray, t_hit, sign = ray[order], t_hit[order], sign[order]
            new = np.ones(len(ray), bool)
            new[1:] = (ray[1:] != ray[:-1]) | (t_hit[1:] - t_hit[:-1] > merge)
            cluster = np.cumsum(new) - 1
            crossing = np.sign(np.bincount(cluster, weights=sign))
            winding = np.bincount(ray[new], weights=crossing, minlength=n)
            votes += winding > 0.5
        return votes > len(_RAY_DIRECTIONS) // 2

    def signed_distance(self, points) -> np.ndarray:
        """Distance to the nearest body triangle [m], negative inside, (n,) float64."""
        self._require_closed()
        d = self.distance(points)
        return np.where(self.inside(points), -d, d)


def body_inside_check(body_vertices, body_triangles, *, name: str = "body") -> BodyProbe:
    """Check a body mesh and return a :class:`BodyProbe` for point queries.

    Args:
        body_vertices: (m, 3) positions [m]. body_triangles: (k, 3) vertex indices.
        name: used in error messages.

    Malformed input (shapes, indices, NaN, no triangles) raises :class:`SandboxError` at
    once. A mesh that is not closed is accepted: ``probe.closed`` is False,
    ``probe.problems`` says why, ``probe.distance`` works, and ``inside`` /
    ``signed_distance`` raise :class:`SandboxError` naming the boundary, non-manifold and
    misoriented edge counts.
    """
    return BodyProbe(body_vertices, body_triangles, name=name)


def penetration_metrics(cloth_vertices, probe: BodyProbe, *, tolerance_m: float = 0.0) -> dict:
    """How deep cloth vertices sit inside the body.

    Returns ``{"penetration_max_m": float, "vertices_inside_body": int}``: the largest depth
    (distance to the body surface) of a vertex inside the body, 0.0 if none is inside; and
    the number of vertices deeper than ``tolerance_m``. Raises :class:`SandboxError` if the
    body is not closed or the tolerance is negative.
    """
    if not np.isfinite(tolerance_m) or tolerance_m < 0:
        raise SandboxError(f"penetration tolerance_m must be >= 0, got {tolerance_m}")
    sd = probe.signed_distance(points_array(cloth_vertices, "cloth vertices"))
    depth = -sd
    return {
        "penetration_max_m": float(max(0.0, depth.max())) if len(depth) else 0.0,
        "vertices_inside_body": int(np.sum(depth > tolerance_m)),
    }


def vertex_normals(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals (n, 3) of a closed mesh, pointing outwards whatever
    the winding (the sign of the enclosed volume decides); 0 for unused vertices."""
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    centre = vertices[np.unique(triangles)].mean(axis=0)
    face = np.cross(b - a, c - a)  # twice the area, along the face normal
    if np.einsum("ij,ij->", a - centre, face) < 0:  # wound inwards
        face = -face
    n = np.zeros_like(vertices)
    for k in range(3):
        np.add.at(n, triangles[:, k], face)
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, length, out=np.zeros_like(n), where=length > 0)


def through_cloth_depth(
    cloth_vertices,
    cloth_triangles,
    body_vertices,
    body_triangles,
    *,
    reach_in_m: float = 0.02,
    reach_out_m: float = 0.05,
) -> np.ndarray:
    """How far each body vertex shows through the cloth [m], (m,) float64; 0 where it does not.

    For each body vertex p with outward normal n (area-weighted), two rays against the cloth
    triangles: inwards (p − s n) and outwards (p + s n). If the inward ray meets the cloth
    within ``reach_in_m`` [m] and the outward ray meets none within ``reach_out_m`` [m], the
    cloth passes *under* the body surface there and nothing covers it: the body shows
    through, by the depth s of the inward hit. A coarse triangle spanning a bust point while
    its corners stay outside is the typical case; cloth vertices inside the body
    (:func:`penetration_metrics`) do not see it. Body vertices away from the cloth (bare
    arms, the head) meet no cloth either way and are 0. Open3D ``RaycastingScene`` (float32,
    coordinates relative to the cloth's centre: about 0.1 µm on a garment).
    """
    import open3d as o3d  # heavy import, only where a body is probed

    cv, ct = mesh_arrays(cloth_vertices, cloth_triangles, "cloth")
    bv, bt = mesh_arrays(body_vertices, body_triangles, "body")
    out = np.zeros(len(bv))
    if len(ct) == 0 or len(bt) == 0 or not np.all(np.isfinite(cv)):
        return out
    reach = max(reach_in_m, reach_out_m)
    lo, hi = cv.min(axis=0) - reach, cv.max(axis=0) + reach
    normals = vertex_normals(bv, bt)
    near = np.all((bv >= lo) & (bv <= hi), axis=1) & np.any(normals != 0.0, axis=1)
    if not near.any():
        return out
    centre = 0.5 * (lo + hi)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(np.ascontiguousarray(cv - centre, dtype=np.float32)),
                        o3d.core.Tensor(np.ascontiguousarray(ct, dtype=np.uint32)))  # fmt: skip
    origin, n = bv[near] - centre, normals[near]

    def first_hit(direction: np.ndarray) -> np.ndarray:
        rays = np.ascontiguousarray(np.hstack([origin, direction]), dtype=np.float32)
        return scene.cast_rays(o3d.core.Tensor(rays))["t_hit"].numpy().astype(np.float64)

    depth = first_hit(-n)
    shows = (depth <= reach_in_m) & ~(first_hit(n) <= reach_out_m)
    out[np.nonzero(near)[0][shows]] = depth[shows]
    return out


def body_through_cloth(cloth_vertices, cloth_triangles, body_vertices, body_triangles, *,
                       tolerance_m: float = 0.0) -> dict:  # fmt: skip
    """Body surface showing through the cloth where the cloth covers it
    (:func:`through_cloth_depth`): ``{"body_through_cloth_vertices": int,
    "body_through_cloth_max_m": float}``, the body vertices showing through by more than
    ``tolerance_m`` [m] and the largest depth [m] (0.0 if none)."""
    depth = through_cloth_depth(cloth_vertices, cloth_triangles, body_vertices, body_triangles)
    return {
        "body_through_cloth_vertices": int(np.sum(depth > tolerance_m)),
        "body_through_cloth_max_m": float(depth.max()) if len(depth) else 0.0,
    }


def follow_body(points, body_vertices, body_triangles, new_body_vertices) -> np.ndarray:
    """Points (n, 3) [m] carried along with a body that changes shape but not structure.

    Each point moves by the displacement of its closest point on the body: the same face and
    barycentric coordinates on ``new_body_vertices`` (m, 3) as on ``body_vertices``. Cloth
    resting on a mannequin that is resized keeps its place on it instead of ending inside
    the grown body (where contact, which only keeps cloth from entering, cannot free it).
    """
    import open3d as o3d

    p = np.asarray(points, np.float64)
    v0 = np.asarray(body_vertices, np.float64)
    v1 = np.asarray(new_body_vertices, np.float64)
    t = np.asarray(body_triangles, np.int64)
    if v0.shape != v1.shape:
        raise SandboxError("follow_body: the new body has another number of vertices")
    if not len(p):
        return p.copy()
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(v0.astype(np.float32)),
                        o3d.core.Tensor(t.astype(np.uint32)))  # fmt: skip
    ans = scene.compute_closest_points(o3d.core.Tensor(p.astype(np.float32)))
    face = ans["primitive_ids"].numpy().astype(np.int64)
    uv = ans["primitive_uvs"].numpy().astype(np.float64)
    w = np.column_stack([1.0 - uv[:, 0] - uv[:, 1], uv[:, 0], uv[:, 1]])
    corners = t[face]
    move = np.einsum("nk,nkx->nx", w, v1[corners] - v0[corners])
    return p + move
