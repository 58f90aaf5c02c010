"""The sewing phase (paper §2.4): the seam springs pull the placed panels together, then
seams and cloth stiffen to their full strength and gravity acts.

While the seams close, the scene's settings are changed for the phase only (gravity, the
speed limit, friction with ``implicit_euler``, self-collision off on request) through
:class:`_SewingSettings`, which puts every one of them back, whatever happens.
"""

from __future__ import annotations

import math
import time

import numpy as np

from sandbox.garment.config import SewingConfig
from sandbox.garment.metrics import hangs_from


class _SewingSettings:
    """The scene settings the sewing phase changes, saved on entry and restored on exit."""

    def __init__(self, scene, config: SewingConfig, gravity_fraction: float,
                 self_collision: bool):  # fmt: skip
        self.scene, self.config = scene, config
        self.gravity_fraction, self.self_collision = gravity_fraction, self_collision

    def __enter__(self):
        from sandbox import runtime

        scene, config = self.scene, self.config
        solver, control = scene.solver, scene.control
        self.gravity = control.gravity[None]
        control.gravity[None] = [float(self.gravity_fraction) * float(g) for g in self.gravity]
        self.self_collider = solver.self_collider
        self.friction = solver.friction()
        solver.set_speed_limit(config.speed_limit_m_s)  # the implicit solver needs none
        if scene.spec.simulation.integrator == "implicit_euler":
            solver.set_friction(self.friction.uniform(config.friction_implicit))
        if not self.self_collision:
            solver.self_collider = None  # the solver runs the fused step without its passes
        self.k_final = scene.model.seam_stiffness_np.astype(runtime.float_dtype())
        return self

    def __exit__(self, *exc):
        scene = self.scene
        scene.model.set_seam_stiffness(self.k_final)
        scene.control.gravity[None] = self.gravity
        scene.solver.self_collider = self.self_collider  # first: the cloth's μ is its own
        scene.solver.set_speed_limit(0.0)
        scene.solver.set_friction(self.friction)
        return False


def sewing_gravity_fraction(scene, config: SewingConfig) -> float:
    """Gravity while sewing: :attr:`SewingConfig.gravity_fraction_tops` for a garment that
    hangs from the shoulders (:func:`~sandbox.garment.metrics.hangs_from`), none for one that
    hangs from the waist, whose panels would slide down before their seams hold them."""
    mannequin = scene.garment.mannequin
    shoulders = hangs_from(scene.model.initial_positions_np, mannequin) == "shoulder_point_left"
    return config.gravity_fraction_tops if shoulders else 0.0


def sew(scene, config: SewingConfig | None = None, *, gravity_fraction: float | None = None,
        ) -> dict:  # fmt: skip
    """Sewing phase: close the seams, then stiffen them and turn full gravity on.

    The seam springs pull at ``config.stiffness_factor`` of their final stiffness (as stiff
    as the cloth: the seams then hold the garment's weight) until every spring is shorter
    than ``config.gap_m``, the largest gap stalls (``stall_frames``, ``stall_shrink``) or
    ``time_limit_s`` of simulated time has passed. Meanwhile no particle keeps a speed above
    ``speed_limit_m_s``. Then the seams stiffen over ``ramp_frames`` frames at the scene's own
    step, without the speed limit. With ``implicit_euler`` and no gravity, every sewing frame
    ends at rest (``at_rest_implicit``). ``gravity_fraction`` scales gravity while sewing
    (default :func:`sewing_gravity_fraction`).

    Returns ``{"sew_sim_time_s", "sew_wall_time_s", "sew_frames", "sew_gap_m", "sew_dt_s",
    "sew_gravity_fraction", "sew_stalled", "sew_at_rest"}``.
    """
    from sandbox.scene.run import SimulationDiverged

    config = config or SewingConfig()
    model, solver, state, control = scene.model, scene.solver, scene.state, scene.control
    out = {"sew_sim_time_s": 0.0, "sew_wall_time_s": 0.0, "sew_frames": 0, "sew_gap_m": 0.0}
    if not model.seam_count:
        return out
    pairs, rest = model.seam_pairs_np, model.seam_rest_np
    t0 = time.perf_counter()
    solver.reset_watch()
    if gravity_fraction is None:
        gravity_fraction = sewing_gravity_fraction(scene, config)
    frame_s = scene.dt_s * scene.steps_per_frame
    frames = max(1, math.ceil(config.time_limit_s / frame_s))
    n_ramp = config.ramp_frames
    ramp = [config.stiffness_factor ** (1 - k / n_ramp) for k in range(n_ramp + 1)]
    at_rest = (config.at_rest_implicit and scene.spec.simulation.integrator == "implicit_euler"
               and gravity_fraction == 0.0)  # fmt: skip
    gap, gaps, stalled = math.inf, [], False
    done = 0
    with _SewingSettings(scene, config, gravity_fraction, config.self_collision) as saved:
        k_final = saved.k_final
        model.set_seam_stiffness(k_final * ramp[0])
        while done < frames:
            solver.advance(state, control, frame_s / scene.steps_per_frame, scene.steps_per_frame)
            done += 1
            if at_rest:
                state.v.fill(0.0)
            bad = solver.first_bad()
            if bad is not None:
                raise SimulationDiverged(f"{scene.spec.source}: the simulation diverged while "
                                         f"sewing (vertex {bad[1]})")  # fmt: skip
            x = state.positions()
            gap = float(np.max(np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1) - rest))
            gaps.append(gap)
            if gap < config.gap_m:
                break
            back = gaps[-1 - config.stall_frames] if len(gaps) > config.stall_frames else math.inf
            if gap > config.stall_shrink * back:
                stalled = True  # a corner held by the body: the ramp's stiffer seams close it
                break
        solver.set_speed_limit(0.0)  # the seams have closed: no shock left to tame
        for f in ramp[1:]:  # stiffen the seams, then gravity acts
            model.set_seam_stiffness(k_final * f)
            solver.advance(state, control, scene.dt_s, scene.steps_per_frame)
            done += 1
            if at_rest:
                state.v.fill(0.0)
    out.update(sew_sim_time_s=done * frame_s, sew_wall_time_s=time.perf_counter() - t0,
               sew_frames=done, sew_gap_m=gap, sew_dt_s=frame_s / scene.steps_per_frame,
               sew_gravity_fraction=float(gravity_fraction), sew_stalled=stalled,
               sew_at_rest=at_rest)  # fmt: skip
    return out
