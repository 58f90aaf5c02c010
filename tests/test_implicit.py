"""Implicit Euler (sandbox/sim/implicit.py) and its per-element Hessians (hessians.py).

Hessians against central differences of the exact gradients of forces.py (float64), in
the configurations where the PSD projection drops nothing, and PSD everywhere; free fall;
pins; a stiff sheet (denim, membrane x100) hanging from two corners at dt = 1/60 s against
a fine-step symplectic Euler reference computed here.
"""

import numpy as np
import pytest
import taichi as ti

from sandbox.scene.build import build_scene
from sandbox.scene.spec import scene_from_dict
from sandbox.sim import forces, hessians
from sandbox.sim.implicit import ImplicitEulerSolver
from sandbox.sim.implicit_config import ImplicitConfig
from sandbox.sim.materials import get_material

# ---------------------------------------------------------------------------- Hessians
_X = None


def _fields():
    global _X
    if _X is None:
        _X = {
            "x": ti.Vector.field(3, float, shape=4),
            "rinv": ti.Matrix.field(2, 2, float, shape=()),
            "grad": ti.Vector.field(3, float, shape=4),
            "hess": ti.Matrix.field(3, 3, float, shape=(4, 4)),
            "par": ti.field(float, shape=4),
            "diff": ti.field(float, shape=()),
        }
    return _X


@ti.kernel
def _membrane(x: ti.template(), rinv: ti.template(), grad: ti.template(),
              hess: ti.template(), par: ti.template(), diff: ti.template()):  # fmt: skip
    r = rinv[None]
    f_u, f_v = forces.deformation_columns(x[0], x[1], x[2], r)
    g_u, g_v = forces.eq8_membrane_gradient(f_u, f_v, par[0], par[1], par[2], par[3])
    m_u, m_v = hessians.membrane_gradient_f(f_u, f_v, par[0], par[1], par[2], par[3])
    diff[None] = ti.max((g_u - m_u).norm(), (g_v - m_v).norm()) / (g_u.norm() + g_v.norm())
    h_uu, h_uv, h_vv = hessians.membrane_hessian_f(f_u, f_v, par[0], par[1], par[2], par[3])
    cu = ti.Vector([-(r[0, 0] + r[1, 0]), r[0, 0], r[1, 0]])
    cv = ti.Vector([-(r[0, 1] + r[1, 1]), r[0, 1], r[1, 1]])
    for i in ti.static(range(3)):
        grad[i] = cu[i] * g_u + cv[i] * g_v
        for j in ti.static(range(3)):
            hess[i, j] = (cu[i] * cu[j] * h_uu + cu[i] * cv[j] * h_uv
                          + cv[i] * cu[j] * h_uv.transpose() + cv[i] * cv[j] * h_vv)  # fmt: skip


@ti.kernel
def _hinge(x: ti.template(), grad: ti.template(), hess: ti.template(), par: ti.template()):
    th, g0, g1, g2, g3 = forces.dihedral_angle_gradient(x[0], x[1], x[2], x[3])
    g = ti.Matrix.rows([g0, g1, g2, g3])
    s = par[0] * (th - par[1])
    for i in ti.static(range(4)):
        grad[i] = s * ti.Vector([g[i, 0], g[i, 1], g[i, 2]])
        for j in ti.static(range(4)):
            gi = ti.Vector([g[i, 0], g[i, 1], g[i, 2]])
            gj = ti.Vector([g[j, 0], g[j, 1], g[j, 2]])
            hess[i, j] = hessians.hinge_hessian_block(par[0], gi, gj)
    par[2] = th


@ti.kernel
def _seam(x: ti.template(), grad: ti.template(), hess: ti.template(), par: ti.template()):
    d = x[0] - x[1]
    k, r = par[0], par[1]
    g = k * d
    if r > 0.0:
        g = k * (d.norm() - r) / d.norm() * d
    grad[0] = g
    grad[1] = -g
    h = hessians.seam_spring_hessian(d, r, k)
    hess[0, 0] = h
    hess[1, 1] = h
    hess[0, 1] = -h
    hess[1, 0] = -h


def _eval(kind, x, **p):
    f = _fields()
    xx = np.zeros((4, 3))
    xx[: len(x)] = x
    f["x"].from_numpy(xx)
    if kind == "membrane":
        f["rinv"][None] = ti.Matrix(p["rinv"].tolist())
        f["par"].from_numpy(np.array([p["area"], *p["e"]], float))
        _membrane(f["x"], f["rinv"], f["grad"], f["hess"], f["par"], f["diff"])
    elif kind == "hinge":
        f["par"].from_numpy(np.array([p["k"], p["rest"], 0.0, 0.0]))
        _hinge(f["x"], f["grad"], f["hess"], f["par"])
    else:
        f["par"].from_numpy(np.array([p["k"], p["rest"], 0.0, 0.0]))
        _seam(f["x"], f["grad"], f["hess"], f["par"])
    k = len(x)
    g = f["grad"].to_numpy()[:k].ravel()
    h = f["hess"].to_numpy()[:k, :k].transpose(0, 2, 1, 3).reshape(3 * k, 3 * k)
    return g, h


def _fd_jacobian(kind, x, eps=1e-7, **p):
    x = np.asarray(x, float)
    cols = []
    for a in range(x.size):
        d = np.zeros(x.size)
        d[a] = eps
        gp, _ = _eval(kind, x + d.reshape(x.shape), **p)
        gm, _ = _eval(kind, x - d.reshape(x.shape), **p)
        cols.append((gp - gm) / (2 * eps))
    return np.array(cols).T


def _psd(h):
    w = np.linalg.eigvalsh(0.5 * (h + h.T))
    return w.min() >= -1e-9 * max(1.0, np.abs(w).max())


REST = np.array([[0.0, 0.0], [0.02, 0.0], [0.005, 0.015]])  # (u, v) of a triangle [m]


def _tri(pos):
    dm = np.column_stack([REST[1] - REST[0], REST[2] - REST[0]])  # [[du1, du2], [dv1, dv2]]
    return {"rinv": np.linalg.inv(dm), "area": 0.5 * abs(np.linalg.det(dm)),
            "e": (400.0, 2000.0, 100.0)}  # fmt: skip


def test_membrane_hessian_matches_finite_differences_in_tension_without_shear():
    # F = diag stretch (1.03 along u, 1.05 along v) then a rotation: no shear, both columns
    # stretched, so the clamp and the dropped shear term are both zero: the Hessian is exact
    rot = np.linalg.qr(np.random.default_rng(1).normal(size=(3, 3)))[0]
    f = rot @ np.array([[1.03, 0.0], [0.0, 1.05], [0.0, 0.0]])
    x = (f @ REST.T).T + np.array([0.1, 0.2, -0.3])
    p = _tri(x)
    _, h = _eval("membrane", x, **p)
    fd = _fd_jacobian("membrane", x, **p)
    assert np.abs(h - fd).max() <= 1e-6 * np.abs(fd).max()
    assert np.allclose(h, h.T, atol=1e-9 * np.abs(h).max())


def test_membrane_gradient_is_eq8_and_hessian_is_symmetric_psd_under_shear_and_compression():
    rng = np.random.default_rng(2)
    for _ in range(20):
        x = np.column_stack([REST, np.zeros(3)]) + rng.normal(scale=0.004, size=(3, 3))
        _, h = _eval("membrane", x, **_tri(x))
        assert float(_fields()["diff"][None]) < 1e-12  # the solver's gradient is Eq. 8's
        assert np.allclose(h, h.T, atol=1e-9 * np.abs(h).max())
        assert _psd(h)


@ti.kernel
def _column(f: ti.template(), out: ti.template(), grad: ti.template()):
    for _ in range(1):
        v = f[0]
        s = v.norm()
        grad[0] = 7.0 * (s - 1.0) * v / s  # E a = 7: gradient of E a/2 (|f| − 1)²
        out[None] = hessians.stretch_column_hessian(v, 1.0, 7.0)
        out[None] += hessians.stretch_compression_term(v, 1.0, 7.0)


@pytest.mark.parametrize("length", [0.9, 1.1])
def test_stretch_column_hessian_plus_compression_term_is_exact(length):
    f = ti.Vector.field(3, float, shape=1)
    g = ti.Vector.field(3, float, shape=1)
    h = ti.Matrix.field(3, 3, float, shape=())
    v0 = length * np.array([0.6, -0.48, 0.64])
    f.from_numpy(v0[None])
    _column(f, h, g)
    exact = h.to_numpy()
    fd = np.zeros((3, 3))
    for a in range(3):
        for sign in (1, -1):
            v = v0.copy()
            v[a] += sign * 1e-7
            f.from_numpy(v[None])
            _column(f, h, g)
            fd[:, a] += sign * g.to_numpy()[0] / 2e-7
    assert np.abs(exact - fd).max() <= 1e-6 * np.abs(fd).max()


def test_hinge_hessian_matches_finite_differences_at_the_rest_angle():
    x = np.array([[0.0, 0.0, 0.0], [0.02, 0.001, 0.0], [0.008, 0.015, 0.002],
                  [0.012, -0.014, 0.006]])  # fmt: skip
    theta = _eval("hinge", x, k=1.0, rest=0.0)[0]  # run once to get θ
    th = float(_fields()["par"][2])
    assert abs(th) > 0.1 and theta.shape == (12,)
    p = {"k": 3e-5, "rest": th}  # at θ = θ0 Gauss-Newton is the exact Hessian
    _, h = _eval("hinge", x, **p)
    fd = _fd_jacobian("hinge", x, **p)
    assert np.abs(h - fd).max() <= 1e-6 * np.abs(fd).max()
    assert _psd(h)


@pytest.mark.parametrize("rest", [0.0, 0.01])
def test_seam_hessian_matches_finite_differences_when_stretched(rest):
    x = np.array([[0.0, 0.0, 0.0], [0.012, -0.005, 0.007]])
    p = {"k": 50.0, "rest": rest}
    _, h = _eval("seam", x, **p)
    fd = _fd_jacobian("seam", x, **p)
    assert np.abs(h - fd).max() <= 1e-6 * np.abs(fd).max()
    x_short = np.array([[0.0, 0.0, 0.0], [0.004, 0.002, 0.0]])  # compressed: clamped, PSD
    assert _psd(_eval("seam", x_short, k=50.0, rest=0.01)[1])


# ---------------------------------------------------------------------------- scenes
def _sheet(material, *, pins, size=0.3, edge=0.03, damping=0.0, velocity=(0.0, 0.0, 0.0),
           integrator="symplectic_euler", dt="auto", rotation=-10.0):  # fmt: skip
    return build_scene(scene_from_dict({
        "scene": {"name": "implicit-test"},
        "simulation": {"dt_s": dt, "damping_per_s": damping, "frame_rate_hz": 60,
                       "integrator": integrator},
        "cloth": [{"name": "sheet", "size_m": [size, size], "edge_length_m": edge,
                   "mesher": "grid", "material": material, "origin_m": [-size / 2, 0.5, 0.0],
                   "rotation_deg": [rotation, 0.0, 0.0], "velocity_m_s": list(velocity),
                   "pins": pins}],
    }, source="test_implicit"))  # fmt: skip


def stiff(preset: str, factor: float) -> dict:
    """A preset with its membrane (stretch and shear) stiffness multiplied by ``factor``."""
    m = get_material(preset)
    return {
        "preset": preset,
        "stretch_u_N_m": m.stretch_u_N_m * factor,
        "stretch_v_N_m": m.stretch_v_N_m * factor,
        "shear_N_m": m.shear_N_m * factor,
    }


@pytest.mark.slow
def test_free_fall_is_exact():
    scene = _sheet("denim", pins=[], velocity=(0.3, 1.0, -0.2), integrator="implicit_euler")
    x0 = scene.state.positions()
    solver = scene.solver
    assert isinstance(solver, ImplicitEulerSolver) and scene.dt_s == pytest.approx(1 / 60)
    h, g, v = scene.dt_s, np.array([0.0, -9.80665, 0.0]), np.array([0.3, 1.0, -0.2])
    x = x0.copy()
    for k in range(5):
        solver.step(scene.state, scene.state, scene.control, h, k)
        v = v + h * g
        x = x + h * v
    assert np.abs(scene.state.positions() - x).max() < 1e-12
    assert np.abs(scene.state.velocities() - v).max() < 1e-10
    assert solver.stats()["newton_iterations"] == 5  # x̂ is the answer: one check per step


def _strain(scene, x):
    """Largest stretch max(S_u, S_v) − 1 over the triangles."""
    m = scene.model
    t = m.tri_indices_np
    d = np.stack([x[t[:, 1]] - x[t[:, 0]], x[t[:, 2]] - x[t[:, 0]]], axis=2)  # (m, 3, 2)
    f = d @ m.tri_rest_inv_np
    return float(np.linalg.norm(f, axis=1).max() - 1.0)


def _run(scene, seconds):
    """Positions at the end and the sag (pin height − lowest point) [m] after each frame."""
    pinned = scene.model.pinned_np
    scene.solver.advance(scene.state, scene.control, 0.0, 1)
    sags = []
    for f in range(round(seconds * 60)):
        k = scene.steps_per_frame
        scene.solver.advance(scene.state, scene.control, scene.dt_s, k, f * k)
        x = scene.state.positions()
        sags.append(x[pinned, 1].max() - x[:, 1].min())
    assert scene.solver.first_bad() is None
    return x, np.array(sags)


@pytest.mark.slow
def test_stiff_sheet_at_frame_steps_matches_a_fine_step_explicit_reference():
    # denim with stretch and shear x100, 30 x 30 cm, starts flat and horizontal, hangs from
    # two corners; damping 8/s (both solvers) so that both settle within 3 s
    material = stiff("denim", 100.0)
    pins = [{"corners": "top"}]
    seconds, size = 3.0, 0.3
    ref = _sheet(material, pins=pins, damping=8.0, rotation=-90.0)  # symplectic Euler
    assert ref.dt_s < 2e-5
    x_ref, sag_ref = _run(ref, seconds)
    imp = _sheet(material, pins=pins, damping=8.0, rotation=-90.0, integrator="implicit_euler")
    assert imp.dt_s == pytest.approx(1 / 60)
    x0 = imp.state.positions()
    x, sag = _run(imp, seconds)
    stats = imp.solver.stats()
    assert np.isfinite(x).all()
    assert stats["steps"] == 180 and stats["unconverged_steps"] == 0
    assert stats["max_error_over_tolerance"] <= 1.0
    pinned = imp.model.pinned_np
    assert np.array_equal(x[pinned], x0[pinned])  # pins do not move
    assert abs(sag[-1] - sag_ref[-1]) <= 0.01 * size
    assert np.linalg.norm(x - x_ref, axis=1).max() <= 0.01 * size
    assert abs(_strain(imp, x) - _strain(ref, x_ref)) <= 0.01
    # not frozen mid-air: it falls as fast as the reference (first frame at 90 % of the
    # final sag within two frames of the reference's)
    assert sag[-1] > 0.25
    first = lambda s: int(np.argmax(s >= 0.9 * s[-1]))  # noqa: E731
    assert abs(first(sag) - first(sag_ref)) <= 2


@pytest.mark.slow
def test_matrix_free_product_is_symmetric():
    scene = _sheet(stiff("denim", 10.0), pins=[{"corners": "top"}], integrator="implicit_euler")
    s = scene.solver
    s.advance(scene.state, scene.control, scene.dt_s, 3)
    n = scene.model.particle_count
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    a[scene.model.pinned_np] = b[scene.model.pinned_np] = 0.0
    aa, ab = s.system_product(a), s.system_product(b)
    assert float((aa * b).sum()) == pytest.approx(float((ab * a).sum()), rel=1e-10)
    assert float((ab * b).sum()) > 0.0  # b·A b > 0: positive definite
    assert np.abs(ab[scene.model.pinned_np]).max() == 0.0  # pinned rows are zero


def test_scene_picks_the_integrator():
    data = {"scene": {"name": "x"}, "simulation": {"integrator": "implicit_euler"},
            "cloth": [{"name": "c", "size_m": [0.1, 0.1], "edge_length_m": 0.05,
                       "material": "denim"}]}  # fmt: skip
    scene = build_scene(scene_from_dict(data, source="t.toml"))
    assert isinstance(scene.solver, ImplicitEulerSolver)
    assert scene.dt_s == pytest.approx(1 / 60) and scene.steps_per_frame == 2
    data["simulation"]["integrator"] = "backward"
    from sandbox.errors import SandboxError

    with pytest.raises(SandboxError, match="integrator"):
        scene_from_dict(data, source="t.toml")


@pytest.mark.slow
@pytest.mark.parametrize("seams", [False, True])
def test_assembled_matrix_equals_the_matrix_free_product(seams):
    scene = _sheet(stiff("denim", 10.0), pins=[{"corners": "top"}], integrator="implicit_euler")
    s, m = scene.solver, scene.model
    assert s.linear_solver == "direct"  # the CPU default
    if seams:  # a live seam (rest 0 and rest > 0) changes the pattern
        sewn = ImplicitEulerSolver(
            _with_seams(scene), config=ImplicitConfig(linear_solver="direct")
        )
        s, m = sewn, sewn.model
    s.advance(scene.state, scene.control, scene.dt_s, 2)
    n = m.particle_count
    y = np.random.default_rng(1).normal(size=(n, 3))
    y[m.pinned_np] = 0.0
    a = s.assembled_matrix()
    assert a.shape == (3 * n, 3 * n)
    assert abs(a - a.T).max() <= 1e-9 * abs(a).max()  # symmetric
    got = (a @ y.ravel()).reshape(n, 3)
    want = s.system_product(y)
    free = ~m.pinned_np
    assert np.abs(got[free] - want[free]).max() <= 1e-9 * np.abs(want).max()
    assert np.allclose(a[np.ix_(*(np.flatnonzero(np.repeat(~free, 3)),) * 2)].toarray(),
                       np.eye(3 * int((~free).sum())))  # fmt: skip


def _with_seams(scene):
    """The scene's sheet rebuilt with room for seams, two springs sewn (rest 0 and 1 cm)."""
    from sandbox.sim.builder import ModelBuilder
    from sandbox.sim.materials import get_material
    from sandbox.sim.seams import set_seam_springs

    m0 = scene.model
    b = ModelBuilder()
    b.add_cloth(name="s", pattern_uv=m0.rest_uv_np, triangles=m0.tri_indices_np,
                material=get_material("denim"), positions=m0.initial_positions_np,
                pinned=m0.pinned_np)  # fmt: skip
    m = b.finalize(seam_capacity=4)
    n = m.particle_count
    set_seam_springs(m, np.array([[n // 3, n - 1], [n // 2, 5]]), np.array([0.0, 0.01]),
                     np.array([50.0, 80.0]))  # fmt: skip
    scene.state, scene.control = m.state(), m.control(gravity=(0.0, -9.80665, 0.0))
    return m


@pytest.mark.slow
@pytest.mark.parametrize("factor", ["banded", "superlu"])
def test_direct_and_cg_linear_solvers_agree(factor):
    # "superlu": every band counts as wide, so LU, reused as CG's preconditioner
    banded_flops = 0.0 if factor == "superlu" else ImplicitConfig().banded_flops
    runs = {}
    for name in ("direct", "cg"):
        scene = _sheet(stiff("denim", 100.0), pins=[{"corners": "top"}], damping=8.0,
                       rotation=-90.0, integrator="implicit_euler")  # fmt: skip
        config = ImplicitConfig(linear_solver=name, banded_flops=banded_flops)
        scene.solver = ImplicitEulerSolver(scene.model, config=config)
        x, sag = _run(scene, 0.5)
        runs[name] = (x, scene.solver.stats())
    (xd, sd), (xc, sc) = runs["direct"], runs["cg"]
    assert sd["unconverged_steps"] == 0 and sc["unconverged_steps"] == 0
    assert np.abs(xd - xc).max() <= 1e-4  # both within the Newton tolerance of the solution
    assert sd["factorisations"] >= 1 and sc["factorisations"] == 0
    assert sd["newton_iterations"] <= sc["newton_iterations"]
    if factor == "superlu":  # the factors were reused: fewer factorisations than solves
        assert sd["factorisations"] < sd["newton_iterations"]
    else:
        assert sd["factorisations"] == sd["newton_iterations"]


# ---------------------------------------------------------------------------- body contact
@ti.kernel
def _contact_eval(s: ti.template(), x: ti.types.ndarray(), out: ti.types.ndarray()):
    xi = ti.Vector([x[0], x[1], x[2]], ti.f64)
    e, g, h = s._contact_terms(0, xi)
    out[0] = e
    for a in ti.static(range(3)):
        out[1 + a] = g[a]
        for b in ti.static(range(3)):
            out[4 + 3 * a + b] = h[a, b]


def _contact_solver(*, k2: float, lam: float):
    """An implicit solver with a body (the incline's plane), vertex 0 given two planes."""
    from sandbox.validate.cases import incline_spec

    spec, _ = incline_spec(0.05)
    spec.simulation.integrator = "implicit_euler"
    s = build_scene(spec).solver
    assert s.has_contact
    s.h[None] = 1 / 60
    s.x0[0] = [0.0, 0.0, 0.0]
    n2 = np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)  # a crease: a second, tilted plane
    s.c_n[0], s.c_o[0], s.c_k[0] = [0.0, 1.0, 0.0], 0.001, 40.0
    s.c_n2[0], s.c_o2[0], s.c_k2[0] = n2.tolist(), 0.0015, k2
    s.c_mu[0], s.c_lam[0] = 0.3, lam
    return s


def _contact(s, x):
    out = np.zeros(13)
    _contact_eval(s, np.asarray(x, float), out)
    return out[0], out[1:4], out[4:].reshape(3, 3)


@pytest.mark.parametrize("where", ["stick", "slide", "slide_two_planes", "free"])
def test_contact_energy_gradient_and_hessian_match_finite_differences(where):
    """Penalty on the step's planes and the lagged smoothed Coulomb friction
    (ImplicitEulerSolver._contact_terms): gradient = central differences of the energy,
    Hessian = differences of the gradient, PSD; nothing in front of the planes with no
    contact force (λ = 0)."""
    s = _contact_solver(k2=60.0 if where == "slide_two_planes" else 0.0,
                        lam=0.0 if where == "free" else 0.02)  # fmt: skip
    eps_slip = ImplicitConfig().friction_slip_m_s / 60  # ε_v · h
    x = {"stick": [0.3 * eps_slip, 0.0004, -0.2 * eps_slip],
         "slide": [0.004, 0.0002, -0.003],
         "slide_two_planes": [-0.002, 0.0005, 0.003],
         "free": [0.0, 0.01, 0.0]}[where]  # fmt: skip
    e, g, h = _contact(s, x)
    d = 1e-9 if where == "stick" else 1e-7
    fd_g, fd_h = np.zeros(3), np.zeros((3, 3))
    for a in range(3):
        step = np.zeros(3)
        step[a] = d
        fd_g[a] = (_contact(s, x + step)[0] - _contact(s, x - step)[0]) / (2 * d)
        fd_h[:, a] = (_contact(s, x + step)[1] - _contact(s, x - step)[1]) / (2 * d)
    if where == "free":  # in front of the plane, not moving: nothing
        assert e == 0.0 and not g.any() and not h.any()
        return
    assert e > 0.0
    assert np.abs(g - fd_g).max() <= 1e-5 * np.abs(g).max()
    assert np.abs(h - fd_h).max() <= 1e-4 * np.abs(h).max()
    assert _psd(h)


@pytest.mark.slow
@pytest.mark.parametrize("mu", [0.2, 0.7])
def test_implicit_friction_on_the_incline_follows_coulomb(mu):
    """A square on a 30° plane at 1/240 s: with μ = 0.2 < tan 30° it slides with
    a = g (sin α − μ cos α) (backward Euler's own error over 72 steps: (N+1)/N − 1 = 1.4 %);
    with μ = 0.7 > tan 30° it sticks (creeps less than 1 mm in 0.3 s)."""
    from sandbox.validate import cases

    run = cases.incline_case(0.02, "implicit_euler", 1 / 240, mu=mu)
    assert run.outcome == "ok" and run.extra["unconverged_steps"] == 0
    if mu < 0.5:
        assert run.error_pct <= 2.0
    else:
        travelled = 0.5 * run.extra["acceleration_m_s2"] * run.sim_time_s**2
        assert abs(travelled) < 1e-3


def _incline_scene(mu: float, reuse_m: float):
    from sandbox.validate.cases import incline_spec

    spec, _ = incline_spec(0.025, mu)
    spec.simulation.integrator = "implicit_euler"
    return build_scene(spec, implicit=ImplicitConfig(plane_reuse_m=reuse_m))


def test_contact_planes_are_kept_while_cloth_rests_and_found_again_when_the_body_moves():
    """A square sticking on the 30° incline (μ = 0.7) moves less than plane_reuse_m a step,
    so after its first step it keeps the planes it found (``c_at`` stays where they were
    looked up) and runs as with a query every step (plane_reuse_m = 0), to round-off; a
    body moved 5 mm away by ``update`` (its generation changes) has every plane found
    again, 5 mm further back."""
    runs = {}
    for reuse in (1e-3, 0.0):
        sc = _incline_scene(0.7, reuse)
        s, state = sc.solver, sc.state
        s.advance(state, sc.control, 1 / 60, 1)
        at = s.c_at.to_numpy()[: sc.model.particle_count]
        s.advance(state, sc.control, 1 / 60, 10)
        kept = np.all(s.c_at.to_numpy()[: sc.model.particle_count] == at)
        runs[reuse] = (state.positions(), kept, sc, at)
    x_reuse, kept, sc, at = runs[1e-3]
    assert kept and not runs[0.0][1]
    assert np.abs(x_reuse - runs[0.0][0]).max() < 1e-7
    # the body moves 5 mm away from the cloth: every plane is found again, 5 mm back
    s, body = sc.solver, sc.model.colliders[0]
    n = s.c_n.to_numpy()[0]  # the plane's normal, towards the cloth
    offset = s.c_t.to_numpy()[: sc.model.particle_count].copy()
    body.update(body.body_x.to_numpy().astype(float) - 0.005 * n)
    s.advance(sc.state, sc.control, 1 / 60, 1)
    moved = s.c_t.to_numpy()[: sc.model.particle_count] - offset
    np.testing.assert_allclose(moved, -0.005, atol=1e-6)
