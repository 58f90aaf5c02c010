"""Scaled inertia (mass scaling): the explicit step of a run that looks for a rest shape.

A cloth moving overdamped follows the drag γ m and its forces, not its inertia, while the
explicit step of Eq. 2 is set by inertia alone (dt < 2/ω_max, ω_max² the largest eigenvalue
of M⁻¹K). Scaling the inertia by s and keeping the weight and the drag keeps the rest shape
and, while the motion stays overdamped, the path, and lengthens the stable step by √s. The
fine level of a coarse-to-fine drape (:mod:`sandbox.garment.multilevel`) and the window's
refit after a resize (:class:`sandbox.app.session.Session`) run this way.
"""

import contextlib


@contextlib.contextmanager
def scaled_inertia(scene, factor: float):
    """Run ``scene`` with its inertia ``factor`` (s) times its mass, its weight and its drag
    unchanged: particle masses x s, gravity and the damping γ / s, restored on exit.

    Eq. 2 with inertia s m, weight m g and drag γ m reads v' = (F/m + g)/s − (γ/s) v: the
    rest shape (F + m g = 0, the contact and friction bounds, all relative to the weight) is
    the same, and so is an overdamped path (velocity F/(γ m)), while the fastest mode slows
    to ω_max/√s and the stable explicit step grows by √s. Mass scaling, the quasi-static
    device of explicit finite-element codes; the equilibrium residual, measured in units of
    the weight, is unchanged by it.
    """
    saved = scale_inertia(scene, factor)
    try:
        yield
    finally:
        restore_inertia(scene, saved)


def scale_inertia(scene, factor: float):
    """:func:`scaled_inertia`'s entry: scales the scene and returns what
    :func:`restore_inertia` puts back (None for a factor of 1, which changes nothing)."""
    if factor == 1.0:
        return None
    model, control = scene.model, scene.control
    saved = (model.particle_mass.to_numpy(), model.particle_inv_mass.to_numpy(),
             control.gravity[None].to_numpy(), float(control.damping_per_s[None]))  # fmt: skip
    mass, inv_mass, gravity, gamma = saved
    model.particle_mass.from_numpy(mass * factor)
    model.particle_inv_mass.from_numpy(inv_mass / factor)
    control.gravity[None] = gravity / factor
    control.damping_per_s[None] = gamma / factor
    return saved


def restore_inertia(scene, saved) -> None:
    """Undo :func:`scale_inertia` (``saved`` is what it returned)."""
    if saved is None:
        return
    mass, inv_mass, gravity, gamma = saved
    scene.model.particle_mass.from_numpy(mass)
    scene.model.particle_inv_mass.from_numpy(inv_mass)
    scene.control.gravity[None] = gravity
    scene.control.damping_per_s[None] = gamma
