"""The GGUI front end of the sandbox: a window (or the same thing off-screen) over a Session.

:class:`Renderer` draws the mannequin, the garment, the sewn seams and the picked edges
with Taichi GGUI; ``show_window=False`` renders off-screen (lavapipe software Vulkan here),
which is how scripts and tests make pictures. :func:`run_window` is the interactive loop:

=====================  ==================================================================
mouse / key            action
=====================  ==================================================================
right drag             orbit the camera (GGUI's camera control; W/A/S/D/Q/E move it)
left click             sewing mode: pick a panel edge; the first click starts side A, a
                       plain click on another edge sews; shift-click adds an edge to side
                       A, shift+B-click to side B, then "sew picked".
                       Otherwise: drag the nearest cloth vertex (it stays pinned)
space                  play / pause
P                      screenshot (``screenshot_NNN.png``)
Esc                    quit (nothing is left half-written)
=====================  ==================================================================

The side panel has the seven measurement sliders (cm, within the supported range), size
presets, play/pause, step, reset, "sew pattern seams", undo, clear, fabric presets, save
(meshes and the pattern with its seams) and a HUD: fps, simulated time and how fast it
advances against the wall clock, the stop rule's max and mean displacement over the last
frame and whether it holds.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import taichi as ti

from sandbox.app.session import PICK_RADIUS_PX, Session
from sandbox.errors import SandboxError
from sandbox.render.view import vertex_normals

BACKGROUND = (1.0, 1.0, 1.0)
BODY_COLOUR = (0.78, 0.72, 0.64)
CLOTH_COLOUR = (0.23, 0.42, 0.78)
SEAM_COLOUR = (0.9, 0.2, 0.1)
PICK_COLOUR = (0.1, 0.75, 0.2)
FOV_DEG = 45.0
TARGET_FPS = 30.0
SEAM_SHOWN_M = 0.002
"""Seam springs longer than this [m] are drawn as lines (closed ones would not show)."""
MIN_SIM_BUDGET_S = 0.004
"""The least simulation wall time per displayed frame (one step at least is always run)."""
FPS_HEADROOM = 1.05
"""The window plans its frames for this factor above ``target_fps``: frame times jitter
(the simulation's chunks, the software renderer), and aiming at the target exactly left
the measured rate just under it (29.4-29.7 fps for 30)."""


class FrameBudget:
    """The simulation's wall time per displayed frame [s]: ``fixed_s`` if given, else what
    is left of 1/(``FPS_HEADROOM`` x ``target_fps``) after the rest of the recent frames
    (an average), at least :data:`MIN_SIM_BUDGET_S`."""

    def __init__(self, target_fps: float = TARGET_FPS, fixed_s: float | None = None):
        self.frame_s = 1.0 / (FPS_HEADROOM * target_fps)
        self.fixed_s = fixed_s
        self.other_s = None  # a frame's wall time outside the simulation [s]

    def next(self) -> float:
        if self.fixed_s is not None:
            return self.fixed_s
        return max(MIN_SIM_BUDGET_S, self.frame_s - (self.other_s or 0.0))

    def record(self, wall_s: float, sim_s: float) -> None:
        """A frame took ``wall_s``, ``sim_s`` of it simulating."""
        other = wall_s - sim_s
        self.other_s = other if self.other_s is None else 0.8 * self.other_s + 0.2 * other


class Renderer:
    """GGUI drawing of a Session: body, garment, seam springs and picked edges.

    Fields are allocated once at the session's sizes (body vertices, cloth vertices, seam
    capacity); positions are copied in each frame.
    """

    def __init__(self, session: Session, size=(640, 640), *, show_window: bool = False,
                 title: str = "garment sandbox"):  # fmt: skip
        self.session = session
        self.size = tuple(int(s) for s in size)
        self.window = ti.ui.Window(title, self.size, show_window=show_window, vsync=False)
        self.canvas = self.window.get_canvas()
        self.scene = self.window.get_scene()
        self.camera = ti.ui.Camera()
        self.eye = np.array([0.0, 1.15, 2.3])
        self.target = np.array([0.0, 1.05, 0.0])
        self.camera.position(*self.eye)
        self.camera.lookat(*self.target)
        self.camera.up(0.0, 1.0, 0.0)
        self.camera.fov(FOV_DEG)
        m, body = session.model, session.mannequin
        self.body_x = ti.Vector.field(3, ti.f32, shape=len(body.vertices))
        self.body_n = ti.Vector.field(3, ti.f32, shape=len(body.vertices))
        self._body_drawn = None  # the Mannequin whose vertices and normals are uploaded
        self.body_i = ti.field(ti.i32, shape=body.triangles.size)
        self.body_i.from_numpy(body.triangles.astype(np.int32).ravel())
        self.cloth_x = ti.Vector.field(3, ti.f32, shape=m.particle_count)
        self.cloth_n = ti.Vector.field(3, ti.f32, shape=m.particle_count)
        self.cloth_i = ti.field(ti.i32, shape=m.tri_indices_np.size)
        self.cloth_i.from_numpy(m.tri_indices_np.astype(np.int32).ravel())
        self.seam_x = ti.Vector.field(3, ti.f32, shape=2 * max(1, m.seam_capacity))
        n_edge_pts = sum(2 * (len(idx) - 1) for _, _, idx in session.edges)
        self.pick_x = ti.Vector.field(3, ti.f32, shape=max(2, n_edge_pts))
        self.picked: list[tuple[str, int]] = []

    # ------------------------------------------------------------------ drawing
    def draw(self) -> None:
        s = self.session
        body = s.mannequin
        if body is not self._body_drawn:  # a new body (a slider moved): upload it
            self.body_x.from_numpy(body.vertices.astype(np.float32))
            n = vertex_normals(np.asarray(body.vertices, np.float64), body.triangles)
            self.body_n.from_numpy(n.astype(np.float32))
            self._body_drawn = body
        x = s.positions()
        self.cloth_x.from_numpy(x.astype(np.float32))
        # given, as the body's: GGUI's own normals kernel runs in the simulation's precision
        self.cloth_n.from_numpy(vertex_normals(x, s.model.tri_indices_np).astype(np.float32))
        sc = self.scene
        sc.set_camera(self.camera)
        sc.ambient_light((0.45, 0.45, 0.45))
        sc.point_light(pos=(1.5, 3.0, 3.0), color=(0.7, 0.7, 0.7))
        sc.point_light(pos=(-2.0, 2.0, -2.0), color=(0.3, 0.3, 0.3))
        # the body's normals are given: GGUI would recompute them every frame
        sc.mesh(self.body_x, indices=self.body_i, normals=self.body_n, color=BODY_COLOUR)
        sc.mesh(self.cloth_x, indices=self.cloth_i, normals=self.cloth_n, color=CLOTH_COLOUR,
                two_sided=True)  # fmt: skip
        m = s.model
        if m.seam_count:  # the open seams: springs longer than SEAM_SHOWN_M
            ends = x[m.seam_pairs_np[: m.seam_count]]
            ends = ends[np.linalg.norm(ends[:, 0] - ends[:, 1], axis=1) > SEAM_SHOWN_M]
            if len(ends):
                seg = np.zeros((self.seam_x.shape[0], 3), np.float32)
                seg[: 2 * len(ends)] = ends.reshape(-1, 3)
                self.seam_x.from_numpy(seg)
                sc.lines(self.seam_x, width=2.0, color=SEAM_COLOUR, vertex_count=2 * len(ends))
        if self.picked:
            pts = []
            for name, k, idx in s.edges:
                if (name, k) in self.picked:
                    p = x[idx]
                    pts.append(np.stack([p[:-1], p[1:]], 1).reshape(-1, 3))
            seg = np.concatenate(pts)
            buf = np.zeros((self.pick_x.shape[0], 3), np.float32)
            buf[: len(seg)] = seg
            self.pick_x.from_numpy(buf)
            sc.lines(self.pick_x, width=4.0, color=PICK_COLOUR, vertex_count=len(seg))
        self.canvas.set_background_color(BACKGROUND)
        self.canvas.scene(sc)

    def image(self) -> np.ndarray:
        """The current frame as uint8 RGB (height, width, 3), top row first."""
        self.draw()
        img = self.window.get_image_buffer_as_numpy()  # (w, h, 4) float, x right, y up
        rgb = np.clip(np.rot90(img[..., :3]) * 255.0 + 0.5, 0, 255).astype(np.uint8)
        return np.ascontiguousarray(rgb)

    def save_png(self, path) -> Path:
        """Render and write a PNG atomically."""
        import imageio.v3 as iio

        from sandbox.atomic import atomic_path

        img = self.image()
        with atomic_path(path) as tmp:
            iio.imwrite(tmp, img, extension=".png")
        return Path(path)

    # ------------------------------------------------------------------ picking
    def camera_pose(self):
        """(eye, target) of the camera as it is now [m]."""
        try:
            eye = np.array(self.camera.curr_position, float)
            target = np.array(self.camera.curr_lookat, float)
        except AttributeError:
            eye, target = self.eye, self.target
        return eye, target

    def project(self, points: np.ndarray) -> np.ndarray:
        """World points (k, 3) -> window coordinates (k, 2) in [0, 1]², y up (GGUI's)."""
        eye, target = self.camera_pose()
        f = target - eye
        f /= np.linalg.norm(f)
        r = np.cross(f, [0.0, 1.0, 0.0])
        r /= np.linalg.norm(r)
        u = np.cross(r, f)
        rel = np.asarray(points, float) - eye
        z = rel @ f
        t = math.tan(math.radians(FOV_DEG) / 2.0)
        aspect = self.size[0] / self.size[1]
        sx = (rel @ r) / np.maximum(z, 1e-9) / (t * aspect)
        sy = (rel @ u) / np.maximum(z, 1e-9) / t
        return np.stack([0.5 + 0.5 * sx, 0.5 + 0.5 * sy], 1)

    def edge_at(self, cursor) -> tuple[str, int] | None:
        """The panel edge drawn nearest to a cursor position ([0, 1]², y up), or None if
        none is within :data:`PICK_RADIUS_PX` pixels."""
        x = self.session.positions()
        c = np.asarray(cursor, float) * self.size
        best, best_d = None, PICK_RADIUS_PX
        for name, k, idx in self.session.edges:
            p = self.project(x[idx]) * self.size
            a, b = p[:-1], p[1:]
            d = b - a
            t = np.clip(np.einsum("ij,ij->i", c - a, d) / np.maximum((d * d).sum(1), 1e-9), 0, 1)
            dist = float(np.linalg.norm(a + t[:, None] * d - c, axis=1).min())
            if dist < best_d:
                best, best_d = (name, k), dist
        return best

    def screen_of(self, panel: str, edge: int) -> tuple[float, float]:
        """Where the middle of a panel edge is drawn ([0, 1]², y up): for scripts and tests."""
        p = self.session.edge_polyline(panel, edge)
        q = self.project(p[len(p) // 2 : len(p) // 2 + 1])[0]
        return float(q[0]), float(q[1])

    def vertex_at(self, cursor) -> int | None:
        x = self.session.positions()
        p = self.project(x) * self.size
        d = np.linalg.norm(p - np.asarray(cursor, float) * self.size, axis=1)
        i = int(np.argmin(d))
        return i if d[i] < PICK_RADIUS_PX else None


class Sewing:
    """Click-to-sew state: the edges picked for side A, then side B."""

    def __init__(self, session: Session, renderer: Renderer):
        self.session, self.renderer = session, renderer
        self.side_a: list = []
        self.side_b: list = []

    def click(self, cursor, *, add: bool = False, side: str | None = None) -> str:
        """A click at ``cursor`` ([0, 1]², y up) in sewing mode. Returns the HUD message.

        The first click picks side A; a plain click on another edge then sews A to it.
        ``add`` (shift) adds the edge to a side without sewing: to side A until side B has
        an edge, or to side B when ``side == "b"`` (the B key held in the window); the
        "sew picked" button (:meth:`finish`) then sews.
        """
        s = self.session
        edge = self.renderer.edge_at(cursor)
        if edge is None:
            s.message = "no panel edge there"
            return s.message
        if edge in s.sewn_edges():
            s.message = f"refused: edge {edge[1]} of {edge[0]} is already sewn"
            return s.message
        if edge in self.side_a or edge in self.side_b:
            s.message = "refused: an edge cannot be sewn to itself"
            return s.message
        to_b = bool(self.side_a) and (side == "b" or bool(self.side_b) or not add)
        if not to_b:
            self.side_a.append(edge)
            s.message = f"side A: {_sides(self.side_a)} (click the other side; shift adds)"
        else:
            self.side_b.append(edge)
            if add:
                s.message = f"side B: {_sides(self.side_b)} (sew picked to sew)"
            else:
                s.sew(self.side_a, self.side_b)
                self.reset()
                return s.message
        self.renderer.picked = self.side_a + self.side_b
        return s.message

    def finish(self) -> str:
        """Sew what is picked (when side B was built with shift-clicks)."""
        if self.side_a and self.side_b:
            self.session.sew(self.side_a, self.side_b)
        self.reset()
        return self.session.message

    def reset(self) -> None:
        self.side_a, self.side_b = [], []
        self.renderer.picked = []


def _sides(side) -> str:
    return " + ".join(f"{p}[{e}]" for p, e in side)


def run_window(session: Session, *, size=(1024, 768), target_fps: float = TARGET_FPS,
               frame_budget_s: float | None = None, max_frames: int | None = None,
               status_path=None) -> dict:  # fmt: skip
    """The interactive window; returns ``{"frames", "wall_s", "fps", "sim_steps"}`` (the
    rate and steps counted after the first frame, which compiles and opens the window).

    Each displayed frame runs the events, the side panel, simulation, then draws. The
    simulation's wall time per frame is ``frame_budget_s`` if given, else what is left of
    1/``target_fps`` after the rest of the last frames (at least :data:`MIN_SIM_BUDGET_S`):
    the window stays responsive at the target rate and the cloth gets the remaining time.
    ``max_frames`` and ``status_path`` (a JSON file rewritten atomically each frame with
    the body's measurements, the seams and the HUD values) are for automated runs under
    Xvfb.
    """
    from sandbox.atomic import write_json
    from sandbox.mannequin.measurements import KEYS
    from sandbox.sim.materials import list_presets

    r = Renderer(session, size, show_window=True)
    sewing = Sewing(session, r)
    tape = session.mannequin.measure()
    values = {k: float(tape[k]) for k in KEYS}
    applied = dict(values)
    sew_mode, frame, shots = True, 0, 0
    hud = {"fps": 0.0, "speed": 0.0}  # display rate [1/s], simulated s per wall s
    presets = list_presets()
    dragging = None
    budget = FrameBudget(target_fps, frame_budget_s)
    steps0, start = session.steps_taken, time.perf_counter()
    steps_seen = steps0
    while r.window.running and (max_frames is None or frame < max_frames):
        t0 = time.perf_counter()
        try:
            r, sewing, sew_mode, dragging, shots, values, applied = _frame(
                session, r, sewing, sew_mode, dragging, shots, values, applied, size,
                presets, hud, budget.next())  # fmt: skip
        except SandboxError as exc:  # a refused action: say it in the HUD, keep running
            session.message = str(exc)
            applied = dict(values)
        r.draw()
        r.window.show()
        frame += 1
        wall = max(time.perf_counter() - t0, 1e-6)
        budget.record(wall, session.last_run_s if session.playing else 0.0)
        hud["fps"] = 0.9 * hud["fps"] + 0.1 / wall
        steps = session.steps_taken - steps_seen
        steps_seen = session.steps_taken
        hud["speed"] = 0.9 * hud["speed"] + 0.1 * steps * session.scene.dt_s / wall
        if frame == 1:
            steps0, start = session.steps_taken, time.perf_counter()
        if status_path is not None:
            write_json(status_path, {"frame": frame, "fps": hud["fps"],
                                     "measurements": session.mannequin.measure(),
                                     "seams": [[list(map(list, s.side_a)),
                                                list(map(list, s.side_b))]
                                               for s in session.seams],
                                     "message": session.message,
                                     "edge_screen": {f"{p}:{k}": r.screen_of(p, k)
                                                     for p, k, _ in session.edges}})  # fmt: skip
    wall = time.perf_counter() - start
    counted = max(0, frame - 1)
    return {"frames": counted, "wall_s": wall, "fps": counted / wall if wall > 0 else 0.0,
            "sim_steps": session.steps_taken - steps0}  # fmt: skip


def _frame(session, r, sewing, sew_mode, dragging, shots, values, applied, size, presets, hud,
           frame_budget_s):  # fmt: skip
    """One frame of the window: events, the side panel, the slider changes, simulation."""
    from sandbox.mannequin.measurements import KEYS, SUPPORTED_RANGE_CM

    win, gui = r.window, r.window.get_gui()
    for e in win.get_events(ti.ui.PRESS):
        if e.key == ti.ui.ESCAPE:
            win.running = False
        elif e.key == " ":
            session.playing = not session.playing
        elif e.key in ("p", "P"):
            shots += 1
            r.save_png(f"screenshot_{shots:03d}.png")
            session.message = f"saved screenshot_{shots:03d}.png"
        elif e.key == ti.ui.LMB:
            cur = win.get_cursor_pos()
            if cur[0] < 0.3:  # the side panel
                continue
            if sew_mode:
                sewing.click(cur, add=win.is_pressed(ti.ui.SHIFT),
                             side="b" if win.is_pressed("b") else None)  # fmt: skip
            else:
                dragging = r.vertex_at(cur)
                if dragging is None:
                    session.message = "no cloth vertex there"
    if dragging is not None:
        if win.is_pressed(ti.ui.LMB):
            cur = np.asarray(win.get_cursor_pos())
            x = session.positions()[dragging]
            eye, target = r.camera_pose()
            # keep the vertex at its depth, move it under the cursor
            shift = (
                (cur - r.project(x[None])[0])
                * 2.0
                * np.linalg.norm(x - eye)
                * math.tan(math.radians(FOV_DEG) / 2.0)
            )
            f = (target - eye) / np.linalg.norm(target - eye)
            right = np.cross(f, [0.0, 1.0, 0.0])
            right /= np.linalg.norm(right)
            up = np.cross(right, f)
            session.drag(dragging, x + shift[0] * right * r.size[0] / r.size[1]
                         + shift[1] * up)  # fmt: skip
        else:
            dragging = None
    r.camera.track_user_inputs(win, movement_speed=0.03, hold_key=ti.ui.RMB)

    with gui.sub_window("sandbox", 0.0, 0.0, 0.3, 1.0):
        gui.text("mannequin [cm]")
        for k in KEYS:
            lo, hi = SUPPORTED_RANGE_CM[k]
            values[k] = gui.slider_float(k.replace("_", " "), values[k], lo, hi)
        for size in (8, 12, 16, 20):
            if gui.button(f"size {size}"):
                from sandbox.mannequin.measurements import size_entry

                m = size_entry(size).measurements
                values = {k: float(getattr(m, k)) for k in KEYS}
        session.playing = gui.checkbox("play (space)", session.playing)
        gravity = gui.checkbox("gravity (off: sewing table)", session.gravity)
        if gravity != session.gravity:
            session.set_gravity(gravity)
        if gui.button("step"):
            session.run_frames(1)
        if gui.button("reset"):
            session.reset()
        sew_mode = gui.checkbox("sewing mode (else drag)", sew_mode)
        if gui.button("sew picked (shift-built sides)"):
            sewing.finish()
        if gui.button("sew the pattern's seams"):
            session.sew_pattern_seams()
        if gui.button("undo seam"):
            session.undo_seam()
        if gui.button("clear seams"):
            session.clear_seams()
        for p in presets[:6]:
            if gui.button(f"fabric {p}"):
                session.set_fabric(p)
                r = _renderer_again(r, session, size)
                sewing = Sewing(session, r)
        if gui.button("save meshes + pattern"):
            session.save_meshes("sandbox_out")
            session.save_pattern("sandbox_out/pattern.json")
            session.message = "saved into sandbox_out/"
        st = session.stats
        gui.text(f"fps {hud['fps']:5.1f}   t = {st.sim_time_s:6.2f} s")
        gui.text(f"simulating at {hud['speed']:.3f} x real time")
        gui.text(_step_line(session))
        gui.text(f"max {1e3 * st.max_displacement_m:7.2f} mm  mean "
                 f"{1e3 * st.mean_displacement_m:7.3f} mm")  # fmt: skip
        gui.text("refitting the body" if st.settling else
                 "converged" if st.converged else "moving")  # fmt: skip
        gui.text(f"seams {len(session.seams)}  springs {session.model.seam_count}")
        gui.text(session.message[:60])
    changed = {k: v for k, v in values.items() if abs(v - applied[k]) > 0.05}
    if changed:
        session.resize(**changed)
        applied.update(changed)
    if session.playing:
        session.run_for(frame_budget_s)
    return r, sewing, sew_mode, dragging, shots, values, applied


def _renderer_again(old: Renderer, session: Session, size) -> Renderer:
    old.window.destroy()
    return Renderer(session, size, show_window=True)


def _step_line(session) -> str:
    """The HUD's line on the step: its fixed dt, and the self-collision fail-safes so far
    (steps that needed rigid impact zones, steps whose zones had to stand still)."""
    line = f"dt {session.scene.dt_s * 1e3:.3g} ms (fixed)"
    collider = session.model.self_collider
    if collider is not None:
        c = collider.collision_counts()
        if c["impact_zone_steps"] or c["freeze_steps"]:
            line += f"  zones {c['impact_zone_steps']}  stopped {c['freeze_steps']}"
    return line
