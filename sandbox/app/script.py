"""Off-screen sessions driven by a JSON script of actions (how the docs' pictures are made).

A script is a JSON list; each item is one action object:

==============================================  =============================================
action                                          effect
==============================================  =============================================
``{"set": {"bust_girth": 96, ...}}``            resize the mannequin (cm, the 7 measurements)
``{"size": 16}``                                the database size's measurements
``{"sew": {"a": [["front", 1]], "b": [...]}}``  sew two sides (lists of [panel, edge index])
``{"click": [u, v], "shift": false}``           a click at window coordinates ([0, 1]², y up)
                                                in sewing mode, as in the window (``"side":
                                                "b"`` as holding the B key)
``{"click_edge": ["front", 1]}``                a click on the middle of that edge
``{"sew_picked": true}``                        sew the sides built with shift-clicks
``{"sew_pattern": true}``                       sew the pattern file's seams
``{"undo": true}`` / ``{"clear": true}``        undo the last seam / clear all seams
``{"gravity": true}``                            gravity on (off at the start: sewing table)
``{"run_frames": 30}``                          simulate 30 frames of 1/30 s
``{"fabric": "denim"}``                         another fabric preset
``{"pin": 12}`` / ``{"unpin": 12}``             pin or unpin a cloth vertex
``{"save_frame": "name.png"}``                  render a PNG into the output directory
``{"save_meshes": true}``                       garment.obj and body.obj
``{"save_pattern": "pattern.json"}``            the pattern with the seams sewn so far
``{"record": true}``                            from now on every frame goes into the GIF
==============================================  =============================================

Recorded frames are written as ``session.gif`` (imageio) at the end; ``summary.json`` lists
what each action did. Errors name the script, the action's index and the problem.
"""

from __future__ import annotations

import json
from pathlib import Path

from sandbox.errors import SandboxError

ACTIONS = ("set", "size", "gravity", "sew", "click", "click_edge", "sew_picked",
           "sew_pattern", "undo", "clear", "run_frames", "fabric", "pin", "unpin",
           "save_frame", "save_meshes", "save_pattern", "record")  # fmt: skip


def load_script(path) -> list[dict]:
    """Read and check a script file (a JSON list of one-key action objects)."""
    p = Path(path)
    try:
        data = json.loads(p.read_text())
    except FileNotFoundError:
        raise SandboxError(f"{p}: no such script file") from None
    except json.JSONDecodeError as exc:
        raise SandboxError(f"{p}: not valid JSON ({exc})") from None
    if not isinstance(data, list):
        raise SandboxError(f"{p}: a script is a JSON list of actions")
    for i, a in enumerate(data):
        if not isinstance(a, dict) or not a:
            raise SandboxError(f'{p}: action {i}: must be an object such as {{"run_frames": 10}}')
        unknown = [k for k in a if k not in ACTIONS and k not in ("shift", "side")]
        if unknown:
            raise SandboxError(f"{p}: action {i}: unknown action {unknown[0]!r} (known: "
                               f"{', '.join(ACTIONS)})")  # fmt: skip
        problem = _argument_problem(a)
        if problem:
            raise SandboxError(f"{p}: action {i}: {problem}")
    return data


def check_script_edges(actions: list[dict], pattern, source) -> None:
    """Every ``sew`` and ``click_edge`` action names a panel of ``pattern`` (a loaded
    :class:`~sandbox.pattern.spec.Pattern`) and one of its edges; SandboxError naming the
    script, the action and the panels or edges there are. Panel names and edge counts do
    not change with the body, so this holds whatever the script's ``set`` and ``size``."""
    for i, a in enumerate(actions):
        if "sew" in a:
            edges = [*a["sew"]["a"], *a["sew"]["b"]]
        elif "click_edge" in a:
            edges = [a["click_edge"]]
        else:
            continue
        for panel, edge in edges:
            if panel not in pattern.panels:
                raise SandboxError(f"{source}: action {i}: no panel {panel!r} in "
                                   f"{pattern.source} (panels: "
                                   f"{', '.join(pattern.panels)})")  # fmt: skip
            n = len(pattern.panels[panel].edges)
            if not 0 <= edge < n:
                raise SandboxError(f"{source}: action {i}: panel {panel!r} has edges "
                                   f"0..{n - 1}, not {edge}")  # fmt: skip


def _is_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_click(v) -> bool:
    def unit(c) -> bool:
        return isinstance(c, int | float) and not isinstance(c, bool) and 0 <= c <= 1

    return isinstance(v, list) and len(v) == 2 and all(map(unit, v))


def _is_edge(e) -> bool:
    return isinstance(e, list) and len(e) == 2 and isinstance(e[0], str) and _is_int(e[1])


def _argument_problem(a: dict) -> str | None:
    """What is wrong with one action's arguments (None if nothing), without a session."""
    names = [k for k in a if k in ACTIONS]
    if len(names) != 1:
        return f"one action per object, got {', '.join(names) or 'none'}"
    key, v = names[0], a[names[0]]
    if key in ("gravity", "record", "sew_picked", "sew_pattern", "undo", "clear",
               "save_meshes") and not isinstance(v, bool):  # fmt: skip
        return f"{key!r} takes true or false, got {v!r}"
    if "shift" in a and not isinstance(a["shift"], bool):
        return f"'shift' takes true or false, got {a['shift']!r}"
    if "side" in a and a["side"] not in ("a", "b"):
        return f"'side' must be a or b, got {a['side']!r}"
    if key in ("run_frames", "pin", "unpin") and not (_is_int(v) and v >= (key == "run_frames")):
        return f"{key!r} takes a whole number >= {int(key == 'run_frames')}, got {v!r}"
    if key == "set":
        from sandbox.mannequin.measurements import KEYS, SUPPORTED_RANGE_CM

        if not isinstance(v, dict) or not v:
            return f"'set' takes an object of measurements in cm ({', '.join(KEYS)})"
        for k, cm in v.items():
            if k not in KEYS:
                return f"'set': unknown measurement {k!r} (known: {', '.join(KEYS)})"
            lo, hi = SUPPORTED_RANGE_CM[k]
            if isinstance(cm, bool) or not isinstance(cm, int | float) or not lo <= cm <= hi:
                return f"'set': {k} must be a number of cm in {lo:g}-{hi:g}, got {cm!r}"
    if key == "size":
        from sandbox.mannequin.measurements import load_size_table

        sizes = [e.size for e in load_size_table()]
        if not _is_int(v) or v not in sizes:
            return f"'size' {v!r} is not in the size database (sizes {sizes})"
    if key == "fabric":
        from sandbox.sim.materials import get_material

        try:
            get_material(v)
        except SandboxError as exc:
            return f"'fabric': {exc}"
    if key == "sew" and not (isinstance(v, dict) and set(v) == {"a", "b"}
                             and all(isinstance(v[s], list) and v[s] and all(map(_is_edge, v[s]))
                                     for s in "ab")):  # fmt: skip
        return f"'sew' takes an object {{a: [[panel, edge], ...], b: [...]}}, got {v!r}"
    if key == "click" and not _is_click(v):
        return f"'click' takes [u, v] window coordinates in [0, 1], got {v!r}"
    if key == "click_edge" and not _is_edge(v):
        return f"'click_edge' takes [panel, edge number], got {v!r}"
    suffix = {"save_frame": ".png", "save_pattern": ".json"}.get(key)
    if suffix and not (isinstance(v, str) and Path(v).name == v and v.endswith(suffix)):
        return f"{key!r} takes a file name ending in {suffix} (written into --out), got {v!r}"
    return None


def run_script(session, actions: list[dict], out_dir, *, size=(480, 480), source="<script>",
               fps: int = 15) -> dict:  # fmt: skip
    """Play ``actions`` on a Session off-screen, writing into ``out_dir``. Returns a summary."""
    import imageio.v3 as iio

    from sandbox.app.gui import Renderer, Sewing
    from sandbox.atomic import atomic_path, make_dir, write_json

    out = make_dir(out_dir)
    r = Renderer(session, size, show_window=False)
    sewing = Sewing(session, r)
    frames, recording, log = [], False, []
    for i, a in enumerate(actions):
        where = f"{source}: action {i}"
        try:
            if "set" in a:
                tape = session.set_measurements(**a["set"])
                log.append({"set": a["set"], "tape_cm": tape})
            elif "size" in a:
                from sandbox.mannequin.measurements import KEYS, size_entry

                m = size_entry(int(a["size"])).measurements
                tape = session.set_measurements(**{k: getattr(m, k) for k in KEYS})
                log.append({"size": a["size"], "tape_cm": tape})
            elif "gravity" in a:
                session.set_gravity(bool(a["gravity"]))
                log.append({"gravity": bool(a["gravity"])})
            elif "sew" in a:
                ok = session.sew(a["sew"].get("a"), a["sew"].get("b"))
                log.append({"sew": a["sew"], "ok": ok, "message": session.message})
            elif "click" in a or "click_edge" in a:
                cur = a.get("click") or r.screen_of(*a["click_edge"])
                msg = sewing.click(cur, add=bool(a.get("shift", False)), side=a.get("side"))
                log.append({"click": list(cur), "message": msg})
            elif "sew_picked" in a:
                log.append({"sew_picked": sewing.finish()})
            elif "sew_pattern" in a:
                log.append({"sew_pattern": session.sew_pattern_seams()})
            elif "undo" in a:
                log.append({"undo": session.undo_seam()})
            elif "clear" in a:
                session.clear_seams()
                log.append({"clear": True})
            elif "run_frames" in a:
                for _ in range(int(a["run_frames"])):
                    session.run_frames(1)
                    if recording:
                        frames.append(r.image())
                st = session.stats
                log.append({"run_frames": a["run_frames"], "sim_time_s": st.sim_time_s,
                            "max_displacement_m": st.max_displacement_m,
                            "converged": st.converged, "refit": session.last_refit})  # fmt: skip
            elif "fabric" in a:
                session.set_fabric(a["fabric"])
                r = Renderer(session, size, show_window=False)
                sewing = Sewing(session, r)
                log.append({"fabric": a["fabric"]})
            elif "pin" in a or "unpin" in a:
                session.pin(int(a.get("pin", a.get("unpin"))), "pin" in a)
                log.append({"message": session.message})
            elif "save_frame" in a:
                log.append({"save_frame": str(r.save_png(out / a["save_frame"]))})
            elif "save_meshes" in a:
                log.append({k: str(v) for k, v in session.save_meshes(out).items()})
            elif "save_pattern" in a:
                log.append({"save_pattern": str(session.save_pattern(out / a["save_pattern"]))})
            elif "record" in a:
                recording = bool(a["record"])
        except SandboxError as exc:
            raise SandboxError(f"{where}: {exc}") from None
        except (TypeError, ValueError, KeyError, AttributeError) as exc:
            raise SandboxError(f"{where}: bad arguments {a!r} ({exc})") from None
    summary = {"actions": log, "seams": [[list(map(list, s.side_a)), list(map(list, s.side_b))]
                                         for s in session.seams],
               "measurements_cm": session.mannequin.measure(),
               "contact": session.contact_metrics()}  # fmt: skip
    if frames:
        with atomic_path(out / "session.gif") as tmp:
            iio.imwrite(tmp, frames, extension=".gif", duration=1000 // fps, loop=0)
        summary["gif"] = str(out / "session.gif")
    write_json(out / "summary.json", summary)
    r.window.destroy()  # GGUI's window must not outlive a later Taichi reset
    return summary
