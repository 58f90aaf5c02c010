"""Digest of library drapes: the SHA-1 of each garment's final positions and its acceptance.

Usage: python benchmarks/drape_digest.py OUT_DIR [GARMENT ...] [--edge-cm 3]

Drapes each garment (default: the whole library) on the size-12 mannequin in its own
fabric, explicit, without renders or meshes, and writes OUT_DIR/summary.json with the
hash, whether it meets the acceptance, its largest seam gap and its wall time. Two code
versions that give the same hashes drape bit for bit alike.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import time
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("garments", nargs="*")
    ap.add_argument("--edge-cm", type=float, default=3.0)
    args = ap.parse_args()
    from sandbox import runtime
    from sandbox.garment import drape, garment_names

    runtime.init("cpu")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = {}
    for g in args.garments or garment_names():
        t0 = time.perf_counter()
        r = drape(g, size=12, out_dir=out / g, edge_length_m=args.edge_cm / 100.0,
                  render=False, meshes=False, progress=False)  # fmt: skip
        x = np.ascontiguousarray(r.scene.state.positions())
        m = r.metrics
        rows[g] = {"sha1": hashlib.sha1(x.tobytes()).hexdigest(),
                   "meets_acceptance": m["meets_acceptance"],
                   "seam_gap_max_m": m["seam_gap_max_m"],
                   "wall_s": time.perf_counter() - t0}  # fmt: skip
        print(g, json.dumps(rows[g]), flush=True)
        (out / "summary.json").write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
