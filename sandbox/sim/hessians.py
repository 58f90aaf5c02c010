"""Per-element Hessians of the paper's energies (Eq. 7), made positive semi-definite.

Used by the implicit Euler solver (:mod:`sandbox.sim.implicit`). Each function returns the
Hessian of one element's energy in a compact form; ``tests/test_implicit.py`` checks each
against finite differences of the exact gradients of :mod:`sandbox.sim.forces` (float64) in
the configurations where the projection drops nothing, and checks that each is PSD.

What is kept and what is dropped (so that every Newton system is symmetric positive
definite):

* stretch, U = E a/2 (|f| − 1)² per column f = F_u or F_v: the exact Hessian
  E a [f̂f̂ᵀ + (1 − 1/|f|) (I − f̂f̂ᵀ)] with the transverse factor clamped at 0 when the
  column is compressed (|f| < 1). Exact in tension.
* shear, U = E_s a/2 r², r = 2θ_s = asin(f̂_u·f̂_v): Gauss-Newton E_s a ∇r ∇rᵀ. It drops
  E_s a r ∇²r, which vanishes at zero shear.
* bending, U = E_b/2 (θ_b − θ_0)²: Gauss-Newton E_b ∇θ_b ∇θ_bᵀ (rank one, 12x12). It drops
  E_b (θ_b − θ_0) ∇²θ_b, which vanishes at the rest angle.
* seam spring, U = k/2 (|d| − r)²: k [d̂d̂ᵀ + max(0, 1 − r/|d|) (I − d̂d̂ᵀ)]; k I when r = 0
  (then it is exact everywhere). Exact when stretched.
"""

import taichi as ti

from sandbox.sim.forces import SHEAR_EPS


@ti.func
def stretch_column_hessian(f, area, e):
    """3x3 Hessian of E a/2 (|f| − 1)² with respect to the column f [N/m · m² = J].

    Exact for |f| >= 1; for a compressed column the transverse part is clamped to 0 (PSD).
    """
    s = ti.max(f.norm(), SHEAR_EPS)
    fh = f / s
    p = fh.outer_product(fh)
    t = ti.max(0.0, 1.0 - 1.0 / s)
    return area * e * (p + t * (ti.Matrix.identity(float, 3) - p))


@ti.func
def stretch_compression_term(f, area, e):
    """What :func:`stretch_column_hessian` clamps away: E a min(0, 1 − 1/|f|) (I − f̂f̂ᵀ).

    Negative semi-definite; zero for a column in tension. The sum of the two is the exact
    Hessian of E a/2 (|f| − 1)² everywhere (the geometric stiffness of compression).
    """
    s = ti.max(f.norm(), SHEAR_EPS)
    fh = f / s
    return (
        area
        * e
        * ti.min(0.0, 1.0 - 1.0 / s)
        * (ti.Matrix.identity(float, 3) - fh.outer_product(fh))
    )


@ti.func
def shear_angle_gradient(f_u, f_v):
    """r = 2θ_s = asin(f̂_u·f̂_v) and (∂r/∂F_u, ∂r/∂F_v), as in Eq. 8 (3-vectors, 1/m)."""
    s_u = ti.max(f_u.norm(), SHEAR_EPS)
    s_v = ti.max(f_v.norm(), SHEAR_EPS)
    uh = f_u / s_u
    vh = f_v / s_v
    c = ti.math.clamp(uh.dot(vh), -1.0, 1.0)
    r = ti.asin(c)
    w_u = vh - c * uh
    w_v = uh - c * vh
    s = w_u.norm()
    a_u = 0.0 * w_u  # zero of the inputs' precision (the solver works in float64)
    a_v = 0.0 * w_v
    if s > SHEAR_EPS:
        a_u = w_u / (s * s_u)
        a_v = w_v / (s * s_v)
    return r, a_u, a_v


@ti.func
def membrane_gradient_f(f_u, f_v, area, e_u, e_v, e_s):
    """(∂U/∂F_u, ∂U/∂F_v) of Eq. 7, the same values as forces.eq8_membrane_gradient (tested)
    built from :func:`shear_angle_gradient`, and kept in the precision of its inputs."""
    s_u = ti.max(f_u.norm(), SHEAR_EPS)
    s_v = ti.max(f_v.norm(), SHEAR_EPS)
    r, a_u, a_v = shear_angle_gradient(f_u, f_v)
    g_u = area * (e_u * (s_u - 1.0) * f_u / s_u + e_s * r * a_u)
    g_v = area * (e_v * (s_v - 1.0) * f_v / s_v + e_s * r * a_v)
    return g_u, g_v


@ti.func
def membrane_hessian_f(f_u, f_v, area, e_u, e_v, e_s):
    """PSD Hessian of Eq. 7's membrane energy with respect to F = [F_u, F_v] (6x6).

    Returned as its three 3x3 blocks (H_uu, H_uv, H_vv); H_vu = H_uvᵀ. The Hessian with
    respect to the vertex positions is H_ij = Σ_αβ c_α,i c_β,j H_αβ, with F_α = Σ_i c_α,i x_i.
    Stretch: exact, clamped in compression; shear: Gauss-Newton (module docstring).
    """
    _, a_u, a_v = shear_angle_gradient(f_u, f_v)
    k = area * e_s
    h_uu = stretch_column_hessian(f_u, area, e_u) + k * a_u.outer_product(a_u)
    h_vv = stretch_column_hessian(f_v, area, e_v) + k * a_v.outer_product(a_v)
    h_uv = k * a_u.outer_product(a_v)
    return h_uu, h_uv, h_vv


@ti.func
def seam_spring_hessian(d, rest, k):
    """3x3 block H of U = k/2 (|d| − r)², d = x_a − x_b; the pair's 6x6 is [[H, −H], [−H, H]].

    r = 0 gives k I (exact). Otherwise exact when stretched, transverse part clamped at 0
    when compressed (PSD).
    """
    h = k * (ti.Matrix.identity(float, 3) + 0.0 * d.outer_product(d))  # precision of d
    if rest > 0.0:
        length = ti.max(d.norm(), SHEAR_EPS)
        dh = d / length
        p = dh.outer_product(dh)
        h = k * (p + ti.max(0.0, 1.0 - rest / length) * (ti.Matrix.identity(float, 3) - p))
    return h


@ti.func
def hinge_hessian_block(stiffness, g_i, g_j):
    """Block (i, j) of the Gauss-Newton bending Hessian E_b ∇θ_b ∇θ_bᵀ (3x3) [N·m/m²].

    ``g_i``, ``g_j`` are ∂θ_b/∂x_i, ∂θ_b/∂x_j from
    :func:`sandbox.sim.forces.dihedral_angle_gradient`. Exact at θ_b = θ_0.
    """
    return stiffness * g_i.outer_product(g_j)
