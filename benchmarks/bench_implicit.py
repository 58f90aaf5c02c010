"""Implicit Euler (Newton-PCG) against symplectic Euler: cost, accuracy and damping.

Usage: python benchmarks/bench_implicit.py [sections] [--float64]
sections (default: all but garment): sizes, presets, fall, oscillation, cantilever, garment

* sizes: wall time per step for ~1k and ~5k vertex sheets (denim, membrane x100, hanging
  from two corners, dt = 1/60 s), Newton and CG iterations per step.
* presets: every fabric preset with stretch and shear x100, a 30 x 30 cm sheet (3 cm grid)
  starting flat, hanging from two corners, 3 s with damping 8/s: implicit at dt = 1/60 s
  against symplectic Euler at its stable step: max strain, final sag, largest vertex
  distance, wall time.
* fall: the same sheet (denim x100) without damping: the frame at which the sag first
  reaches 90 % of its final value, implicit against explicit (over-damping would be late).
* oscillation: a sheet pinned along its top edge swings from 20° without damping; the
  mechanical energy (kinetic + gravity + elastic) lost per swing period at dt = 1/60 and
  1/240 s, against the backward-Euler prediction (1 + (ωh)²)^(−2π/(ωh)).
* cantilever: the heavy-elastica cantilever (validation.md §2) at λ = 30, h = 2.5 mm, to
  the stop rule: tip error in % of L and wall time, implicit against symplectic Euler.
* garment: why implicit garment drapes are slow. The pencil skirt at 3 cm on size 12, its
  first sewing steps (no gravity, seams at 5 %): Newton iterations, residual force over
  weight, wall time per step; then the time to factorise its Newton matrix with SuperLU as
  the solver does (no pivoting, symmetric mode), and the same for the T-shirt at 1 cm.
* garment_fine: the A-line skirt at 1 cm (7.4k vertices, cotton), sewn by the drape's
  explicit sewing phase, then three implicit steps of 1/60 s under gravity: Newton
  iterations, error over tolerance, residual over weight, wall time per step.
* krylov_bound: what any converged iterative method would cost per step at 1 cm. The
  T-shirt (size 12, jersey) sewn by the drape's explicit phase, then one implicit step;
  its first three Newton systems A Δx = −∇E are solved exactly (scipy) and with
  block-Jacobi preconditioned CG, counting the iterations to an error of 10/1/0.1 % in
  A's norm and to 1 mm/0.1 mm/1.7 µm (the Newton tolerance at 1/60 s) at the worst
  vertex. CG's iterate is the best in A's norm over its Krylov space, which holds the
  iterates of Jacobi and Chebyshev-Jacobi with the same 3x3 blocks, so those need at
  least as many sweeps; plus the time of a matrix-vector product and of a gradient and
  Hessian evaluation in Taichi. Optional arguments: garment, edge [m].
"""

import argparse
import math
import platform
import sys
import time

import numpy as np

from sandbox import runtime
from sandbox.precision import add_precision_flags

# (tol_m_s, rel_tol, cg_tol) of the implicit cantilever runs: the defaults, then looser ones
CANTILEVER_TOLS = [(1e-4, 0.0, 0.1), (1e-4, 0.0, 1e-3), (1e-3, 0.0, 0.1), (1e-4, 1e-2, 0.1)]
SECTIONS = ("sizes", "presets", "fall", "oscillation", "cantilever")
EXTRA = ("garment", "garment_fine", "drape_newton_both", "krylov_bound")  # run only when named
G = 9.80665


def stiff(preset: str, factor: float) -> dict:
    from sandbox.sim.materials import get_material

    m = get_material(preset)
    return {
        "preset": preset,
        "stretch_u_N_m": m.stretch_u_N_m * factor,
        "stretch_v_N_m": m.stretch_v_N_m * factor,
        "shear_N_m": m.shear_N_m * factor,
    }


def sheet(material, integrator, *, size=0.3, edge=0.03, damping=0.0, dt="auto", rot=-90.0,
          pins=None):  # fmt: skip
    from sandbox.scene.build import build_scene
    from sandbox.scene.spec import scene_from_dict

    return build_scene(scene_from_dict({
        "scene": {"name": "bench-implicit"},
        "simulation": {"dt_s": dt, "damping_per_s": damping, "frame_rate_hz": 60,
                       "integrator": integrator},
        "cloth": [{"name": "sheet", "size_m": [size, size], "edge_length_m": edge,
                   "mesher": "grid", "material": material, "origin_m": [-size / 2, 0.5, 0.0],
                   "rotation_deg": [rot, 0.0, 0.0],
                   "pins": pins if pins is not None else [{"corners": "top"}]}],
    }, source="bench_implicit"))  # fmt: skip


def run_frames(scene, frames, on_frame=None):
    s = scene.solver
    s.advance(scene.state, scene.control, 0.0, 1)  # compile
    t0 = time.perf_counter()
    for f in range(frames):
        k = scene.steps_per_frame
        s.advance(scene.state, scene.control, scene.dt_s, k, f * k)
        if on_frame is not None:
            on_frame(f, scene.state.positions())
    wall = time.perf_counter() - t0
    if s.first_bad() is not None:
        raise SystemExit(f"NaN at {s.first_bad()}")
    return wall


def strain(scene, x):
    m = scene.model
    t = m.tri_indices_np
    d = np.stack([x[t[:, 1]] - x[t[:, 0]], x[t[:, 2]] - x[t[:, 0]]], axis=2)
    return float(np.linalg.norm(d @ m.tri_rest_inv_np, axis=1).max() - 1.0)


def sag(scene, x):
    p = scene.model.pinned_np
    return float(x[p, 1].max() - x[:, 1].min())


# ---------------------------------------------------------------------------- sections
def sizes():
    print("\n## sizes: denim x100 sheet 0.5 m, starts flat, two corners, dt = 1/60 s, the first "
          "frames of the fall (the hardest part: large rotations every step)")  # fmt: skip
    print(f"{'verts':>6} {'steps':>5} {'ms/step':>8} {'newton/step':>11} {'cg/step':>8} "
          f"{'cg/newton':>9} {'unconverged':>11} {'us/(cg*vert)':>12}")  # fmt: skip
    for n_side, frames in ((32, 30), (71, 8)):
        edge = 0.5 / (n_side - 1)
        sc = sheet(stiff("denim", 100), "implicit_euler", size=0.5, edge=edge * 1.0001)
        wall = run_frames(sc, frames)
        st = sc.solver.stats()
        n, k = sc.model.particle_count, st["steps"]
        print(f"{n:6d} {k:5d} {1e3 * wall / k:8.1f} {st['newton_iterations'] / k:11.2f} "
              f"{st['cg_iterations'] / k:8.0f} "
              f"{st['cg_iterations'] / st['newton_iterations']:9.0f} "
              f"{st['unconverged_steps']:11d} "
              f"{1e6 * wall / st['cg_iterations'] / n:12.3f}", flush=True)  # fmt: skip


def presets():
    from sandbox.sim.materials import EVERYDAY_PRESETS

    print("\n## presets x100 (stretch, shear): 30 cm sheet, 3 cm grid, two corners, 3 s, "
          "damping 8/s; implicit dt = 1/60 s vs symplectic Euler at its stable dt")  # fmt: skip
    print(f"{'preset':>10} {'dt_ref[us]':>10} {'strain_ref':>10} {'strain_imp':>10} "
          f"{'sag_ref[m]':>10} {'sag_imp[m]':>10} {'|dsag|/L':>9} {'max|dx|/L':>9} "
          f"{'wall_ref':>8} {'wall_imp':>8} {'newton/step':>11} {'unconv':>6}")  # fmt: skip
    for name in EVERYDAY_PRESETS:
        mat = stiff(name, 100)
        ref = sheet(mat, "symplectic_euler", damping=8.0)
        w_ref = run_frames(ref, 180)
        x_ref = ref.state.positions()
        imp = sheet(mat, "implicit_euler", damping=8.0)
        w_imp = run_frames(imp, 180)
        x = imp.state.positions()
        st = imp.solver.stats()
        print(f"{name:>10} {ref.dt_s * 1e6:10.2f} {strain(ref, x_ref):10.2e} "
              f"{strain(imp, x):10.2e} {sag(ref, x_ref):10.4f} {sag(imp, x):10.4f} "
              f"{abs(sag(imp, x) - sag(ref, x_ref)) / 0.3:9.1e} "
              f"{np.linalg.norm(x - x_ref, axis=1).max() / 0.3:9.1e} {w_ref:8.1f} {w_imp:8.1f} "
              f"{st['newton_iterations'] / st['steps']:11.2f} {st['unconverged_steps']:6d}",
              flush=True)  # fmt: skip


def fall():
    print("\n## fall: denim x100, 30 cm, two corners, no damping: sag after each frame [m]")
    curves = {}
    for integ in ("symplectic_euler", "implicit_euler"):
        sc = sheet(stiff("denim", 100), integ)
        s = []
        run_frames(sc, 90, lambda f, x, sc=sc, s=s: s.append(sag(sc, x)))
        curves[integ] = np.array(s)
    e, i = curves["symplectic_euler"], curves["implicit_euler"]
    final = 0.3  # the sheet hangs straight from its corners: sag → its size
    for name, c in curves.items():
        first = int(np.argmax(c >= 0.9 * final))
        print(f"{name:>17}: first frame with sag >= 90 % of 0.3 m: {first + 1} "
              f"(t = {(first + 1) / 60:.3f} s); sag at frames 5, 10, 15, 20, 30, 60: "
              + ", ".join(f"{c[k - 1]:.4f}" for k in (5, 10, 15, 20, 30, 60)))  # fmt: skip
    print(f"largest sag difference over the first 15 frames: {np.abs(e - i)[:15].max():.4f} m")


def oscillation():
    print("\n## oscillation: 30 cm denim sheet pinned along its top edge, released at 20° "
          "from vertical, no damping; mechanical energy above the rest state")  # fmt: skip
    for integ, dt in (("symplectic_euler", "auto"), ("implicit_euler", 1 / 60),
                      ("implicit_euler", 1 / 240)):  # fmt: skip
        sc = sheet("denim", integ, dt=dt, rot=-20.0, pins=[{"side": "top"}])
        m = sc.model.mass_np
        e, zc = [], []

        def on_frame(f, x, sc=sc, e=e, zc=zc, m=m):
            v = sc.state.velocities()
            ek = 0.5 * float((m[:, None] * v * v).sum())
            eg = G * float((m * x[:, 1]).sum())
            e.append(ek + eg + sc.solver.internal_energy(sc.state))
            zc.append(float((m * x[:, 2]).sum() / m.sum()))

        run_frames(sc, 240, on_frame)
        e = np.array(e)
        zc = np.array(zc)
        # rest energy: the sheet hanging straight down (gravity of the vertical drop)
        x0 = sc.model.initial_positions_np
        top = x0[:, 1].max()
        uv = sc.model.rest_uv_np
        y_rest = top - (uv[:, 1].max() - uv[:, 1])
        e_rest = G * float((m * y_rest).sum())
        em = e - e_rest
        # period from the downward zero crossings of the centre-of-mass z
        zz = zc - x0[sc.model.pinned_np, 2].mean()
        cross = np.where((zz[:-1] > 0) & (zz[1:] <= 0))[0]
        period_frames = float(np.diff(cross).mean()) if len(cross) > 1 else math.nan
        h = sc.dt_s
        omega = 2 * math.pi / (period_frames / 60) if period_frames == period_frames else math.nan
        loss = math.nan
        if len(cross) > 1:
            k = int(round(period_frames))
            loss = 1 - em[k] / em[0] if k < len(em) else math.nan
        pred = 1 - (1 + (omega * h) ** 2) ** (-2 * math.pi / (omega * h))
        head = f"{integ:>17} dt = {h:.3g} s: period {period_frames / 60:.3f} s, "
        if integ == "symplectic_euler":
            print(head + f"energy lost over the first period {100 * loss:.2f} % (no damping)")
        else:
            print(head + f"energy lost over the first period {100 * loss:.1f} % (backward "
                  f"Euler predicts {100 * pred:.1f} % for ω = {omega:.2f} rad/s)")  # fmt: skip


def cantilever():
    from sandbox.scene.build import build_scene
    from sandbox.scene.run import run_scene
    from sandbox.sim.implicit_config import ImplicitConfig
    from sandbox.validate.cantilever import LENGTH_M, cantilever_spec
    from sandbox.validate.elastica import tip

    print("\n## cantilever λ = 30, h = 2.5 mm, to the stop rule (2 µm/frame for 3 frames)")
    lam, edge = 30.0, 0.0025
    configs = [("symplectic_euler", None)]
    configs += [("implicit_euler", c) for c in CANTILEVER_TOLS]
    for integ, tol in configs:
        spec = cantilever_spec(lam, edge)
        spec.simulation.integrator = integ
        config = None
        if tol is not None:
            config = ImplicitConfig(tol_m_s=tol[0], rel_tol=tol[1], cg_tol=tol[2])
        sc = build_scene(spec, implicit=config)
        t0 = time.perf_counter()
        res = run_scene(sc, progress=False)
        wall = time.perf_counter() - t0
        x = res.positions
        uv = sc.model.rest_uv_np
        root = x[np.abs(uv[:, 0]) < 1e-9].mean(axis=0)
        tp = x[np.abs(uv[:, 0] - LENGTH_M) < 1e-9].mean(axis=0)
        reach, drop = (tp[0] - root[0]) / LENGTH_M, (root[1] - tp[1]) / LENGTH_M
        ed, er = tip(lam)
        err = 100 * math.hypot(drop - ed, reach - er)
        extra = ""
        if integ == "implicit_euler":
            st = sc.solver.stats()
            extra = (f" tol {tol[0]:g} m/s + {tol[1]:g} x motion, cg_tol {tol[2]:g},"
                     f" newton/step {st['newton_iterations'] / st['steps']:.2f},"
                     f" cg/step {st['cg_iterations'] / st['steps']:.0f}, unconverged "
                     f"{st['unconverged_steps']}")  # fmt: skip
        print(f"{integ:>17}: dt {sc.dt_s:.3g} s, {res.metrics['steps']} steps, "
              f"{sc.model.particle_count} verts, tip error {err:.3f} %L, wall {wall:.2f} s "
              f"(incl. compile {res.metrics['compile_time_s']:.1f} s not counted: "
              f"run {res.metrics['wall_time_s']:.2f} s), converged {res.converged}{extra}",
              flush=True)  # fmt: skip


def garment():
    import scipy.sparse.linalg as spl

    from sandbox.garment import DrapeConfig, SewingConfig, build_drape, make_mannequin

    body = make_mannequin(12)
    implicit = DrapeConfig(integrator="implicit_euler")
    for name, edge, steps in (("pencil-skirt", 0.03, 4), ("t-shirt", 0.01, 0)):
        sc = build_drape(name, body, edge_length_m=edge, config=implicit)
        s, state, control, model = sc.solver, sc.state, sc.control, sc.model
        control.gravity[None] = [0.0, 0.0, 0.0]
        model.set_seam_stiffness(model.seam_stiffness_np * SewingConfig().stiffness_factor)
        s.step(state, state, control, 0.0)  # compile
        for k in range(steps):
            s.step(state, state, control, sc.dt_s, k)
            last = s.last
            print(f"garment {name} {edge * 100:g} cm, {model.particle_count} verts, sewing step"
                  f" {k}: newton {last['newton_iterations']}, residual/weight "
                  f"{last['residual_force_over_weight']:.2g}, converged {last['converged']}, "
                  f"wall {last['wall_s']:.2f} s", flush=True)  # fmt: skip
        s._begin(state.x, state.v, control.gravity, control.damping_per_s, sc.dt_s)
        s._initial_guess()
        s._grad_hess()
        a = s.assembled_matrix()
        times = []
        for _ in range(3):
            t0 = time.perf_counter()
            spl.splu(a, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                     options={"SymmetricMode": True})  # fmt: skip
            times.append(time.perf_counter() - t0)
        print(
            f"garment {name} {edge * 100:g} cm: {a.shape[0]} unknowns, {a.nnz} non-zeros, "
            f"SuperLU factorisation {1e3 * min(times):.0f} ms (best of 3)",
            flush=True,
        )


def garment_fine(steps: int = 3):
    """The A-line skirt at 1 cm (cotton, size 12), sewn by the drape's own explicit sewing
    phase, then stepped by the implicit solver at 1/60 s under gravity."""
    from sandbox.garment import build_drape, make_mannequin
    from sandbox.garment.sewing import sew
    from sandbox.sim.implicit import ImplicitEulerSolver

    sc = build_drape("a-line-skirt", make_mannequin(12), edge_length_m=0.01)
    t0 = time.perf_counter()
    sewn = sew(sc)
    print(f"garment_fine a-line-skirt 1 cm, {sc.model.particle_count} verts: sewn explicitly "
          f"in {time.perf_counter() - t0:.0f} s, gap {sewn['sew_gap_m'] * 1e3:.2f} mm",
          flush=True)  # fmt: skip
    sc.model.strain_damping_s[None] = 0.0  # as an implicit drape runs
    s = ImplicitEulerSolver(sc.model)
    s.step(sc.state, sc.state, sc.control, 0.0)  # compile
    for k in range(steps):
        s.step(sc.state, sc.state, sc.control, 1.0 / 60.0, k)
        last = s.last
        print(f"garment_fine drape step {k}: newton {last['newton_iterations']}, error/tol "
              f"{last['error_estimate_m'] / last['tolerance_m']:.3g}, residual/weight "
              f"{last['residual_force_over_weight']:.2g}, converged {last['converged']}, "
              f"wall {last['wall_s']:.1f} s", flush=True)  # fmt: skip


def krylov_bound(name: str = "t-shirt", edge_m: float = 0.01, systems: int = 3):
    """See the module docstring (krylov_bound)."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as sla

    from sandbox.garment import build_drape, make_mannequin
    from sandbox.garment.sewing import sew
    from sandbox.sim.implicit import ImplicitEulerSolver

    sc = build_drape(name, make_mannequin(12), edge_length_m=edge_m)
    t0 = time.perf_counter()
    sewn = sew(sc)
    n = sc.model.particle_count
    print(
        f"krylov_bound {name} {edge_m * 100:g} cm, {n} verts: sewn explicitly in "
        f"{time.perf_counter() - t0:.0f} s, gap {sewn['sew_gap_m'] * 1e3:.2f} mm",
        flush=True,
    )
    sc.model.strain_damping_s[None] = 0.0  # as an implicit drape runs
    s = ImplicitEulerSolver(sc.model)
    s.step(sc.state, sc.state, sc.control, 0.0)  # compile
    captured = []
    solve_direct = s._solve_direct

    def capture():
        k = solve_direct()
        if len(captured) < systems:
            captured.append((s.assembled_matrix(), -s.grad_np[:n].ravel().copy()))
        return k

    s._solve_direct = capture
    s.step(sc.state, sc.state, sc.control, 1.0 / 60.0, 0)
    last = s.last
    print(
        f"krylov_bound implicit step: newton {last['newton_iterations']}, converged "
        f"{last['converged']}, wall {last['wall_s']:.1f} s"
    )
    for f, label in ((s._apply_kernel, "matrix-vector product"),
                     (s._grad_hess, "gradient + Hessian")):  # fmt: skip
        f()
        t = time.perf_counter()
        for _ in range(20):
            f()
        print(f"krylov_bound {label}: {(time.perf_counter() - t) / 20 * 1e3:.2f} ms")
    for k, (a, b) in enumerate(captured):
        a = a.tocsr()
        x_true = sla.spsolve(a.tocsc(), b)
        rows = (3 * np.arange(n)[:, None, None] + np.arange(3)[None, :, None]).repeat(3, 2)
        cols = rows.transpose(0, 2, 1)
        diag = np.asarray(a[rows.ravel(), cols.ravel()]).reshape(n, 3, 3)
        inv = sp.block_diag(list(np.linalg.inv(diag)), format="csr")
        norm0 = math.sqrt(x_true @ (a @ x_true))
        history = []

        def record(xk, a=a, x_true=x_true, norm0=norm0, history=history):
            e = xk - x_true
            history.append((math.sqrt(e @ (a @ e)) / norm0, np.abs(e).max()))

        precond = sla.LinearOperator(a.shape, matvec=lambda r, inv=inv: inv @ r)
        sla.cg(a, b, rtol=1e-12, maxiter=5000, M=precond, callback=record)

        def first(test, history=history):
            return next((i + 1 for i, h in enumerate(history) if test(h)), "-")

        energy = [first(lambda h, t=t: h[0] <= t) for t in (1e-1, 1e-2, 1e-3)]
        worst = [first(lambda h, t=t: h[1] <= t) for t in (1e-3, 1e-4, 1.7e-6)]
        print(f"krylov_bound Newton system {k}: max |dx| {np.abs(x_true).max() * 1e3:.1f} mm; "
              f"CG iterations to 10/1/0.1 % in A-norm {energy}, to 1 mm/0.1 mm/1.7 um at "
              f"the worst vertex {worst}", flush=True)  # fmt: skip


def drape_newton(name: str = "sleeveless-blouse", contact_in_energy: bool = True):
    """Newton's convergence over a whole implicit drape at 3 cm (size 12, the garment's
    fabric): steps, unconverged steps, mean Newton iterations, line-search halvings, and the
    drape's acceptance figures. ``contact_in_energy=False`` leaves body contact out
    of Newton's energy (contact only after the solve)."""
    from sandbox.garment import (
        DrapeConfig,
        build_drape,
        make_mannequin,
        resolve_pattern,
        run_drape,
    )

    man = make_mannequin(12)
    sc = build_drape(resolve_pattern(name, man), man, edge_length_m=0.03,
                     config=DrapeConfig(integrator="implicit_euler"))  # fmt: skip
    s = sc.solver
    s.has_contact = contact_in_energy  # read when the kernels compile (first step)
    rows = []
    step = s.step

    def logged(*args, **kw):
        step(*args, **kw)
        last = s.last
        rows.append((last["newton_iterations"], last["converged"], last["line_search_halvings"]))

    s.step = logged
    s.advance = lambda st, c, dt, n, first=0: [logged(st, st, c, dt, first + k) for k in range(n)]
    m = run_drape(sc, progress=False).metrics
    a = np.array(rows, float)
    print(f"drape_newton {name} 3 cm, contact in energy {contact_in_energy}: {len(a)} steps, "
          f"{int((a[:, 1] == 0).sum())} unconverged, Newton mean {a[:, 0].mean():.1f}, "
          f"line-search halvings {int(a[:, 2].sum())}; seam gap "
          f"{m['seam_gap_max_m'] * 1e3:.2f} mm, inside {m['vertices_inside_body']}, pairs "
          f"{m['intersecting_triangle_pairs']}, wall {m['total_wall_time_s']:.0f} s",
          flush=True)  # fmt: skip


def drape_newton_both():
    drape_newton(contact_in_energy=True)
    drape_newton(contact_in_energy=False)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sections", nargs="*", default=list(SECTIONS), choices=[*SECTIONS, *EXTRA, []])
    add_precision_flags(ap)
    args = ap.parse_args()
    runtime.init("cpu", float64=args.float64)
    print(f"bench_implicit: {platform.machine()} {platform.processor() or 'cpu'}, python "
          f"{sys.version.split()[0]}, {'float64' if args.float64 else 'float32'}")  # fmt: skip
    for s in args.sections or SECTIONS:
        globals()[s]()


if __name__ == "__main__":
    main()
