"""A guard around any solver: detect instability, roll back, shrink dt, go on.

The guard advances a scene frame by frame. Before each frame it keeps the last good state
(positions and velocities, numpy copies through ``State.positions()/velocities()``). After
the frame it checks the new state:

- **non-finite**: the solver's own watch (``solver.first_bad()``) or any NaN/inf position
  or velocity;
- **energy growth**: the mechanical energy E = kinetic + elastic (``solver.internal_energy``)
  + gravity potential rose by more than ``energy_growth`` × M·|g|·L in one frame (M the cloth
  mass, L the diagonal of its rest bounding box). A passive cloth only loses energy, so a
  rise of a whole "drop over the sheet's own size" in one frame is a blow-up, not physics;
- **hugely stretched** triangles: a warp or weft stretch S_u, S_v (Eq. 6) above
  ``max_stretch`` (default 4, i.e. 300 % strain: a sheet released from a 10 % crumple
  rebounds elastically to about 190 % in places, a blow-up reaches 10⁵ %);
- **inverted** triangles: more than ``max_flip_fraction`` of the triangles turned their
  normal by more than 90° within the frame *while* the mechanical energy rose (by more than
  ``flip_energy`` × M·|g|·L). An exploding mesh flips a large share of its triangles and
  gains energy; a sheet wrapping round an arm at 10 m/s or unfolding from a crumpled start
  also turns most of its triangles over in 1/30 s, but loses energy doing so.

On a failure it restores the last good state, halves dt (the frame is re-run with twice as
many steps, so outputs stay on the frame grid) and tries again, up to ``max_halvings``
times. After ``regrow_frames`` good frames in a row it doubles dt again, never above the
scene's nominal dt. If the frame still fails at the smallest dt, it restores the last good
state (so no NaN can reach an output) and raises :class:`GuardStop` naming the step, the
vertex and the reason. The run loop (``sandbox.scene.run``) reports ``guard_*`` metrics.

The solver is wrapped from outside: nothing in its kernels changes.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from sandbox.errors import SandboxError

log = logging.getLogger(__name__)


STEP_SIZE_RULED_OUT = 8.0
"""A run that still fails with its step shortened this many times did not fail for its step
size, and the guard's message says so instead of suggesting a shorter step."""


class GuardStop(SandboxError):
    """The guard could not recover a run: the message names the step, vertex and reason."""

    def __init__(self, message: str, step: int, vertex: int, reason: str, *,
                 rollbacks: int = 0, dt_s: float | None = None):  # fmt: skip
        super().__init__(message)
        self.step = step
        self.vertex = vertex
        self.reason = reason
        self.rollbacks = rollbacks  # restores of the last good state, the last one included
        self.dt_s = dt_s  # the smallest dt tried [s]


@dataclass
class GuardConfig:
    """Thresholds of the guard (see the module docstring)."""

    max_stretch: float = 4.0
    max_flip_fraction: float = 0.1
    flip_energy: float = 0.01
    energy_growth: float = 1.0
    max_halvings: int = 6
    regrow_frames: int = 10
    enabled: bool = True


@dataclass
class GuardEvent:
    """One rollback: the frame, the dt that failed [s], why, and where."""

    frame: int
    step: int
    dt_s: float
    reason: str
    vertex: int

    def as_dict(self) -> dict:
        return {"frame": self.frame, "step": self.step, "dt_s": self.dt_s,
                "reason": self.reason, "vertex": self.vertex}  # fmt: skip


@dataclass
class Check:
    ok: bool
    reason: str = ""
    vertex: int = -1
    step: int = -1
    max_strain: float = 0.0


def triangle_stretch(x: np.ndarray, tris: np.ndarray, rest_inv: np.ndarray) -> np.ndarray:
    """Warp and weft stretch (S_u, S_v) of Eq. 6 per triangle, (m, 2), from positions (n, 3) [m].

    F = D_s D_m⁻¹ with D_s = [x1 − x0, x2 − x0] (3, 2); S_u, S_v are the norms of its columns.
    """
    ds = np.stack([x[tris[:, 1]] - x[tris[:, 0]], x[tris[:, 2]] - x[tris[:, 0]]], axis=2)
    f = ds @ rest_inv  # (m, 3, 2)
    return np.linalg.norm(f, axis=1)


def triangle_normals(x: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Unnormalised normals (m, 3) (twice the area) of the deformed triangles."""
    return np.cross(x[tris[:, 1]] - x[tris[:, 0]], x[tris[:, 2]] - x[tris[:, 0]])


def max_strain(model, x: np.ndarray) -> float:
    """Largest warp/weft strain max(S − 1) over the model's triangles (0 without any)."""
    if model.tri_count == 0:
        return 0.0
    s = triangle_stretch(x, model.tri_indices_np, model.tri_rest_inv_np)
    return float(np.max(s) - 1.0)


def summary_line(metrics: dict) -> str:
    """One line on what the guard did in a run, from its metrics (the CLI's summary):
    ``guard: 3 rollbacks, dt 0.12 -> 0.06 ms (smallest), 0.12 ms at the end``."""
    return _guard_clause(metrics) + _zones_clause(metrics.get("self_collision_counts") or {})


def _guard_clause(metrics: dict) -> str:
    if not metrics.get("guard_enabled", True):
        return "guard: off (NaN checks only)"
    dt_ms = metrics.get("dt_s", math.nan) * 1e3
    n = int(metrics.get("guard_rollbacks", 0))
    if n == 0:
        return f"guard: no rollbacks, dt {dt_ms:.3g} ms throughout"
    low = metrics.get("guard_min_dt_s", math.nan) * 1e3
    end = metrics.get("guard_final_dt_s", math.nan) * 1e3
    return (f"guard: {n} rollback{'s' * (n != 1)}, dt {dt_ms:.3g} -> {low:.3g} ms (smallest), "
            f"{end:.3g} ms at the end")  # fmt: skip


def _zones_clause(counts: dict) -> str:
    """``; self-collision: rigid impact zones on 12 steps, 1 step stopped (40 vertices)``, or
    nothing when the self-collision fail-safes never ran."""
    zones, frozen = int(counts.get("impact_zone_steps", 0)), int(counts.get("freeze_steps", 0))
    if not zones and not frozen:
        return ""
    out = f"; self-collision: rigid impact zones on {zones} step{'s' * (zones != 1)}"
    if frozen:
        out += (f", {frozen} step{'s' * (frozen != 1)} stopped where zones did not resolve "
                f"(at most {counts.get('frozen_vertices_max', 0)} vertices)")  # fmt: skip
    return out


@dataclass
class StepGuard:
    """Advance a scene a frame at a time with rollback and adaptive dt.

    Args:
        scene: a built :class:`sandbox.scene.build.Scene` (its solver, state, control).
        config: thresholds; ``GuardConfig(enabled=False)`` only advances and checks NaN.
    """

    scene: object
    config: GuardConfig = field(default_factory=GuardConfig)
    halvings: int = 0
    good_frames: int = 0
    rollbacks: int = 0
    steps: int = 0
    events: list = field(default_factory=list)
    min_dt_s: float = math.inf
    max_strain: float = 0.0

    def __post_init__(self):
        model = self.scene.model
        x0 = model.initial_positions_np
        self._mass = np.asarray(model.mass_np, dtype=np.float64)
        free = ~np.asarray(model.pinned_np, bool)
        size = float(np.linalg.norm(x0.max(axis=0) - x0.min(axis=0))) if len(x0) else 1.0
        self._energy_scale = float(self._mass[free].sum()) * 9.80665 * max(size, 1e-3)
        self._tris = model.tri_indices_np
        self._rest_inv = model.tri_rest_inv_np

    # ------------------------------------------------------------------ public
    @property
    def dt_s(self) -> float:
        """The step in use now [s] (the scene's dt divided by 2^halvings)."""
        return self.scene.dt_s / 2**self.halvings

    @property
    def fired(self) -> bool:
        return self.rollbacks > 0

    def metrics(self) -> dict:
        """The ``guard_*`` keys of metrics.json."""
        return {
            "guard_enabled": self.config.enabled,
            "guard_fired": self.fired,
            "guard_rollbacks": self.rollbacks,
            "guard_final_dt_s": self.dt_s,
            "guard_min_dt_s": self.min_dt_s if math.isfinite(self.min_dt_s) else self.dt_s,
            "guard_max_strain": self.max_strain,
            "guard_events": [e.as_dict() for e in self.events[:20]],
        }

    def advance_frame(self, frame: int) -> int:
        """Advance one output frame; returns the number of steps taken.

        Raises GuardStop (state restored to the last good frame) if it cannot recover.
        """
        sc = self.scene
        solver, state, control = sc.solver, sc.state, sc.control
        frame_s = sc.steps_per_frame * sc.dt_s
        if not self.config.enabled:
            solver.advance(state, control, sc.dt_s, sc.steps_per_frame, self.steps)
            bad = solver.first_bad()
            if bad is not None:
                reason = "a position became NaN or infinite"
                raise GuardStop(self._message(bad[0], bad[1], reason), bad[0], bad[1], reason)
            self.steps += sc.steps_per_frame
            return sc.steps_per_frame
        x_good, v_good = state.positions(), state.velocities()
        e_good = self._energy(x_good, v_good)
        n_good = triangle_normals(x_good, self._tris)
        while True:
            sub = sc.steps_per_frame * 2**self.halvings
            dt = frame_s / sub
            solver.reset_watch()
            solver.advance(state, control, dt, sub, self.steps)
            check = self._check(x_good, e_good, n_good, sub)
            if check.ok:
                self.steps += sub
                self.min_dt_s = min(self.min_dt_s, dt)
                self.max_strain = max(self.max_strain, check.max_strain)
                self.good_frames += 1
                if self.halvings and self.good_frames >= self.config.regrow_frames:
                    self.halvings -= 1
                    self.good_frames = 0
                return sub
            state.set(x_good, v_good)  # roll back: the last good state is finite
            solver.reset_watch()
            self.good_frames = 0
            self.events.append(GuardEvent(frame, check.step, dt, check.reason, check.vertex))
            log.info("guard: frame %d, dt %.3g s: %s (vertex %d); rolling back", frame, dt,
                     check.reason, check.vertex)  # fmt: skip
            if self.halvings >= self.config.max_halvings:
                raise GuardStop(self._message(check.step, check.vertex, check.reason, dt),
                                check.step, check.vertex, check.reason,
                                rollbacks=self.rollbacks + 1, dt_s=dt)  # fmt: skip
            self.rollbacks += 1
            self.halvings += 1

    # ------------------------------------------------------------------ checks
    def _energy(self, x: np.ndarray, v: np.ndarray) -> float:
        """Mechanical energy [J]: kinetic + elastic + gravity potential (−Σ m g·x)."""
        sc = self.scene
        g = np.asarray(sc.control.gravity.to_numpy(), dtype=np.float64).reshape(3)
        kinetic = 0.5 * float(np.sum(self._mass[:, None] * v * v))
        potential = -float(np.sum(self._mass * (x @ g)))
        return kinetic + potential + sc.solver.internal_energy(sc.state)

    def _check(self, x_good, e_good, n_good, sub) -> Check:
        sc = self.scene
        bad = sc.solver.first_bad()
        x, v = sc.state.positions(), sc.state.velocities()
        if bad is not None or not (np.isfinite(x).all() and np.isfinite(v).all()):
            if bad is None:
                rows = ~(np.isfinite(x).all(axis=1) & np.isfinite(v).all(axis=1))
                bad = (self.steps + sub - 1, int(np.argmax(rows)))
            return Check(False, "a position became NaN or infinite", bad[1], bad[0])
        end = self.steps + sub - 1
        strain = 0.0
        e = self._energy(x, v)
        if len(self._tris):
            s = triangle_stretch(x, self._tris, self._rest_inv)
            worst = int(np.argmax(s.max(axis=1)))
            strain = float(s[worst].max() - 1.0)
            if strain + 1.0 > self.config.max_stretch:
                return Check(False, f"triangle {worst} stretched by {100 * strain:.0f} %",
                             int(self._tris[worst, 0]), end)  # fmt: skip
            n = triangle_normals(x, self._tris)
            flipped = np.einsum("ij,ij->i", n, n_good) < 0.0
            gained = e - e_good > self.config.flip_energy * self._energy_scale
            if gained and flipped.mean() > self.config.max_flip_fraction:
                t = int(np.argmax(flipped))
                return Check(False, f"{int(flipped.sum())} of {len(flipped)} triangles "
                             f"turned over in one frame while the energy rose by "
                             f"{e - e_good:.3g} J", int(self._tris[t, 0]), end)  # fmt: skip
        if e - e_good > self.config.energy_growth * self._energy_scale:
            speed = np.linalg.norm(v, axis=1)
            return Check(False, f"the energy rose by {e - e_good:.3g} J in one frame "
                         f"(limit {self.config.energy_growth * self._energy_scale:.3g} J)",
                         int(np.argmax(speed)), end)  # fmt: skip
        return Check(True, max_strain=strain)

    def _message(self, step: int, vertex: int, reason: str, dt: float | None = None) -> str:
        sc = self.scene
        where = f"vertex {vertex}"
        piece = next((p for p in sc.model.pieces
                      if p.particle_start <= vertex < p.particle_start + p.particle_count),
                     None)  # fmt: skip
        if piece is not None:
            where += f" (vertex {vertex - piece.particle_start} of cloth {piece.name!r})"
        tried = ""
        if dt is not None:
            tried = (f" The guard rolled back {self.rollbacks + 1} times and shrank dt from "
                     f"{sc.dt_s:.3g} s to {dt:.3g} s without recovering.")  # fmt: skip
        if dt is not None and dt <= sc.dt_s / STEP_SIZE_RULED_OUT:
            advice = self._not_the_step(vertex)
        else:
            advice = (f" dt = {sc.dt_s:.3g} s; the explicit stability estimate is "
                      f'{sc.dt_limit_s:.3g} s: try a smaller dt_s, more damping, dt_s = "auto" '
                      'or integrator = "implicit_euler".')  # fmt: skip
        return (f"{sc.spec.source}: the simulation diverged at step {step} near {where}: "
                f"{reason}.{tried}{advice} No mesh was written.")  # fmt: skip

    def _not_the_step(self, vertex: int) -> str:
        """The advice once a much shorter step did not help: the energy came from something
        that does not shrink with dt. Names the collider the vertex was touching, if any."""
        from trimesh.triangles import closest_point

        sc = self.scene
        x = sc.state.positions()[vertex]  # the last good state (rolled back to)
        out = (" A step that much shorter did not help, so the energy does not come from the "
               "step size.")  # fmt: skip
        for c in sc.model.colliders:
            tris = c.body_x.to_numpy().astype(float)[c.triangles_np]
            d = float(np.linalg.norm(x - closest_point(tris, np.tile(x, (len(tris), 1))),
                                     axis=1).min())  # fmt: skip
            h = float(c.thickness[None])
            if d <= 2.0 * h:
                return out + (f" The vertex was {d * 1e3:.2g} mm from collider {c.name!r} (its "
                              f"contact thickness is {h * 1e3:.2g} mm): the contact there put "
                              "the energy in; look for a sharp edge or corner of that body "
                              "under the cloth.")  # fmt: skip
        return out + (
            " The vertex was touching no collider: look at what pulls on it (pins, "
            "seams, a stiffness far above the fabric presets)."
        )
