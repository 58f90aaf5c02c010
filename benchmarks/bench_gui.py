"""Interactive sandbox speed: frames per second while simulating, and slider latency.

Usage: python benchmarks/bench_gui.py [--garment sheath-dress] [--edge-cm 1.5] [--frames 40]

A real GGUI window when $DISPLAY is set (run it under Xvfb), else off-screen GGUI (the same
Renderer), float32 on the CPU. With a window, the frame rate is that of the real window loop
(``run_window``: events, the side panel with its sliders, simulation, drawing, show) for
``--frames`` frames; the simulation gets what is left of 1/30 s after the rest (or
``--budget`` s if given). Off-screen, the same loop is drawing + reading the image back.
Slider latency = resizing the mannequin (§2.1.4) + moving the collider + drawing the next
frame. The cover check = what the window spends every ``COVER_EVERY_FRAMES`` frames while
the cloth settles: finding body vertices that show through the cloth and thickening the
contact there (``BodyCollider.cover``). The refit = a resize to size 20's girths and the
frames until the stop rule holds again (the session's refit mode after a resize). Target:
>= 30 fps with a 5k-vertex garment simulating; a slider change shows within 100 ms.
"""

import argparse
import os
import platform
import time

import numpy as np

from sandbox.app.live_solver import DEFAULT_LIVE_SOLVER, INTEGRATORS
from sandbox.precision import add_precision_flags


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--garment", default="sheath-dress")
    ap.add_argument("--edge-cm", type=float, default=1.5)
    ap.add_argument("--frames", type=int, default=40)
    ap.add_argument("--size", type=int, nargs=2, default=[1024, 768])
    ap.add_argument(
        "--budget",
        type=float,
        default=None,
        help="fixed simulation wall time per frame [s] (default: what 30 fps leaves)",
    )
    ap.add_argument("--integrator", default=DEFAULT_LIVE_SOLVER.integrator, choices=INTEGRATORS)
    ap.add_argument("--newton", type=int, default=DEFAULT_LIVE_SOLVER.newton_iterations,
                    help="Newton iterations a step at most")  # fmt: skip
    ap.add_argument("--steps", type=int, default=DEFAULT_LIVE_SOLVER.steps_per_frame,
                    help="implicit steps per 1/30 s frame")  # fmt: skip
    ap.add_argument(
        "--hold",
        type=int,
        default=60,
        help="frames run after the refit to see whether the cloth stays at rest",
    )
    add_precision_flags(ap)
    args = ap.parse_args()
    from sandbox import runtime
    from sandbox.app.gui import FrameBudget, Renderer, run_window
    from sandbox.app.session import COVER_EVERY_FRAMES, LiveSolver, Session

    runtime.init("cpu", float64=args.float64)
    s = Session(
        args.garment,
        edge_cm=args.edge_cm,
        sewn=True,
        solver=LiveSolver(
            integrator=args.integrator, newton_iterations=args.newton, steps_per_frame=args.steps
        ),
    )
    s.set_gravity(True)
    windowed = bool(os.environ.get("DISPLAY"))  # a real window (e.g. under Xvfb) if possible
    r = Renderer(s, tuple(args.size), show_window=windowed)

    def present():
        if windowed:
            r.draw()
            r.window.show()
        else:
            r.image()  # off-screen: draw and read the image back

    def steady():  # a resize starts the refit mode (fewer, longer steps): time the usual one
        while s.stats.settling:
            s.run_frames(1)

    s.run_frames(1)
    r.image()  # compile and warm up
    s.resize(bust_girth=94.0)
    r.image()
    steady()
    n = s.model.particle_count
    sim, draw = [], []
    for _ in range(args.frames):
        t0 = time.perf_counter()
        s.run_frames(1)
        t1 = time.perf_counter()
        r.image()
        draw.append(time.perf_counter() - t1)
        sim.append(t1 - t0)
    sim, draw = np.array(sim), np.array(draw)
    cover = []
    for _ in range(5):  # as Session._finish_frame calls it
        t0 = time.perf_counter()
        s.collider.cover(s.positions(), s.model.tri_indices_np)
        cover.append(time.perf_counter() - t0)
    resize = []
    for _ in range(3):  # back to the window's own path (draw + show) before timing it
        present()
    for bust in (96.0, 92.0, 100.0, 94.0, 88.0, 97.0, 91.0):
        t0 = time.perf_counter()
        s.resize(bust_girth=bust)  # as the window's slider does
        present()
        resize.append(time.perf_counter() - t0)
    steady()
    # the window's loop: simulation for what the frame budget leaves, then drawing
    if windowed:
        r.window.destroy()  # one GGUI window at a time: run_window opens its own
        loop_stats = run_window(s, size=tuple(args.size), frame_budget_s=args.budget,
                                max_frames=args.frames)  # fmt: skip
        loop_fps = loop_stats["fps"]
        steps_per_frame = loop_stats["sim_steps"] / max(1, loop_stats["frames"])
    else:
        budget, loop, steps0 = FrameBudget(fixed_s=args.budget), [], s.steps_taken
        for _ in range(args.frames):  # the window's loop without the panel
            t0 = time.perf_counter()
            s.run_for(budget.next())
            present()
            loop.append(time.perf_counter() - t0)
            budget.record(loop[-1], s.last_run_s)
        loop_fps = 1.0 / np.median(loop)
        steps_per_frame = (s.steps_taken - steps0) / args.frames
    # a large slider move: the three girths of size 20, and the frames until the cloth
    # refits the new body (Session's refit mode) and the stop rule holds
    s.run_frames(30)
    t0 = time.perf_counter()
    s.resize(bust_girth=104.0, waist_girth=88.0, hip_girth=112.0)
    refit_frames = 0
    while refit_frames < 300:
        s.run_frames(1)
        refit_frames += 1
        if s.stats.converged and not s.stats.settling:
            break
    refit_s = time.perf_counter() - t0
    refit_draw_s = refit_frames * float(np.median(draw))
    # does it stay at rest? the largest vertex move of each of the next --hold frames
    held = []
    for _ in range(args.hold):
        s.run_frames(1)
        held.append((s.stats.max_displacement_m, s.stats.converged))
    w, h = args.size
    where = f"a window on {os.environ['DISPLAY']}" if windowed else "off-screen GGUI"
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python "
          f"{platform.python_version()}, {where}, {w}x{h}")  # fmt: skip
    dt, spf = s.scene.dt_s * 1e3, s.scene.steps_per_frame
    print(f"{args.garment}: {n} vertices, {s.model.tri_count} triangles, dt {dt:.3f} ms, "
          f"{spf} steps per 1/30 s frame")  # fmt: skip
    ms_sim, ms_draw = 1e3 * np.median(sim), 1e3 * np.median(draw)
    print(f"one simulated 1/30 s frame: {ms_sim:.1f} ms (median); drawing + read-back: "
          f"{ms_draw:.1f} ms")  # fmt: skip
    both, alone = 1.0 / np.median(sim + draw), 1.0 / np.median(draw)
    print(f"display fps with one simulated frame per display frame: {both:.1f}; "
          f"drawing alone: {alone:.1f} fps")  # fmt: skip
    what = "adaptive" if args.budget is None else f"{1e3 * args.budget:.0f} ms"
    parts = "panel, draw, show" if windowed else "draw, read back"
    print(f"window loop (simulation budget {what}, {parts}): {loop_fps:.1f} fps, "
          f"{steps_per_frame:.1f} steps per displayed frame "
          f"(simulated {steps_per_frame * s.scene.dt_s * loop_fps:.3f} s per wall s)")  # fmt: skip
    print(f"real-time factor of the simulation: {(1 / 30) / np.median(sim):.2f}")
    print(
        f"cover check (body through the cloth, every {COVER_EVERY_FRAMES} frames while it "
        f"settles): {1e3 * np.median(cover):.0f} ms median, {1e3 * max(cover):.0f} ms max"
    )
    print(f"refit after a resize to size 20's girths: stop rule after {refit_frames} frames, "
          f"{refit_s:.1f} s of simulation (+ {refit_draw_s:.1f} s drawing them); "
          f"{s.last_refit}")  # fmt: skip
    if held:
        moves = np.array([m for m, _ in held]) * 1e3
        print(f"after the refit, {len(held)} more frames: largest move {moves.max():.2f} mm, "
              f"median {np.median(moves):.2f} mm, the stop rule held in "
              f"{sum(c for _, c in held)} of them")  # fmt: skip
    print("slider changes [ms]:", " ".join(f"{1e3 * t:.0f}" for t in resize))
    print(f"slider change to a new frame: {1e3 * np.median(resize):.0f} ms median, "
          f"{1e3 * max(resize):.0f} ms max")  # fmt: skip


if __name__ == "__main__":
    main()
