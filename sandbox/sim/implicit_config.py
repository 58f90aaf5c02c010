"""Settings of the implicit Euler solver (:mod:`sandbox.sim.implicit`): one frozen dataclass.

The solver reads them once, at construction; the contact fields are compiled into its
kernels as constants. A scene sets ``linear_solver`` (``[simulation] linear_solver``); the
rest are for Python callers, who pass ``ImplicitEulerSolver(model, config=ImplicitConfig(...))``.
"""

import dataclasses

import taichi as ti

from sandbox import runtime
from sandbox.errors import SandboxError

LINEAR_SOLVERS = ("auto", "direct", "cg")
REAL = ti.f64
"""The solver's own precision, whatever Taichi's default float: with float32 positions a
stiff membrane's strain (x_j − x_i, |F_u| − 1) drowns in round-off (the residual force of
denim x100 stayed at ~20x the vertex weight), so Newton could not reach its tolerance. The
state is read and written in the default float; everything in between is float64."""


@dataclasses.dataclass(frozen=True)
class ImplicitConfig:
    """Newton, line search and body-contact settings of backward Euler (SI units).

    Newton's tolerance (:func:`sandbox.sim.implicit_line_search.newton_error_estimate`) is
    ``tol_m_s·h + rel_tol·max_i |x_i − x_n,i|``. Loose tolerances fake damping: Newton
    stopped early leaves every step short of its solution in the same (slow) direction, so a
    creeping cloth lags. Measured on the cantilever (docs/implicit.md): 1e-3 m/s, or 1e-4 m/s
    + 1 % of the motion, took 11x and 4x more steps to settle than the defaults.
    """

    tol_m_s: float = 1e-4
    """Absolute part of the Newton tolerance, as a velocity [m/s] (1.7 µm at 1/60 s)."""
    rel_tol: float = 0.0
    """Relative part [1]: a fraction of the largest vertex motion of the step (0: off; the
    cantilever settled 4x slower with 1 %)."""
    cg_tol: float = 1e-1
    """CG stops when |r| <= cg_tol |r_0| [1] (2-norm of the force residual): Newton tolerates
    an inexact inner solve, and a tenth costs few iterations."""
    max_newton: int = 50
    """Newton iterations per step before the step is counted unconverged in ``stats()``."""
    max_cg: int = 2000
    """CG iterations per Newton iteration (a cap; the tolerance normally stops CG first)."""
    step_residual: bool = True
    """Evaluate the equilibrium residual at the end of every step for ``stats()`` (one more
    gradient and Hessian evaluation a step: about 6 % of a three-iteration step of the
    sheath dress at 1.5 cm). The live sandbox turns it off; a scene's metrics measure the
    residual of the final state apart (:mod:`sandbox.sim.residual`)."""
    compression_stiffness: bool = False
    """Keep the (negative) geometric stiffness of compressed warp/weft columns in the Newton
    matrix and truncate CG at negative curvature. Off: measured slower on a falling stiff
    sheet (docs/implicit.md)."""
    linear_solver: str = "auto"
    """How each Newton system is solved. ``"direct"``: assembled and factorised by sparse LU,
    the factors reused as CG's preconditioner while they work (:mod:`sandbox.sim.sparse`);
    ``"cg"``: matrix-free CG with the block-Jacobi preconditioner, all in Taichi kernels
    (what a GPU runs); ``"auto"``: direct on the CPU, cg elsewhere or with
    ``compression_stiffness`` (whose matrix can be indefinite)."""
    banded_flops: float = 3e7
    """The direct solver factorises a narrow band (N·(bw + 1)² up to this) by banded
    Cholesky, about 10 ms at the default; a wider one by SuperLU
    (:class:`sandbox.sim.sparse.FactorisedSolver`)."""
    armijo: float = 1e-4
    """Armijo constant of the backtracking line search [1]: a step must lower E by this
    fraction of its linear prediction (the usual textbook value)."""
    fused_particle_limit: int = 3000
    """On the CPU, up to this many particles the whole CG loop runs in one serial kernel
    launch (no launch and read-back per iteration); above it each iteration is one
    parallel launch."""
    contact_stiffness: float = 1e3
    """Body contact penalty stiffness as a multiple of a vertex's m/h² [1]: a vertex pressed
    on the body by a hundred times its weight sinks 0.27 mm into the thickness at 1/60 s.
    Adding 10 or 100 times the stiffness of the seams and triangles pulling on the vertex
    made the line search halve its steps 20-150 times a step and the sewing of the A-line
    skirt diverge; deeper pulls are left to the contact response after the solve."""
    contact_stiffening_max: float = 8.0
    """A vertex that starts a step behind its body face (the penalty let it through) has its
    own penalty stiffness doubled, up to this factor [1], until it has no body face within
    reach: cloth pulled tight over a ridge (a shoulder under a dress too small for the
    body) presses on it with hundreds of its weight, and a small vertex's m/h² penalty
    let it sink 2-3 mm, be lifted out, sink again, every other step."""
    contact_reach_m: float = 2e-2
    """A vertex gets a contact plane for the step when a body face is within this distance
    [m] plus twice its predicted motion (|x̂ − x_n|) of its start."""
    crease_reach_m: float = 5e-3
    """A vertex's second contact plane (a concave crease: armpit, under the bust) comes from a
    body face within this distance [m] plus twice its predicted motion of its start: the
    faces it can reach this step. Looking as far as ``contact_reach_m`` for it made the
    contact planes 1.5x slower on the sheath dress at 1.5 cm (every vertex on a flat part
    of the body searched its whole reach for a crease that is not there)."""
    plane_reuse_m: float = 1e-3
    """A vertex keeps the contact planes found at an earlier step while it has moved less
    than this [m] since and no body has changed; each query looks twice this farther than
    the step needs, so a face it did not find stays out of reach."""
    plane_band_m: float = 1e-9
    """A vertex within this distance [m] of a contact plane, or behind it, has the plane's
    penalty in its Newton matrix; one farther in front does not, and a Newton step that
    would carry it through the plane stops it on the plane."""
    friction_slip_m_s: float = 1e-3
    """Friction's smoothing speed ε_v [m/s]: below it the friction force grows linearly with
    the tangential speed (sticking creeps at most this fast), above it it is μ λ (Coulomb)."""
    lift_max_m: float = 0.03
    """The longest lift [m] out of the body after a solve; a longer one means planes that
    do not bound the body near the vertex, and it is not made."""
    lift_min_sin2: float = 0.25
    """A crease's two planes are both used for a lift only when sin² of the angle between
    their normals exceeds this [1] (30° to 150°): the line where nearly parallel or opposite
    planes meet is far away (1e-9 stretched the vest's and the T-shirt's triangles to 3.2
    times their length)."""

    def __post_init__(self):
        if self.linear_solver not in LINEAR_SOLVERS:
            raise SandboxError(f"linear_solver must be one of {', '.join(LINEAR_SOLVERS)}, "
                               f"got {self.linear_solver!r}")  # fmt: skip


def resolve_linear_solver(name: str, compression_stiffness: bool = False) -> str:
    """``"direct"`` or ``"cg"`` for the ``linear_solver`` setting (see :class:`ImplicitConfig`)."""
    if name not in LINEAR_SOLVERS:
        raise SandboxError(f"linear_solver must be one of {', '.join(LINEAR_SOLVERS)}, "
                           f"got {name!r}")  # fmt: skip
    if name == "auto":
        return "direct" if runtime.arch() == "cpu" and not compression_stiffness else "cg"
    if name == "direct" and compression_stiffness:
        raise SandboxError("linear_solver 'direct' needs a positive definite matrix: "
                           "turn compression_stiffness off or use 'cg'")  # fmt: skip
    return name
