"""The paper's equations as Taichi functions (Leong, Kuo, Fang 2011, §2.3).

Each equation lives in one function whose docstring names it. Symbols follow the paper:
``Δu, Δv`` are rest edge vectors in the pattern plane (u along the warp, v along the weft),
``Δx, Δy, Δz`` the deformed edge vectors, ``k_ij`` their dot products, ``S_u, S_v`` the
stretch ratios, ``θ_s`` the shear angle, ``θ_b`` the dihedral (bending) angle.

Forces are the exact negative gradient of the energies (Eq. 8); ``tests/test_forces.py``
checks them against finite differences of the energy in float64.
"""

import taichi as ti

SHEAR_EPS = 1e-12


@ti.func
def eq6_strain(d1, d2, du1, dv1, du2, dv2):
    """Eq. 6: S_u, S_v and θ_s of one triangle, written as in the paper.

    Args: ``d1 = q2 − q1`` and ``d2 = q3 − q1`` deformed edges (3-vectors, m);
    ``(du1, dv1)`` and ``(du2, dv2)`` the same edges at rest in the pattern plane (m).
    Returns ``(S_u, S_v, θ_s)``; θ_s in radians. The solver uses the equivalent
    deformation-gradient form in :func:`deformation_columns` (identical values, tested).
    """
    k11 = d1.dot(d1)
    k22 = d2.dot(d2)
    k12 = d1.dot(d2)
    det = du1 * dv2 - du2 * dv1
    s_u = ti.sqrt(k11 * dv2**2 + k22 * dv1**2 - 2.0 * k12 * dv1 * dv2) / det
    s_v = ti.sqrt(k11 * du2**2 + k22 * du1**2 - 2.0 * k12 * du1 * du2) / det
    arg = (k12 * (du1 * dv2 + du2 * dv1) - k11 * du2 * dv2 - k22 * du1 * dv1) / (s_u * s_v * det**2)
    theta_s = 0.5 * ti.asin(ti.math.clamp(arg, -1.0, 1.0))
    return s_u, s_v, theta_s


@ti.func
def deformation_columns(x0, x1, x2, rest_inv):
    """Columns of the deformation gradient F = [F_u, F_v] (3x2) of one triangle.

    ``rest_inv`` is the inverse of the rest edge matrix [[Δu1, Δu2], [Δv1, Δv2]], so that
    F_u is the image of the unit warp direction and F_v of the unit weft direction:
    S_u = |F_u|, S_v = |F_v| and sin(2θ_s) = F_u·F_v / (S_u S_v), which is Eq. 6.
    """
    d1 = x1 - x0
    d2 = x2 - x0
    f_u = rest_inv[0, 0] * d1 + rest_inv[1, 0] * d2
    f_v = rest_inv[0, 1] * d1 + rest_inv[1, 1] * d2
    return f_u, f_v


@ti.func
def eq7_membrane_energy(f_u, f_v, area, e_u, e_v, e_s):
    """Eq. 7: U_u + U_v + U_s of one triangle [J].

    U_u = E_u a/2 (S_u − 1)^2, U_v = E_v a/2 (S_v − 1)^2, U_s = E_s a/2 (2θ_s)^2, with E in
    N/m (energy per rest area per unit strain squared) and ``a`` the rest area [m^2].
    """
    s_u = f_u.norm()
    s_v = f_v.norm()
    c = ti.math.clamp(f_u.dot(f_v) / (s_u * s_v), -1.0, 1.0)
    two_theta_s = ti.asin(c)
    return 0.5 * area * (e_u * (s_u - 1.0) ** 2 + e_v * (s_v - 1.0) ** 2 + e_s * two_theta_s**2)


@ti.func
def eq8_membrane_gradient(f_u, f_v, area, e_u, e_v, e_s):
    """Eq. 8 for the membrane: (∂U/∂F_u, ∂U/∂F_v), the exact gradient of Eq. 7.

    With û = F_u/S_u, v̂ = F_v/S_v, c = û·v̂ = sin(2θ_s):
      ∂U/∂F_u = a [E_u (S_u−1) û + E_s (2θ_s) (v̂ − c û) / (S_u √(1−c²))]
      ∂U/∂F_v = a [E_v (S_v−1) v̂ + E_s (2θ_s) (û − c v̂) / (S_v √(1−c²))]
    |v̂ − c û| = √(1−c²), so the shear term stays bounded as the shear approaches 90°.
    The force on vertex i is −(c_u,i ∂U/∂F_u + c_v,i ∂U/∂F_v), where F_u = Σ_i c_u,i x_i.
    """
    s_u = ti.max(f_u.norm(), SHEAR_EPS)
    s_v = ti.max(f_v.norm(), SHEAR_EPS)
    uh = f_u / s_u
    vh = f_v / s_v
    c = ti.math.clamp(uh.dot(vh), -1.0, 1.0)
    two_theta_s = ti.asin(c)
    w_u = vh - c * uh
    w_v = uh - c * vh
    s = w_u.norm()
    shear = 0.0
    if s > SHEAR_EPS:
        shear = e_s * two_theta_s / s
    g_u = area * (e_u * (s_u - 1.0) * uh + shear * w_u / s_u)
    g_v = area * (e_v * (s_v - 1.0) * vh + shear * w_v / s_v)
    return g_u, g_v


@ti.func
def membrane_damping_gradient(f_u, f_v, r_u, r_v, area, e_u, e_v, e_s, beta):
    """Strain-rate damping of the membrane: (∂D/∂Ḟ_u, ∂D/∂Ḟ_v) of the dissipation
    D = β a/2 (E_u Ṡ_u² + E_v Ṡ_v² + E_s (2θ̇_s)²), the rates of Eq. 6's strains.

    ``r_u = Ḟ_u``, ``r_v = Ḟ_v`` are the rates of the deformation columns [1/s] (the same
    combination of the corner velocities as F of the positions), β [s] the damping time.
    The force on vertex i is −(c_u,i g_u + c_v,i g_v), as for Eq. 8; its power is −2D ≤ 0,
    so it only removes energy, and it acts on strain rates alone: a rigid motion and a
    slow drape (rate × β ≪ strain) are untouched. It is Rayleigh's stiffness-proportional
    damping of this energy with a positive-definite (Gauss–Newton) stiffness: a mode of
    angular frequency ω decays at about β ω²/2 [1/s], fast for the contact chatter of
    stiff fabrics (ω ~ 10^3-10^4 rad/s), negligible for draping (ω ~ 10 rad/s).
    """
    s_u = ti.max(f_u.norm(), SHEAR_EPS)
    s_v = ti.max(f_v.norm(), SHEAR_EPS)
    uh = f_u / s_u
    vh = f_v / s_v
    c = ti.math.clamp(uh.dot(vh), -1.0, 1.0)
    w_u = vh - c * uh
    w_v = uh - c * vh
    s = ti.max(w_u.norm(), SHEAR_EPS)
    # Ṡ_u, Ṡ_v and (2θ_s)˙ (∂(2θ_s)/∂F_u = w_u / (S_u √(1−c²)), as in Eq. 8's shear term)
    du = uh.dot(r_u)
    dv = vh.dot(r_v)
    d_shear = w_u.dot(r_u) / (s * s_u) + w_v.dot(r_v) / (s * s_v)
    g_u = beta * area * (e_u * du * uh + e_s * d_shear * w_u / (s * s_u))
    g_v = beta * area * (e_v * dv * vh + e_s * d_shear * w_v / (s * s_v))
    return g_u, g_v


@ti.func
def dihedral_angle(x0, x1, x2, x3):
    """θ_b of Eq. 7: signed angle between the two faces of a hinge [rad].

    The hinge edge is x0–x1; x2 is opposite it in face (x0, x1, x2) and x3 in face
    (x1, x0, x3). θ_b = 0 for a flat hinge; positive when the hinge folds towards the
    normal of the first face.
    """
    e = x1 - x0
    n1 = e.cross(x2 - x0)
    n2 = (x3 - x0).cross(e)
    s = n1.cross(n2).dot(e) / ti.max(e.norm(), SHEAR_EPS)
    return ti.atan2(s, n1.dot(n2))


@ti.func
def dihedral_angle_gradient(x0, x1, x2, x3):
    """θ_b and ∂θ_b/∂x_i for the four hinge vertices (Bridson, Marino, Fedkiw 2003, §4).

    Returns ``(θ_b, g0, g1, g2, g3)``; the g sum to zero (translation invariance) and have
    zero total moment (rotation invariance). θ_b is the same as :func:`dihedral_angle`.
    """
    e = x1 - x0
    le = ti.max(e.norm(), SHEAR_EPS)
    n1 = e.cross(x2 - x0)
    n2 = (x3 - x0).cross(e)
    theta = ti.atan2(n1.cross(n2).dot(e) / le, n1.dot(n2))
    n1sq = ti.max(n1.norm_sqr(), SHEAR_EPS * SHEAR_EPS)
    n2sq = ti.max(n2.norm_sqr(), SHEAR_EPS * SHEAR_EPS)
    g2 = -le / n1sq * n1
    g3 = -le / n2sq * n2
    t2 = (x2 - x0).dot(e) / le  # projection of the opposite vertices on the edge
    t3 = (x3 - x0).dot(e) / le
    g1 = t2 / n1sq * n1 + t3 / n2sq * n2
    g0 = -(g1 + g2 + g3)
    return theta, g0, g1, g2, g3
