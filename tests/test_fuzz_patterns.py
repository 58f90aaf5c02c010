"""Fuzz the pattern reader and the meshers with random outlines and seams (hypothesis).

Degenerate, self-crossing, repeated, huge, tiny and NaN coordinates: each case ends in a
SandboxError or a valid mesh, never another exception. The cases run in a child process
with 2 GB of address space, so a crash inside Triangle fails this test instead of killing
pytest.
"""

import os
import subprocess
import sys
from pathlib import Path

EXAMPLES = 150  # per property; about 15 s in all on a slow shared CPU
MEMORY_BYTES = 2 * 1024**3


def test_fuzz_outlines_and_seams_never_crash():
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    proc = subprocess.run(
        [sys.executable, "-X", "faulthandler", __file__, str(EXAMPLES)],
        capture_output=True, text=True, timeout=300, env=env,
        cwd=Path(__file__).resolve().parents[1],
    )  # fmt: skip
    assert proc.returncode == 0, (
        f"exit status {proc.returncode}\n{proc.stdout[-4000:]}\n{proc.stderr[-4000:]}"
    )
    assert "fuzz: ok" in proc.stdout


def _child(examples: int) -> None:  # runs in the child process only
    import math
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_BYTES, MEMORY_BYTES))
    import numpy as np
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    from sandbox.errors import SandboxError
    from sandbox.pattern.limits import PatternLimits
    from sandbox.pattern.mesh2d import mesh_polygon
    from sandbox.pattern.panel_mesh import mesh_pattern
    from sandbox.pattern.spec import load_pattern

    limits = PatternLimits(max_mesh_vertices=20_000)
    special = st.sampled_from([math.nan, math.inf, -math.inf, 1e300, -1e300, 1e-300, 0.0, 1e9])
    coord = st.one_of(st.floats(-80, 80).map(lambda v: round(v, 3)), st.integers(-60, 60),
                      special)  # fmt: skip
    point = st.tuples(coord, coord)

    @st.composite
    def outline(draw):
        pts = draw(st.lists(point, min_size=2, max_size=24))
        if draw(st.booleans()):  # a regular polygon: valid, then spoiled a little
            n = draw(st.integers(3, 40))
            r = draw(st.sampled_from([0.001, 0.5, 30.0, 300.0, 1e5]))
            t = np.linspace(0, 2 * np.pi, n, endpoint=False)
            pts = [(float(r * math.cos(a)), float(r * math.sin(a))) for a in t]
        for _ in range(draw(st.integers(0, 3))):  # repeat a corner, or nearly
            k = draw(st.integers(0, len(pts) - 1))
            eps = draw(st.sampled_from([0.0, 1e-9, 1e-5, 1e-3]))
            pts.insert(k + 1, (pts[k][0] + eps, pts[k][1]))
        return pts

    def curve(draw):
        kind = draw(st.sampled_from(["line", "line", "arc", "quadratic", "cubic"]))
        if kind == "arc":
            return {"type": "arc", "sagitta": draw(coord)}
        if kind == "quadratic":
            return {"type": "quadratic", "control": list(draw(point))}
        if kind == "cubic":
            return {"type": "cubic", "controls": [list(draw(point)), list(draw(point))]}
        return None

    @st.composite
    def pattern(draw):
        panels = {}
        for p in range(draw(st.integers(1, 2))):
            pts = draw(outline())
            edges = []
            for k in range(len(pts)):
                e = {"name": f"e{k}", "from": k, "to": (k + 1) % len(pts)}
                c = curve(draw)
                if c:
                    e["curve"] = c
                edges.append(e)
            panels[f"p{p}"] = {"vertices": [list(q) for q in pts], "edges": edges}
        seams = []
        for _ in range(draw(st.integers(0, 3))):
            side = [{"panel": draw(st.sampled_from(list(panels))), "edge": draw(st.integers(0, 4))}
                    for _ in range(2)]  # fmt: skip
            direction = draw(st.sampled_from(["auto", "same", "reverse"]))
            seams.append({"a": [side[0]], "b": [side[1]], "direction": direction})
        return {"format": "sandbox-pattern/1", "units": draw(st.sampled_from(["cm", "mm", "m"])),
                "mesh_edge": draw(st.sampled_from([0.5, 2.0, 10.0, 1e-4, 1e6])),
                "panels": panels, "seams": seams}  # fmt: skip

    def valid_mesh(points, tris):
        assert np.all(np.isfinite(points)) and len(tris) > 0
        assert tris.min() >= 0 and tris.max() < len(points)
        p = points[tris]
        cross = (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (
            p[:, 1, 1] - p[:, 0, 1]
        ) * (p[:, 2, 0] - p[:, 0, 0])
        assert np.all(cross > 0), "a triangle is flat or clockwise"

    common = settings(max_examples=examples, deadline=None, database=None,
                      suppress_health_check=list(HealthCheck))  # fmt: skip

    @common
    @given(pattern())
    def pattern_files(data):
        try:
            meshes = mesh_pattern(load_pattern(data, where="fuzz.json", limits=limits),
                                  limits=limits)  # fmt: skip
        except SandboxError as exc:
            assert "\n" not in str(exc) and str(exc).startswith("fuzz.json"), str(exc)
            return
        for m in meshes.values():
            valid_mesh(m.points, m.triangles)

    @common
    @given(outline(), st.lists(st.tuples(point, point), max_size=2),
           st.sampled_from([0.01, 0.2, 5.0, 1e-6]))  # fmt: skip
    def scene_outlines(pts, lines, h):
        try:
            points, tris = mesh_polygon(np.array(pts, float) / 100, h, where="scene.toml",
                                        inner_segments=lines, limits=limits)  # fmt: skip
        except SandboxError as exc:
            assert "\n" not in str(exc) and str(exc).startswith("scene.toml"), str(exc)
            return
        valid_mesh(points, tris)

    pattern_files()
    scene_outlines()
    print("fuzz: ok")


if __name__ == "__main__":
    _child(int(sys.argv[1]))
