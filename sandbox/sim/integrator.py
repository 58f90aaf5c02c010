"""The contract every cloth integrator implements, so callers treat them alike.

Two integrators implement :class:`Integrator`: the explicit
:class:`~sandbox.sim.solver.SymplecticEulerSolver` (paper Eq. 2) and the implicit
:class:`~sandbox.sim.implicit.ImplicitEulerSolver` (backward Euler by Newton). The run loop,
the sewing, the guard and the interactive window use only what is listed here: stepping,
compiling ahead (``warm_up``), the NaN watch, the solver's own counters, the self-collision
slot, the sewing's speed limit and the contacts' friction.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Protocol, runtime_checkable

if TYPE_CHECKING:
    from sandbox.collision.self_contact import SelfCollider
    from sandbox.sim.model import Control, Model, State


@dataclasses.dataclass(frozen=True)
class ContactFriction:
    """The friction coefficients of a scene's contacts [1], read or written as one value."""

    body: tuple[tuple[float, float], ...] = ()
    """(μ_s, μ_k), static and kinetic, of each body collider in ``model.colliders`` order."""
    cloth: float | None = None
    """μ between cloth layers (the self-collider's), or None when there is no self-collider."""

    def uniform(self, mu: float) -> ContactFriction:
        """The same contacts, every coefficient set to ``mu``."""
        cloth = None if self.cloth is None else float(mu)
        return ContactFriction(tuple((float(mu), float(mu)) for _ in self.body), cloth)


def read_friction(model: Model, self_collider: SelfCollider | None) -> ContactFriction:
    """The friction of the model's body colliders and of ``self_collider`` (if any)."""
    body = tuple((float(c.mu_s[None]), float(c.mu_k[None])) for c in model.colliders)
    cloth = None if self_collider is None else float(self_collider.mu[None])
    return ContactFriction(body, cloth)


def write_friction(model: Model, self_collider: SelfCollider | None,
                   friction: ContactFriction) -> None:  # fmt: skip
    """Set the body colliders' (μ_s, μ_k) and, where both exist, the self-collider's μ."""
    for c, (mu_s, mu_k) in zip(model.colliders, friction.body, strict=True):
        c.mu_s[None], c.mu_k[None] = mu_s, mu_k
    if self_collider is not None and friction.cloth is not None:
        self_collider.mu[None] = friction.cloth


@runtime_checkable
class Integrator(Protocol):
    """A cloth integrator: advances a :class:`~sandbox.sim.model.State` of its model.

    ``self_collider`` is the cloth's self-collision (``model.self_collider`` at
    construction); setting it to None switches its passes off (the sewing does this).
    """

    model: Model
    self_collider: SelfCollider | None

    def step(self, state_in: State, state_out: State, control: Control, dt: float,
             index: int = 0) -> None:  # fmt: skip
        """Advance one step of ``dt`` [s] from ``state_in`` into ``state_out`` (may be the
        same); ``index`` is the global step number the NaN watch records."""
        ...

    def advance(self, state: State, control: Control, dt: float, steps: int,
                first_index: int = 0) -> None:  # fmt: skip
        """Advance ``state`` in place by ``steps`` steps of ``dt`` [s]."""
        ...

    def warm_up(self, state: State, control: Control) -> None:
        """Compile every kernel a run of this model can reach; the state is not changed."""
        ...

    def reset_watch(self) -> None:
        """Forget the first non-finite position seen so far (see :meth:`first_bad`)."""
        ...

    def first_bad(self) -> tuple[int, int] | None:
        """(step, vertex) of the first non-finite position since the last reset, or None."""
        ...

    def stats(self) -> dict:
        """The integrator's own counters since :meth:`reset_stats` (empty if it has none)."""
        ...

    def reset_stats(self) -> None:
        """Zero the counters of :meth:`stats`."""
        ...

    def internal_energy(self, state: State) -> float:
        """The cloth's elastic energy U at ``state`` [J]."""
        ...

    def set_speed_limit(self, limit_m_s: float) -> None:
        """Cap each particle's speed after its velocity update at ``limit_m_s`` [m/s]
        (0: no cap). Not physics: the sewing uses it so a closing seam cannot fling a
        panel; an integrator that needs no cap for that documents why it ignores it."""
        ...

    def friction(self) -> ContactFriction:
        """The friction of the body contacts and of the cloth against itself."""
        ...

    def set_friction(self, friction: ContactFriction) -> None:
        """Set the friction of the contacts (as read by :meth:`friction`)."""
        ...
