"""How the interactive sandbox steps its cloth (:class:`LiveSolver`), one frozen setting."""

import dataclasses

from sandbox.errors import SandboxError

INTEGRATORS = ("implicit_euler", "symplectic_euler")


@dataclasses.dataclass(frozen=True)
class LiveSolver:
    """How the sandbox steps its cloth: the window must keep up with the user, so what
    counts is simulated time per wall second and how soon the cloth is at rest again.

    ``implicit_euler`` (default): backward Euler (:mod:`sandbox.sim.implicit`) with a fixed
    Newton budget, ``steps_per_frame`` steps of a 1/30 s frame and at most
    ``newton_iterations`` Newton iterations a step, each solved by matrix-free conjugate
    gradients. A step left short of Newton's tolerance is stable (each iteration lowers
    the step's energy) and more damped than backward Euler. One step of a whole frame with
    five iterations simulates 5-7 times more time per wall second than the explicit step
    at 1.5 cm, and holds the cloth still once at rest, on the body it was dressed on and
    after a resize (docs/gui.md gives the figures).
    ``symplectic_euler``: the paper's Eq. 2 at its explicit step (hundreds of steps a
    frame at 1.5 cm), as a drape runs it.
    A resize refits overdamped (:data:`sandbox.app.session.SETTLE_DAMPING_PER_S`) either
    way. ``python benchmarks/bench_gui.py --integrator NAME`` measures either.
    """

    integrator: str = "implicit_euler"
    newton_iterations: int = 5
    """Newton iterations per step at most [1] (implicit_euler)."""
    steps_per_frame: int = 1
    """Steps per 1/30 s frame [1] (implicit_euler; the explicit step is set by stability)."""

    def __post_init__(self):
        if self.integrator not in INTEGRATORS:
            raise SandboxError(f"integrator must be one of {', '.join(INTEGRATORS)}, "
                               f"got {self.integrator!r}")  # fmt: skip
        if self.newton_iterations < 1 or self.steps_per_frame < 1:
            raise SandboxError("newton_iterations and steps_per_frame must be at least 1")

    @property
    def implicit(self) -> bool:
        return self.integrator == "implicit_euler"


DEFAULT_LIVE_SOLVER = LiveSolver()
