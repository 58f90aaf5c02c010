"""The interactive sandbox's state and actions, without a window.

A :class:`Session` holds one garment's panels placed around the mannequin, simulating, and
everything a user does to it: resize the mannequin with the seven measurements, sew panel
edges together (the paper's §2.4 seams: Fig. 5a direction rule, Fig. 5b parametric
matching), undo or clear seams, run frames, pin, drag, reset, save. The GGUI window
(:mod:`sandbox.app.gui`) and the off-screen scripts (:mod:`sandbox.app.script`) call these
methods; neither holds any physics of its own.

Data path: pattern + mannequin (numpy) -> :func:`sandbox.garment.build_drape` (no seams
sewn, room for seam springs) -> Taichi Model/State -> ``solver.advance`` per frame. Seams made
here are :class:`~sandbox.pattern.spec.SeamSpec` records, the same a pattern file holds;
their springs come from :func:`sandbox.garment.seam_springs` and are swapped in with
:func:`sandbox.sim.seams.set_seam_springs` (no recompilation). Resizing rebuilds the body
with the paper's §2.1.4 rule and moves the collider (:meth:`BodyCollider.update`); the cloth
keeps simulating around it.
"""

from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path

import numpy as np
import taichi as ti

from sandbox.app.live_solver import DEFAULT_LIVE_SOLVER, LiveSolver
from sandbox.errors import SandboxError

LIVE_SEAM_FACTOR = 1.0
"""Seam springs made live end at this fraction of the drape's seam stiffness (the cloth's
own, so they hold the garment's weight); the time step is fitted to them at start."""
SEAM_START_FACTOR = 0.05
"""A new seam starts this soft (as the drape's sewing phase) so it does not snap the panels
through the body; it stiffens geometrically to LIVE_SEAM_FACTOR over SEAM_RAMP_FRAMES."""
SEAM_RAMP_FRAMES = 30
COVER_BELOW_STOP = 2.0
"""Once no vertex moves more than this many times the stop rule's largest displacement in a
frame (the cloth is settling), the body's contact thickens wherever the body still shows
through the cloth (:meth:`~sandbox.collision.body.BodyCollider.cover`); a cloth still
falling or sliding crosses the body only for a moment and leaves the thickness alone."""
COVER_EVERY_FRAMES = 10
"""... checked every this many frames (20-45 ms a check at 3 and 1.5 cm,
``benchmarks/bench_gui.py``)."""
SETTLE_DAMPING_PER_S = 60.0
"""After a resize the cloth refits the new body overdamped, as a drape's fine level settles
(``DrapeConfig.fine_damping_per_s``): it moves onto the body without swinging ..."""
SETTLE_INERTIA = 4.0
"""... with its inertia scaled by this (:func:`sandbox.sim.inertia.scaled_inertia`:
the same weight, drag and rest shape, the explicit step x2), until the paper's stop rule
holds ..."""
SETTLE_SHOWS_M = 1e-3
"""... and no body vertex shows through it deeper than this [m] (the drape acceptance's
``AcceptanceConfig.body_through_m``), ..."""
SETTLE_MAX_FRAMES = 90
"""... or for at most this many frames (3 s simulated); then the cloth has its own inertia
and damping again."""
SETTLE_EASE = 4.0
"""Once the stop rule holds overdamped, the damping steps down by this factor, the stop rule
holding again at each step, to the cloth's own (:meth:`Session._settle_eased`)."""
PICK_RADIUS_PX = 18.0
"""A click farther than this from every boundary edge (on screen) sews nothing."""


@dataclasses.dataclass
class FrameStats:
    """What the HUD shows after a frame: the paper's stop rule over that frame."""

    frame: int = 0
    sim_time_s: float = 0.0
    max_displacement_m: float = math.inf
    mean_displacement_m: float = math.inf
    converged: bool = False
    wall_s: float = 0.0
    body_shows: int = 0
    """Body vertices that showed through the cloth at the frame's end (the contact then
    thickened there; 0 when the frame was not checked: the cloth was still moving)."""
    settling: bool = False
    """The cloth is refitting a resized body (overdamped, :data:`SETTLE_DAMPING_PER_S`)."""


class Session:
    """One garment on the mannequin, simulating, with the user's actions.

    Args:
        garment: library name (``python -m sandbox drape --list``) or pattern file.
        size: database size of the starting mannequin. edge_cm: mesh edge [cm].
        fabric: fabric preset (default: the garment's own). sewn: start with the
        pattern's seams sewn. self_collision: cloth against itself (slower). limits: the
        largest scene accepted (:class:`~sandbox.scene.budget.ResourceLimits`). solver:
        how the cloth is stepped (:class:`LiveSolver`).
    """

    def __init__(self, garment: str = "sheath-dress", *, size: int = 12, edge_cm: float = 3.0,
                 fabric: str | None = None, sewn: bool = False,
                 self_collision: bool = False, limits=None,
                 solver: LiveSolver = DEFAULT_LIVE_SOLVER):  # fmt: skip
        from sandbox import runtime
        from sandbox.garment import DrapeConfig, build_drape, make_mannequin, resolve_pattern
        from sandbox.garment.build import check_drape_size
        from sandbox.garment.inputs import material_for
        from sandbox.scene.budget import ResourceLimits, mesher_limits

        runtime.ensure_init()
        if not (edge_cm > 0 and math.isfinite(edge_cm)):
            raise SandboxError(f"edge length must be a positive number of cm, got {edge_cm}")
        self.size = size
        self.garment, self.edge_cm, self.self_collision = garment, edge_cm, self_collision
        self.measurements: dict[str, float] = {}
        self.mannequin = make_mannequin(size)
        self.pattern = resolve_pattern(garment, self.mannequin)
        self.fabric = fabric
        self.solver = solver
        config = DrapeConfig(self_collision=self_collision, limits=limits or ResourceLimits(),
                             integrator=solver.integrator,
                             dt_s=1.0 / 30.0 / solver.steps_per_frame if solver.implicit
                             else None)  # fmt: skip
        implicit = None
        if solver.implicit:
            from sandbox.sim.implicit_config import ImplicitConfig

            implicit = ImplicitConfig(max_newton=solver.newton_iterations, linear_solver="cg",
                                      step_residual=False)  # fmt: skip
        check_drape_size(self.pattern, edge_cm / 100.0, material_for(self.pattern, fabric),
                         config, say=False)  # fmt: skip
        meshes_boundary = 0
        from sandbox.pattern.panel_mesh import mesh_pattern

        for mesh in mesh_pattern(self.pattern, edge_cm / 100.0,
                                 limits=mesher_limits(config.limits)).values():  # fmt: skip
            meshes_boundary += len(mesh.boundary)
        self.scene = build_drape(self.pattern, self.mannequin, fabric=fabric,
                                 edge_length_m=edge_cm / 100.0,
                                 config=config,
                                 sew_pattern=False,
                                 seam_capacity=2 * meshes_boundary + 16,
                                 implicit=implicit)  # fmt: skip
        self.model = self.scene.model
        self._fit_time_step()
        self.state = self.scene.state
        self.collider = self.model.colliders[0]
        self.seams: list = []
        self._ramp: list[float] = []
        self._frame_steps = 0
        self._frame_x0 = None
        self._step_s = 0.0  # measured wall time per step [s] (run_for's chunks)
        self.steps_taken = 0  # steps run by run_for and run_frames
        self.last_run_s = 0.0  # wall time of the last run_for [s]
        self._springs: list[tuple] = []
        self._seam_k: list[np.ndarray] = []
        self.message = ""
        self.stats = FrameStats()
        self.playing = True
        self.pinned = np.zeros(self.model.particle_count, bool)
        self._inv_mass0 = self.model.particle_inv_mass.to_numpy()[: self.model.particle_count]
        self.edges = self._boundary_edges()
        self._gravity = tuple(self.scene.control.gravity[None])
        self._settle = None  # while refitting a resized body: what to restore, and its frames
        self.last_refit: dict | None = None
        """The last refit after a resize: frames and wall time [s] until the stop rule held
        (``at_rest``) or the frames ran out."""
        import open3d  # noqa: F401  the contact checks' ray caster: loaded here (1-2 s), not
        # in the window's first settled frame (COVER_EVERY_FRAMES)

        self.set_gravity(sewn)  # the paper's sewing table: no gravity until the user says
        if sewn:
            self.sew_pattern_seams()

    def _fit_time_step(self) -> None:
        """Shrink dt so the explicit step stays stable with live seams added.

        The scene's dt was fitted to the cloth alone (no seams were sewn at build). A seam
        spring of stiffness k on a particle of mass m adds k/m to ω²; with up to three
        springs per particle, 1/dt² grows by 3 k_live / (4 m_min) (dt = 2/ω).
        """
        sc, m = self.scene, self.model
        if sc.spec.simulation.integrator != "symplectic_euler":
            return
        k_live = LIVE_SEAM_FACTOR * sc.garment.seam_stiffness_N_m
        m_min = float(m.mass_np[~m.pinned_np].min()) if (~m.pinned_np).any() else 1.0
        dt_cloth = sc.dt_limit_s if math.isfinite(sc.dt_limit_s) else sc.dt_s
        limit = 1.0 / math.sqrt(1.0 / dt_cloth**2 + 3.0 * k_live / (4.0 * m_min))
        frame = sc.dt_s * sc.steps_per_frame
        if sc.dt_s > 0.9 * limit:
            sc.steps_per_frame = max(1, math.ceil(frame / (0.9 * limit)))
            sc.dt_s = frame / sc.steps_per_frame

    # ------------------------------------------------------------------ geometry
    def _boundary_edges(self) -> list[tuple[str, int, np.ndarray]]:
        """Every panel edge as ``(panel, edge index, global particle indices along it)``."""
        out = []
        for piece in self.model.pieces:
            mesh = self.scene.garment.meshes[piece.name]
            for k, idx in enumerate(mesh.edge_vertices):
                out.append((piece.name, k, np.asarray(idx, np.int64) + piece.particle_start))
        return out

    def positions(self) -> np.ndarray:
        """Cloth positions (n, 3) [m]."""
        return self.state.positions()

    def edge_polyline(self, panel: str, edge: int) -> np.ndarray:
        """Current world points (k, 3) [m] along one panel edge."""
        for name, k, idx in self.edges:
            if name == panel and k == edge:
                return self.positions()[idx]
        raise SandboxError(f"panel {panel!r} has no edge {edge}")

    def nearest_edge(self, point: np.ndarray, max_distance_m: float = 0.05):
        """The boundary edge closest to a world point [m], as ``(panel, edge)``, or None."""
        x = self.positions()
        best, best_d = None, max_distance_m
        for name, k, idx in self.edges:
            d = _polyline_distance(np.asarray(point, float), x[idx])
            if d < best_d:
                best, best_d = (name, k), d
        return best

    # ------------------------------------------------------------------ seams
    def _side(self, side, what: str) -> list[tuple[str, int]]:
        if not side:
            raise SandboxError(f"{what}: no edge given")
        out = []
        for entry in side:
            try:
                panel, edge = str(entry[0]), int(entry[1])
            except (TypeError, ValueError, IndexError):
                raise SandboxError(f"{what}: {entry!r} is not [panel, edge index]") from None
            if panel not in self.pattern.panels:
                raise SandboxError(f"{what}: no panel {panel!r} (panels: "
                                   f"{', '.join(self.pattern.panels)})")  # fmt: skip
            n_edges = len(self.pattern.panels[panel].edges)
            if not 0 <= edge < n_edges:
                raise SandboxError(f"{what}: panel {panel!r} has edges 0..{n_edges - 1}, "
                                   f"not {edge}")  # fmt: skip
            out.append((panel, edge))
        return out

    def sewn_edges(self) -> set[tuple[str, int]]:
        return {e for s in self.seams for e in list(s.side_a) + list(s.side_b)}

    def sew(self, side_a, side_b, *, name: str = "") -> bool:
        """Sew two sides (each a list of ``(panel, edge index)``) with the paper's rules.

        Returns False, with the reason in :attr:`message`, when an edge is sewn to itself or
        is already in a seam; raises SandboxError for edges that do not exist.
        """
        from sandbox.pattern.spec import SeamSpec

        a = self._side(side_a, "sew: side a")
        b = self._side(side_b, "sew: side b")
        if set(a) & set(b) or len(set(a)) < len(a) or len(set(b)) < len(b):
            self.message = "refused: an edge cannot be sewn to itself"
            return False
        taken = self.sewn_edges() & (set(a) | set(b))
        if taken:
            p, e = sorted(taken)[0]
            self.message = f"refused: edge {e} of {p} is already sewn"
            return False
        seam = SeamSpec(side_a=a, side_b=b, direction="auto", name=name)
        self.seams.append(seam)
        try:
            self._apply_seams()
        except SandboxError as exc:
            self.seams.pop()
            self._apply_seams()
            self.message = f"refused: {exc}"
            return False
        self.message = f"sewn: {_side_text(a)} to {_side_text(b)}"
        return True

    def sew_pattern_seams(self) -> int:
        """Sew every seam of the pattern file that is not sewn yet; returns how many."""
        done = 0
        for s in self.pattern.seams:
            if not (self.sewn_edges() & (set(s.side_a) | set(s.side_b))):
                self.seams.append(dataclasses.replace(s, side_a=list(s.side_a),
                                                      side_b=list(s.side_b)))  # fmt: skip
                done += 1
        self._apply_seams()
        self.message = f"sewn the pattern's {done} seams"
        return done

    def undo_seam(self) -> bool:
        if not self.seams:
            self.message = "nothing to undo"
            return False
        self.seams.pop()
        self._apply_seams()
        self.message = f"undone; {len(self.seams)} seams left"
        return True

    def clear_seams(self) -> None:
        self.seams.clear()
        self._apply_seams()
        self.message = "all seams cleared"

    def _apply_seams(self) -> None:
        """Springs of every seam (per seam, so each keeps its own stiffening ramp)."""
        from sandbox.garment import seam_springs
        from sandbox.sim.seams import set_seam_springs

        while len(self._ramp) < len(self.seams):
            self._ramp.append(SEAM_START_FACTOR)
        del self._ramp[len(self.seams) :]
        # each seam's springs are fixed when it is made (its direction by Fig. 5a at the
        # positions of that moment), so sewing another seam never turns an old one around
        del self._springs[len(self.seams) :]
        while len(self._springs) < len(self.seams):
            self._springs.append(seam_springs(self.scene, [self.seams[len(self._springs)]]))
        parts = self._springs
        self._seam_k = [p[2] for p in parts]
        if parts:
            pairs = np.concatenate([p[0] for p in parts])
            rest = np.concatenate([p[1] for p in parts])
        else:
            pairs, rest = np.zeros((0, 2), np.int64), np.zeros(0)
        set_seam_springs(self.model, pairs, rest, self._stiffness())

    def _stiffness(self) -> np.ndarray:
        if not self._seam_k:
            return np.zeros(0)
        ramp = zip(self._ramp, self._seam_k, strict=True)
        return np.concatenate([LIVE_SEAM_FACTOR * f * k for f, k in ramp])

    def _stiffen(self) -> None:
        """One frame of the seams' geometric ramp to their final stiffness."""
        if any(f < 1.0 for f in self._ramp):
            grow = (1.0 / SEAM_START_FACTOR) ** (1.0 / SEAM_RAMP_FRAMES)
            self._ramp = [min(1.0, f * grow) for f in self._ramp]
            self.model.set_seam_stiffness(self._stiffness())

    def seam_gap_m(self) -> float:
        """Largest distance between a seam's two sides [m] (0 without seams), as a drape's
        ``seam_gap_max_m`` (:func:`sandbox.scene.run.seam_gap_max`)."""
        from sandbox.scene.run import seam_gap_max

        if not self.model.seam_count:
            return 0.0
        return seam_gap_max(self.model, self.positions())

    def contact_metrics(self) -> dict:
        """The drape's contact measures of the current state (docs/collision_metrics.md):
        cloth inside the body, body through the cloth, crossing cloth triangles."""
        from sandbox.scene.run import contact_metrics

        return contact_metrics(self.scene.model, self.positions())

    def pattern_with_seams(self):
        """The session's pattern with its seams replaced by the ones sewn here."""
        return dataclasses.replace(self.pattern, seams=list(self.seams))

    def save_pattern(self, path) -> Path:
        """Write the pattern with the seams sewn here (atomically, validated)."""
        from sandbox.pattern.spec import save_pattern

        return save_pattern(self.pattern_with_seams(), path)

    # ------------------------------------------------------------------ mannequin
    def resize(self, **cm: float):
        """Resize the mannequin (§2.1.4) to these measurements [cm]; returns the new body.

        Keys: ``bust_girth``, ``waist_girth``, ``hip_girth``, ``shoulder_width``,
        ``back_width``, ``shoulder_length``, ``back_length``; the others keep their values.
        The collider moves to the new body between two steps, and the cloth with it: each
        free vertex by the displacement of its closest body point
        (:func:`~sandbox.collision.body_probe.follow_body`), at rest.
        """
        from sandbox.garment import make_mannequin
        from sandbox.mannequin.measurements import KEYS

        for k, v in cm.items():
            if k not in KEYS:
                raise SandboxError(f"unknown measurement {k!r}: choose one of {', '.join(KEYS)}")
            if not math.isfinite(float(v)):
                raise SandboxError(f"measurement {k!r} must be a number, got {v!r}")
        merged = {**self.measurements, **{k: float(v) for k, v in cm.items()}}
        body = make_mannequin(self.size, merged, arm_angle_deg=self.mannequin.arm_angle_deg,
                              head_length_cm=self.mannequin.head_length_cm)  # fmt: skip
        if body.vertices.shape != self.mannequin.vertices.shape:
            raise SandboxError("the resized mannequin has another structure")
        from sandbox.collision.body_probe import follow_body

        x = self.positions()
        moved = follow_body(x, self.mannequin.vertices, self.mannequin.triangles, body.vertices)
        free = self.model.particle_inv_mass.to_numpy()[: len(x)] > 0.0
        x[free] = moved[free]
        self.state.set(x, np.zeros_like(x))
        self.collider.uncover()  # the old body's cover does not fit the new one
        self.collider.update(body.vertices)
        self._start_settling()
        self.mannequin = body
        self.measurements = merged
        self.message = ", ".join(f"{k} {v:g} cm" for k, v in cm.items())
        return body

    def set_measurements(self, **cm: float) -> dict[str, float]:
        """:meth:`resize`, then the tape measure on the new body [cm] (about 13 ms, which
        the window's sliders skip)."""
        return self.resize(**cm).measure()

    # ------------------------------------------------------------------ simulation
    def _start_settling(self) -> None:
        """Refit mode after a resize, until the stop rule holds with the body covered
        (:meth:`_finish_frame`) or :data:`SETTLE_MAX_FRAMES` have run; a new resize while
        settling starts the count again. Meanwhile the cloth is overdamped (damping
        :data:`SETTLE_DAMPING_PER_S`); the explicit step also scales its inertia by
        :data:`SETTLE_INERTIA` and lengthens its step by that factor's square root (the same
        frame), while backward Euler keeps its step, stable at any damping."""
        from sandbox.sim.inertia import scale_inertia

        sc = self.scene
        if self._settle is not None:
            self._settle["frames"] = 0
            self._settle["t0"] = time.perf_counter()
            return
        if not self.gravity:
            return  # the sewing table (no gravity) has no rest to refit
        saved = {"frames": 0, "dt_s": sc.dt_s, "steps_per_frame": sc.steps_per_frame,
                 "damping": float(sc.control.damping_per_s[None]),
                 "t0": time.perf_counter()}  # fmt: skip
        self._settle = saved
        self.stats.settling = True
        sc.control.damping_per_s[None] = SETTLE_DAMPING_PER_S
        if self.solver.implicit:
            return
        saved["inertia"] = scale_inertia(sc, SETTLE_INERTIA)
        steps = max(1, math.ceil(sc.steps_per_frame / math.sqrt(SETTLE_INERTIA)))
        self._set_step(saved["dt_s"] * saved["steps_per_frame"] / steps, steps)

    def _settle_eased(self) -> bool:
        """At rest while overdamped: the damping steps down towards the cloth's own by
        :data:`SETTLE_EASE` (True), and the stop rule must hold again at each step; False once
        it is the cloth's own. Dropped at once, the damping left a 1.5 cm dress's hem
        swinging 2 mm a frame after the refit: creeping overdamped, the cloth meets the
        stop rule before its forces balance."""
        sc, own = self.scene, self._settle["damping"]
        damping = float(sc.control.damping_per_s[None])
        if damping <= own * SETTLE_EASE:
            return False
        sc.control.damping_per_s[None] = max(own, damping / SETTLE_EASE)
        return True

    def _stop_settling(self) -> None:
        """Back to the cloth's own inertia, damping and step (after :meth:`_start_settling`)."""
        if self._settle is None:
            return
        from sandbox.sim.inertia import restore_inertia

        sc, saved = self.scene, self._settle
        if "inertia" in saved:  # the explicit step's scaling
            restore_inertia(sc, saved["inertia"])
            self._set_step(saved["dt_s"], saved["steps_per_frame"])
        sc.control.damping_per_s[None] = saved["damping"]
        self._settle = None
        self.stats.settling = False
        self.last_refit = {"frames": saved["frames"], "at_rest": self.stats.converged,
                           "wall_s": time.perf_counter() - saved["t0"]}  # fmt: skip

    def _set_step(self, dt_s: float, steps_per_frame: int) -> None:
        """Steps of ``dt_s`` [s], ``steps_per_frame`` a frame; a frame the window's budget
        left open keeps the part of it already run (its steps rescaled), so a slider move
        never waits for the rest of a frame."""
        sc = self.scene
        if self._frame_steps:
            done = self._frame_steps / sc.steps_per_frame
            self._frame_steps = min(steps_per_frame - 1, round(done * steps_per_frame))
        sc.steps_per_frame = steps_per_frame
        sc.dt_s = dt_s

    def run_frames(self, frames: int = 1) -> FrameStats:
        """Simulate ``frames`` output frames (1/30 s each); returns the last frame's stats."""
        sc = self.scene
        for _ in range(int(frames)):
            t0 = time.perf_counter()
            if self._frame_steps:  # finish a frame the window's budget left open
                sc.solver.advance(self.state, sc.control, sc.dt_s,
                                  sc.steps_per_frame - self._frame_steps)  # fmt: skip
                self.steps_taken += sc.steps_per_frame - self._frame_steps
                self._frame_steps = 0
                self._finish_frame(self._frame_x0, time.perf_counter() - t0)
                continue
            self._stiffen()
            x0 = self.positions()
            sc.solver.advance(self.state, sc.control, sc.dt_s, sc.steps_per_frame)
            self.steps_taken += sc.steps_per_frame
            self._finish_frame(x0, time.perf_counter() - t0)
        return self.stats

    def set_gravity(self, on: bool) -> None:
        """Gravity on, or off (the sewing table: panels float while seams close)."""
        self._stop_settling()
        self.gravity = bool(on)
        self.scene.control.gravity[None] = self._gravity if on else (0.0, 0.0, 0.0)
        self.message = f"gravity {'on' if on else 'off'}"

    def run_for(self, budget_s: float) -> int:
        """Simulate for about ``budget_s`` of wall time (the window's frame budget, so
        drawing keeps its rate when a whole 1/30 s frame takes longer); at least one step.

        The steps go in chunks sized from the measured time per step, so the budget is not
        overshot by more than about one step. The HUD's stats are updated each time a whole
        frame's steps are done. Returns the steps taken.
        """
        sc = self.scene
        t0 = time.perf_counter()
        done = 0
        while True:
            if self._frame_steps == 0:
                self._stiffen()
                self._frame_x0 = self.positions()
            k = sc.steps_per_frame - self._frame_steps
            left = budget_s - (time.perf_counter() - t0)
            k = min(k, max(1, int(left / self._step_s))) if self._step_s else 1
            t1 = time.perf_counter()
            sc.solver.advance(self.state, sc.control, sc.dt_s, k)
            ti.sync()
            per_step = (time.perf_counter() - t1) / k
            self._step_s = per_step if not self._step_s else 0.7 * self._step_s + 0.3 * per_step
            done += k
            self._frame_steps += k
            if self._frame_steps >= sc.steps_per_frame:
                self._frame_steps = 0
                self._finish_frame(self._frame_x0, time.perf_counter() - t0)
            if time.perf_counter() - t0 + 0.5 * self._step_s >= budget_s:
                self.steps_taken += done
                self.last_run_s = time.perf_counter() - t0
                return done

    def _finish_frame(self, x0: np.ndarray, wall_s: float) -> None:
        from sandbox.scene.run import SimulationDiverged

        sc = self.scene
        bad = sc.solver.first_bad()
        if bad is not None:
            raise SimulationDiverged(f"the simulation diverged at vertex {bad[1]}; reset it")
        d = np.linalg.norm(self.positions() - x0, axis=1)
        s, stop = self.stats, sc.spec.stop
        s.frame += 1
        s.sim_time_s += sc.dt_s * sc.steps_per_frame
        s.max_displacement_m = float(d.max())
        s.mean_displacement_m = float(d.mean())
        s.converged = (s.max_displacement_m < stop.max_displacement_m
                       and s.mean_displacement_m < stop.mean_displacement_m)  # fmt: skip
        s.wall_s = wall_s
        s.body_shows = 0
        checked = False
        if self._settle is not None:
            self._settle["frames"] += 1
            if s.converged:  # at rest on the new body, unless it still shows through
                s.body_shows = self.collider.cover(self.positions(), self.model.tri_indices_np)
                checked = True
                # else its contact just thickened there and the cloth moves on
                s.converged = self.collider.cover_depth_m <= SETTLE_SHOWS_M
            if s.converged and not self._settle_eased():
                self._stop_settling()
            elif self._settle["frames"] >= SETTLE_MAX_FRAMES:
                self._stop_settling()
        if (not checked and s.frame % COVER_EVERY_FRAMES == 0
                and s.max_displacement_m < COVER_BELOW_STOP * stop.max_displacement_m):  # fmt: skip
            # settling: where the body still shows through, the contact thickens there
            s.body_shows = self.collider.cover(self.positions(), self.model.tri_indices_np)

    def reset(self) -> None:
        """Panels back to their start positions (seams and body kept)."""
        self._stop_settling()
        self.state.set(self.model.initial_positions_np)
        self.scene.solver.reset_watch()
        self.stats = FrameStats()
        self._frame_steps = 0
        self.message = "reset"

    def set_fabric(self, preset: str) -> None:
        """Another fabric preset: the scene is rebuilt (positions, body and seams kept)."""
        x, v, seams = self.positions(), self.state.velocities(), list(self.seams)
        measurements = dict(self.measurements)
        fresh = Session(self.garment, size=self.size, fabric=preset, edge_cm=self.edge_cm,
                        self_collision=self.self_collision, solver=self.solver)  # fmt: skip
        self.__dict__.update(fresh.__dict__)
        if measurements:
            self.set_measurements(**measurements)
        self.state.set(x, v)
        self.seams = seams
        self._apply_seams()
        self.message = f"fabric: {preset}"

    def pin(self, vertex: int, pinned: bool = True) -> None:
        """Pin (inverse mass 0) or unpin one cloth vertex."""
        n = self.model.particle_count
        if not 0 <= int(vertex) < n:
            raise SandboxError(f"vertex {vertex} out of range 0..{n - 1}")
        self._stop_settling()  # pins are written as inverse masses of the cloth's own inertia
        self.pinned[vertex] = pinned
        inv = np.where(self.pinned, 0.0, self._inv_mass0)
        self.model.particle_inv_mass.from_numpy(inv.astype(self._inv_mass0.dtype))
        self.message = f"vertex {vertex} {'pinned' if pinned else 'unpinned'}"

    def drag(self, vertex: int, target_m) -> None:
        """Move a (pinned) vertex to ``target_m`` (3,) [m]; it stays pinned there."""
        if not self.pinned[vertex]:
            self.pin(vertex)
        x, v = self.positions(), self.state.velocities()
        x[vertex] = np.asarray(target_m, float)
        v[vertex] = 0.0
        self.state.set(x, v)

    def save_meshes(self, out_dir) -> dict[str, Path]:
        """``garment.obj`` (UVs = pattern coordinates [m]) and ``body.obj`` into out_dir."""
        from sandbox.render import write_mesh

        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        g = write_mesh(out / "garment.obj", self.positions(), self.model.tri_indices_np,
                       uvs=self.model.rest_uv_np)  # fmt: skip
        b = write_mesh(out / "body.obj", self.mannequin.vertices, self.mannequin.triangles)
        return {"garment": g, "body": b}


def _side_text(side) -> str:
    return " + ".join(f"{p}[{e}]" for p, e in side)


def _polyline_distance(p: np.ndarray, line: np.ndarray) -> float:
    a, b = line[:-1], line[1:]
    d = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, d) / np.maximum((d * d).sum(1), 1e-30), 0, 1)
    return float(np.linalg.norm(a + t[:, None] * d - p, axis=1).min())
