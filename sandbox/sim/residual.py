"""The equilibrium residual: how far a state is from rest, as a force, whatever the solver.

A stop rule on displacement can be fooled: heavy damping slows the cloth down before it
reaches rest. The residual cannot: at rest every free vertex's net force is zero, up to what
contact can carry. Here it is measured per free vertex i, in units of its own weight:

    f_i = elastic (Eq. 6-8 membrane, Eq. 7-8 bending) + seam springs + m_i g   (no damping)
          + the thread's pull at a stitch held at its limit (:func:`thread_tension`)
    r_i = |f_i|                                  away from the body
    r_i = max(0, |f_t| − μ_s |f_n|)              within reach of the body and f_i·n < 0

where n is the outward normal of the nearest body face within reach, f_n = f_i·n (pushing
the vertex into the body, which the body's reaction cancels) and f_t the rest of f_i
(which static friction holds up to μ_s |f_n|: Coulomb's cone, Bridson et al. 2002). In a
concave crease (an armpit) the vertex leans on two faces, and the reaction may be any
non-negative combination of their normals. Where the body's vertices hold the cloth's
triangles up (the face pass, ``[collision] body_faces``), a corner of a triangle resting on
a body vertex leans on the triangle's plane as well (:func:`face_support_normals`).
``r_i / (m_i |g|)``
is 1 for a vertex in free fall and 0 at rest. Cloth-on-cloth contact is not modelled as a
support: a vertex resting on another layer shows its share of that layer's reaction.
"""

import weakref

import numpy as np
import taichi as ti

CONTACT_REACH = 2.0
"""A vertex within this many contact thicknesses of the body can lean on it."""


def contact_normals(collider, x: np.ndarray, reach_m: float):
    """The body planes each point leans on: ``(count (n,), n1 (n, 3), n2 (n, 3))`` from the
    collider's own query (:meth:`~sandbox.collision.body.BodyCollider.contact_planes`: the
    nearest face within ``reach_m`` [m] and, in a concave crease, a second one)."""
    x = np.ascontiguousarray(x, np.float64)
    out = np.zeros((len(x), 7), np.float64)
    if len(x):
        _planes_kernel(collider, x, float(reach_m), out)
    return out[:, 0].astype(np.int64), out[:, 1:4], out[:, 4:7]


@ti.kernel
def _planes_kernel(body: ti.template(), x: ti.types.ndarray(), reach: float,
                   out: ti.types.ndarray()):  # fmt: skip
    for i in range(x.shape[0]):
        p = ti.Vector([x[i, 0], x[i, 1], x[i, 2]])
        count, n1, _, n2, _ = body.contact_planes(p, reach, reach)
        out[i, 0] = count
        for k in ti.static(range(3)):
            out[i, 1 + k] = n1[k]
            out[i, 4 + k] = n2[k]


def face_support_normals(
    x: np.ndarray, triangles: np.ndarray, body_v: np.ndarray, body_n: np.ndarray, reach_m: float
) -> np.ndarray:
    """Per cloth vertex, the mean outward normal (n, 3) of its triangles that rest on a body
    vertex (zero where none does).

    A triangle rests on body vertex p when p's projection along the triangle's normal n
    (turned to p's outward vertex normal ``body_n``) falls inside it and p lies at most
    ``reach_m`` [m] below it (s = (p − a)·n > −reach, and not deeper than a quarter of the
    longest edge, as in :meth:`~sandbox.collision.body.BodyCollider.poke`). ``x``: (n, 3)
    cloth positions [m]; ``triangles``: (k, 3); ``body_v``, ``body_n``: (m, 3).
    """
    from scipy.spatial import cKDTree

    out = np.zeros_like(x)
    t = np.asarray(triangles, np.int64)
    if not len(t) or not len(body_v):
        return out
    a, b, c = x[t[:, 0]], x[t[:, 1]], x[t[:, 2]]
    nc = np.cross(b - a, c - a)
    area2 = np.linalg.norm(nc, axis=1)
    longest = np.max(np.linalg.norm(np.stack([b - a, c - b, a - c]), axis=2), axis=0)
    centre = (a + b + c) / 3.0
    radius = np.max(np.linalg.norm(np.stack([a, b, c]) - centre, axis=2), axis=0) + reach_m
    near = cKDTree(body_v).query_ball_point(centre, radius)
    count = np.fromiter((len(v) for v in near), np.int64, len(near))
    if not count.sum():
        return out
    tri = np.repeat(np.arange(len(t)), count)
    vid = np.concatenate([np.asarray(v, np.int64) for v in near if v])
    ok = area2[tri] > 1e-12 * longest[tri] ** 2
    tri, vid = tri[ok], vid[ok]
    n = nc[tri] / area2[tri, None]
    n *= np.where(np.einsum("ij,ij->i", n, body_n[vid]) < 0.0, -1.0, 1.0)[:, None]
    p = body_v[vid]
    s = np.einsum("ij,ij->i", p - a[tri], n)
    q = p - s[:, None] * n
    # barycentric weights of q in (a, b, c)
    e0, e1, e2 = b[tri] - a[tri], c[tri] - a[tri], q - a[tri]
    d00, d01, d11 = (np.einsum("ij,ij->i", u, w) for u, w in ((e0, e0), (e0, e1), (e1, e1)))
    d20, d21 = np.einsum("ij,ij->i", e2, e0), np.einsum("ij,ij->i", e2, e1)
    den = d00 * d11 - d01 * d01
    w1 = (d11 * d20 - d01 * d21) / den
    w2 = (d00 * d21 - d01 * d20) / den
    rest = (s > -reach_m) & (s < 0.25 * longest[tri]) & (w1 > 0) & (w2 > 0) & (w1 + w2 < 1)
    for k in range(3):
        np.add.at(out, t[tri[rest], k], n[rest])
    length = np.linalg.norm(out, axis=1, keepdims=True)
    return np.where(length > 0, out / np.maximum(length, 1e-300), 0.0)


def _supported(f: np.ndarray, n1: np.ndarray, n2: np.ndarray, count: np.ndarray, mu: float):
    """What is left of forces f (n, 3) once the planes (normals n1, n2; ``count`` of them,
    0-2) push back and static friction holds: min over the planes' active sets of
    max(0, |f + N| − μ|N|), N ≥ 0 along the active normals (the normal reaction cancels the
    part of f pressing into them)."""
    best = np.linalg.norm(f, axis=1)
    for normals, planes in (((n1,), 1), ((n2,), 2), ((n1, n2), 2)):
        if len(normals) == 1:
            n = normals[0]
            lam = -np.einsum("ij,ij->i", f, n)
            ok = lam > 0.0
            reaction = lam[:, None] * n
            load = lam
        else:
            g11 = np.einsum("ij,ij->i", n1, n1)
            g12 = np.einsum("ij,ij->i", n1, n2)
            g22 = np.einsum("ij,ij->i", n2, n2)
            b1, b2 = -np.einsum("ij,ij->i", f, n1), -np.einsum("ij,ij->i", f, n2)
            det = g11 * g22 - g12 * g12
            safe = np.where(np.abs(det) > 1e-9, det, 1.0)
            l1 = (b1 * g22 - b2 * g12) / safe
            l2 = (g11 * b2 - g12 * b1) / safe
            ok = (np.abs(det) > 1e-9) & (l1 > 0.0) & (l2 > 0.0) & (count >= 2)
            reaction = l1[:, None] * n1 + l2[:, None] * n2
            load = np.linalg.norm(reaction, axis=1)
        ok &= count >= planes
        left = np.maximum(0.0, np.linalg.norm(f + reaction, axis=1) - mu * load)
        best = np.where(ok, np.minimum(best, left), best)
    return best


def thread_tension(model, x: np.ndarray, f: np.ndarray) -> np.ndarray:
    """The forces ``f`` (n, 3) [N] with the thread's pull added at each stitch the seam hold
    keeps at its limit (``model.seam_limit``, :meth:`~sandbox.sim.solver.
    SymplecticEulerSolver._seam_hold`): at such a stitch the thread pulls its two sides
    together with whatever tension t >= 0 the cloth asks, as the body pushes back on cloth
    pressing into it. For a stitch a–q (q = Σ c_k x_k, one point or a point between two of
    the other side's, as in :func:`~sandbox.sim.seams.seam_openings`) along n = (x_a − q) /
    |x_a − q|, the thread adds −t n to f_a and c_k t n to f_k, with the t that leaves the
    least net force: t = max(0, (f_a − Σ c_k f_k)·n / (1 + Σ c_k²)). A stitch counts as at
    its limit (``model.seam_limit``) beyond 0.9 of it. Returns a new array."""
    f = np.array(f, np.float64)
    hold = float(model.seam_hold_m[None]) if model.has_seams else 0.0
    if hold <= 0.0 or model.seam_pairs_np is None:
        return f
    from sandbox.sim.seams import partner_points, seam_openings

    pairs, rest = model.seam_pairs_np, model.seam_rest_np
    limit = model.seam_limit.to_numpy()[: len(pairs)]
    gap = seam_openings(pairs, rest, x)
    a, b = pairs[:, 0], pairs[:, 1]
    twin, second, b2, w = partner_points(pairs, rest)
    c1, c2 = 1.0 - w, w
    held = (limit >= 0) & ~second & (gap > 0.9 * limit)
    held &= ~((rest > 0) & ~twin)  # a spring with a rest length: its stretch, not a point
    q = c1[:, None] * x[b] + c2[:, None] * x[b2]
    d = x[a] - q
    n = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300)
    pull = (np.einsum("ij,ij->i", f[a], n) - c1 * np.einsum("ij,ij->i", f[b], n)
            - c2 * np.einsum("ij,ij->i", f[b2], n))  # fmt: skip
    t = np.where(held, np.maximum(0.0, pull / (1.0 + c1**2 + c2**2)), 0.0)
    np.add.at(f, a, -t[:, None] * n)
    np.add.at(f, b, (c1 * t)[:, None] * n)
    np.add.at(f, b2, (c2 * t)[:, None] * n)
    return f


def equilibrium_residual(model, x: np.ndarray, forces: np.ndarray, gravity) -> dict:
    """The residual of a state, per free vertex, over its weight (module docstring).

    Args:
        model: the Model (masses, pinned particles, body colliders with their thickness
            and static friction μ_s).
        x: (n, 3) positions [m]; ``forces``: (n, 3) the undamped forces at ``x`` with gravity
            [N] (``SymplecticEulerSolver.static_forces``); ``gravity``: (3,) [m/s^2].
    Returns ``{"residual_max_over_weight", "residual_mean_over_weight",
    "residual_p99_over_weight", "residual_argmax", "residual_contact_vertices"}``.
    """
    x = np.asarray(x, np.float64)
    f = thread_tension(model, x, forces)
    mass = model.particle_mass.to_numpy()[: len(x)].astype(np.float64)
    free = model.particle_inv_mass.to_numpy()[: len(x)] > 0
    g = float(np.linalg.norm(gravity))
    r = np.linalg.norm(f, axis=1)
    touching = np.zeros(len(x), bool)
    for c in model.colliders:
        # a crease's thickness (BodyCollider.follow_cloth) holds cloth further out
        reach = CONTACT_REACH * float(c.thickness[None]) + float(c.extra_max[None])
        count, n1, n2 = contact_normals(c, x, reach)
        if getattr(c, "face_pass", False) and model.tri_count:
            nf = face_support_normals(x, model.tri_indices_np, c.body_x.to_numpy(),
                                      c.vertex_normal.to_numpy(), reach)  # fmt: skip
            held = np.linalg.norm(nf, axis=1) > 0
            first = held & (count == 0)
            second = held & (count == 1)
            n1 = np.where(first[:, None], nf, n1)
            n2 = np.where(second[:, None], nf, n2)
            count = np.where(first | second, count + 1, count)
        left = _supported(f, n1, n2, count, float(c.mu_s[None]))
        touching |= left < r
        r = np.minimum(r, left)
    weight = mass * g if g > 0 else np.ones_like(mass)
    ratio = np.where(free, r / np.maximum(weight, 1e-300), 0.0)
    sel = ratio[free]
    if not len(sel):
        return {"residual_max_over_weight": 0.0, "residual_mean_over_weight": 0.0,
                "residual_p99_over_weight": 0.0, "residual_argmax": None,
                "residual_contact_vertices": 0}  # fmt: skip
    return {
        "residual_max_over_weight": float(sel.max()),
        "residual_mean_over_weight": float(sel.mean()),
        "residual_p99_over_weight": float(np.percentile(sel, 99)),
        "residual_argmax": int(np.argmax(ratio)),
        "residual_contact_vertices": int(touching.sum()),
    }


def scene_residual(scene) -> dict:
    """:func:`equilibrium_residual` of a scene's current state. A scene whose solver has no
    undamped force evaluation (implicit Euler) gets one from a symplectic Euler solver of
    the same model, made once."""
    solver = scene.solver
    if not hasattr(solver, "static_forces"):
        solver = _FORCE_SOLVERS.get(scene.model)
        if solver is None:
            from sandbox.sim.solver import SymplecticEulerSolver

            solver = _FORCE_SOLVERS[scene.model] = SymplecticEulerSolver(scene.model)
    f = solver.static_forces(scene.state.x, scene.control.gravity)
    g = np.asarray(scene.control.gravity[None].to_numpy(), np.float64)
    return equilibrium_residual(scene.model, scene.state.positions(), f, g)


_FORCE_SOLVERS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
