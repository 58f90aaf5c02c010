"""Resize time for a live slider: new measurements -> new mesh at the default resolution.

Run: python benchmarks/bench_mannequin_resize.py
Each step moves one slider by up to 6 % from size 14 (as a UI does).
"""

from __future__ import annotations

import statistics
import time

import numpy as np

from sandbox.mannequin import DEFAULT_RESOLUTION, KEYS, build_mannequin


def main(steps: int = 200) -> None:
    body = build_mannequin(size=14)  # warms the template cache (one-off ~0.1 s)
    rng = np.random.default_rng(0)
    times = []
    base = body.measurements_requested
    for i in range(steps):
        key = KEYS[i % len(KEYS)]
        value = getattr(base, key)
        m = base.replace(**{key: round(value * (1 + rng.uniform(-0.06, 0.06)), 1)})
        t0 = time.perf_counter()
        body = body.resize(m)
        times.append(1000 * (time.perf_counter() - t0))
    t = np.array(times)
    print(
        f"resize at resolution {DEFAULT_RESOLUTION} ({len(body.triangles)} triangles), "
        f"{steps} slider steps: median {statistics.median(t):.1f} ms, "
        f"p95 {np.percentile(t, 95):.1f} ms, max {t.max():.1f} ms"
    )


if __name__ == "__main__":
    main()
