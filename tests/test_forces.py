"""Eq. 6-8: strains, energies and forces of the triangle and hinge model."""

import math

import numpy as np
import pytest
import taichi as ti

from sandbox.sim import forces
from sandbox.sim.hinges import find_hinges
from sandbox.sim.model import Model, PieceInfo
from sandbox.sim.solver import SymplecticEulerSolver

RNG = np.random.default_rng(7)


def random_patch(n_tris=6):
    """A small irregular fan patch: random rest (u, v) and a random deformed 3D shape."""
    k = n_tris
    ang = np.sort(RNG.uniform(0, 2 * np.pi, k))
    ang = np.linspace(0, 2 * np.pi, k, endpoint=False) + RNG.uniform(-0.2, 0.2, k)
    r = RNG.uniform(0.6, 1.4, k) * 0.01
    uv = np.vstack([[0.0, 0.0], np.stack([r * np.cos(ang), r * np.sin(ang)], 1)])
    tris = np.array([[0, 1 + i, 1 + (i + 1) % k] for i in range(k)])
    x = np.hstack([uv, np.zeros((k + 1, 1))]) @ random_rotation().T
    x = 1.15 * x + RNG.normal(0, 0.0015, x.shape)
    return uv, tris, x


def random_rotation():
    q, _ = np.linalg.qr(RNG.normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def make_model(uv, tris, stiffness, bend_k=None, rest_angle=None, pinned=None):
    d1 = uv[tris[:, 1]] - uv[tris[:, 0]]
    d2 = uv[tris[:, 2]] - uv[tris[:, 0]]
    dm = np.stack([np.stack([d1[:, 0], d2[:, 0]], 1), np.stack([d1[:, 1], d2[:, 1]], 1)], 1)
    area = 0.5 * (d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1])
    assert np.all(area > 0)
    hinges = find_hinges(tris) if bend_k is not None else None
    n = len(uv)
    return Model(
        rest_uv=uv,
        positions=np.hstack([uv, np.zeros((n, 1))]),
        velocities=np.zeros((n, 3)),
        mass=np.full(n, 1e-3),
        pinned=np.zeros(n, bool) if pinned is None else pinned,
        tri_indices=tris,
        tri_rest_inv=np.linalg.inv(dm),
        tri_rest_area=area,
        tri_stiffness=np.tile(stiffness, (len(tris), 1)).astype(float),
        hinge_indices=hinges,
        hinge_rest_angle=None
        if hinges is None
        else (np.zeros(len(hinges)) if rest_angle is None else np.full(len(hinges), rest_angle)),
        hinge_stiffness=None if hinges is None else np.full(len(hinges), bend_k),
        pieces=[PieceInfo("p", None, 0, n, 0, len(tris))],
    )


def fd_gradient(solver, state, x, h=1e-7):
    grad = np.zeros_like(x)
    for i in range(x.shape[0]):
        for d in range(3):
            xp, xm = x.copy(), x.copy()
            xp[i, d] += h
            xm[i, d] -= h
            state.set(xp)
            ep = solver.internal_energy(state)
            state.set(xm)
            em = solver.internal_energy(state)
            grad[i, d] = (ep - em) / (2 * h)
    state.set(x)
    return grad


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_membrane_and_bending_forces_are_the_energy_gradient(seed):
    global RNG
    RNG = np.random.default_rng(seed)
    uv, tris, x = random_patch(7)
    model = make_model(uv, tris, stiffness=[120.0, 45.0, 7.0], bend_k=3e-5, rest_angle=0.1)
    solver = SymplecticEulerSolver(model)
    state = model.state()
    state.set(x)
    control = model.control(gravity=(0, 0, 0))
    f = solver.compute_forces(state, control)
    g = fd_gradient(solver, state, x)
    scale = np.abs(g).max()
    assert scale > 1e-3
    np.testing.assert_allclose(f, -g, rtol=0, atol=1e-6 * scale)


def test_hinge_only_forces_are_the_energy_gradient():
    uv = np.array([[0.0, 0.0], [0.01, 0.0], [0.004, 0.008], [0.006, -0.009]])
    tris = np.array([[0, 1, 2], [1, 0, 3]])
    model = make_model(uv, tris, stiffness=[0.0, 0.0, 0.0], bend_k=2e-4, rest_angle=-0.2)
    solver = SymplecticEulerSolver(model)
    state = model.state()
    x = np.hstack([uv, np.zeros((4, 1))])
    x[2, 2] = 0.004
    x[3, 2] = 0.002
    state.set(x)
    f = solver.compute_forces(state, model.control(gravity=(0, 0, 0)))
    g = fd_gradient(solver, state, x)
    np.testing.assert_allclose(f, -g, rtol=0, atol=1e-6 * np.abs(g).max())
    assert np.abs(f.sum(axis=0)).max() < 1e-12  # no net force


@ti.kernel
def _eq6_vs_f(
    d1: ti.types.vector(3, ti.f64), d2: ti.types.vector(3, ti.f64),
    rest: ti.types.matrix(2, 2, ti.f64), out: ti.types.ndarray(),
):  # fmt: skip
    # explicit f64: a bare `float` in a module-level annotation is fixed at import time
    s_u, s_v, th = forces.eq6_strain(d1, d2, rest[0, 0], rest[1, 0], rest[0, 1], rest[1, 1])
    f_u, f_v = forces.deformation_columns(ti.Vector([0.0, 0, 0]), d1, d2, rest.inverse())
    out[0], out[1], out[2] = s_u, s_v, th
    out[3], out[4] = f_u.norm(), f_v.norm()
    out[5] = 0.5 * ti.asin(f_u.dot(f_v) / (f_u.norm() * f_v.norm()))


def test_eq6_equals_the_deformation_gradient_values():
    for _ in range(20):
        rest = RNG.normal(size=(2, 2)) * 0.01
        if np.linalg.det(rest) < 0:
            rest[:, [0, 1]] = rest[:, [1, 0]]
        if abs(np.linalg.det(rest)) < 2e-5:
            continue
        d = RNG.normal(size=(2, 3)) * 0.01
        out = np.zeros(6)
        _eq6_vs_f(d[0], d[1], rest, out)
        np.testing.assert_allclose(out[:3], out[3:], rtol=1e-9, atol=1e-12)
        # and against numpy: F = Ds Dm^-1
        f = d.T @ np.linalg.inv(rest)
        np.testing.assert_allclose(out[3:5], np.linalg.norm(f, axis=0), rtol=1e-9)


def test_pure_stretch_and_shear_are_recovered():
    rest = np.array([[0.01, 0.0], [0.0, 0.01]])  # edges along u and along v
    out = np.zeros(6)
    _eq6_vs_f([0.011, 0, 0], [0, 0.0095, 0], rest, out)
    np.testing.assert_allclose(out[:3], [1.1, 0.95, 0.0], atol=1e-12)
    gamma = 0.3  # shear the v edge towards u: angle between F_u and F_v = pi/2 - gamma
    _eq6_vs_f([0.01, 0, 0], [0.01 * math.sin(gamma), 0.01 * math.cos(gamma), 0], rest, out)
    np.testing.assert_allclose(out[:3], [1.0, 1.0, gamma / 2], atol=1e-12)


def test_zero_force_at_rest_and_under_rigid_motion():
    uv, tris, _ = random_patch(6)
    model = make_model(uv, tris, stiffness=[300.0, 80.0, 20.0], bend_k=1e-5)
    solver = SymplecticEulerSolver(model)
    state = model.state()
    control = model.control(gravity=(0, 0, 0))
    x0 = np.hstack([uv, np.zeros((len(uv), 1))])
    for x in (x0, x0 @ random_rotation().T + np.array([0.3, -1.0, 2.0])):
        state.set(x)
        f = solver.compute_forces(state, control)
        assert np.abs(f).max() < 1e-10
        assert abs(solver.internal_energy(state)) < 1e-16


def _dissipation(model, x, v, beta):
    """D = β a/2 Σ (E_u Ṡ_u² + E_v Ṡ_v² + E_s (2θ̇_s)²), in numpy, for the test below."""
    total = 0.0
    for t, (i0, i1, i2) in enumerate(model.tri_indices_np):
        r = model.tri_rest_inv_np[t]
        e_u, e_v, e_s = model.tri_stiffness_np[t]

        def columns(p, r=r, i0=i0, i1=i1, i2=i2):
            d1, d2 = p[i1] - p[i0], p[i2] - p[i0]
            return r[0, 0] * d1 + r[1, 0] * d2, r[0, 1] * d1 + r[1, 1] * d2

        f_u, f_v = columns(x)
        r_u, r_v = columns(v)
        s_u, s_v = np.linalg.norm(f_u), np.linalg.norm(f_v)
        c = f_u @ f_v / (s_u * s_v)
        # rates by the chain rule: Ṡ = d/dε S(F + ε Ḟ) at ε = 0, exactly
        eps = 1e-7

        def strains(a, b):
            su, sv = np.linalg.norm(a), np.linalg.norm(b)
            return su, sv, math.asin(np.clip(a @ b / (su * sv), -1, 1))

        p = strains(f_u + eps * r_u, f_v + eps * r_v)
        m = strains(f_u - eps * r_u, f_v - eps * r_v)
        du, dv, dsh = ((p[k] - m[k]) / (2 * eps) for k in range(3))
        assert abs(c) < 1
        total += 0.5 * beta * model.tri_rest_area_np[t] * (e_u * du**2 + e_v * dv**2 + e_s * dsh**2)
    return total


def test_strain_rate_damping_is_the_dissipation_gradient_and_spares_rigid_motion():
    """The membrane's strain-rate damping: f = −∂D/∂v (finite differences), its power
    −2D ≤ 0, and no force for a rigid motion (translation + rotation)."""
    uv, tris, x = random_patch(7)
    model = make_model(uv, tris, stiffness=[120.0, 45.0, 7.0])
    solver = SymplecticEulerSolver(model)
    state = model.state()
    control = model.control(gravity=(0, 0, 0))
    v = RNG.normal(0, 0.05, x.shape)
    beta = 2e-6
    state.set(x, v)
    f0 = solver.compute_forces(state, control)
    model.strain_damping_s[None] = beta
    f_d = solver.compute_forces(state, control) - f0
    grad = np.zeros_like(v)
    h = 1e-4
    for i in range(v.shape[0]):
        for d in range(3):
            vp, vm = v.copy(), v.copy()
            vp[i, d] += h
            vm[i, d] -= h
            grad[i, d] = (_dissipation(model, x, vp, beta) - _dissipation(model, x, vm, beta)) / (
                2 * h
            )
    scale = np.abs(grad).max()
    assert scale > 0
    np.testing.assert_allclose(f_d, -grad, rtol=0, atol=1e-5 * scale)
    power = float((f_d * v).sum())
    assert power < 0
    assert power == pytest.approx(-2 * _dissipation(model, x, v, beta), rel=1e-5)
    omega = np.array([0.3, -1.1, 0.7])
    rigid = np.cross(omega, x) + np.array([0.2, 0.0, -0.4])
    state.set(x, rigid)
    f_r = solver.compute_forces(state, control)
    model.strain_damping_s[None] = 0.0
    np.testing.assert_allclose(
        f_r, solver.compute_forces(state, control), rtol=0, atol=1e-9 * scale
    )
