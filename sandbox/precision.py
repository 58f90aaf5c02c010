"""The simulator's float precision: the default and the command-line flags.

Kept apart from :mod:`sandbox.runtime` so that parsers can add the flags without importing
Taichi (whose banner would mix into ``--help`` and ``--list`` output).
"""

from __future__ import annotations

DEFAULT_FLOAT64 = True
"""Simulate in double precision unless asked otherwise (``--float32`` on the command line).

Measured on the 1 cm denim vest, size 12 (``benchmarks/bench_drape.py vest --edge-cm 1``):
in float32 it never met the stop rule (after 8 s simulated, 560 s wall, the cloth still
moved 0.35 mm a frame on average, 3 mm at most, in place), in float64 it converged after
2.1 s simulated, 188 s wall. A float32 position near y = 1.3 m is only known to 0.12 µm,
so a 1 cm edge's strain only to ~1e-5; at denim's stiffness that noise is a force of the
order of the vertex's own weight, and the stiff cloth shakes in place instead of settling.
A float64 step costs about 18 % more wall time (same runs). The explicit-step throughput
benchmarks (``bench_step``, ``bench_elements``, ``bench_collision``) keep measuring float32.
"""


def add_precision_flags(parser) -> None:
    """Add ``--float32`` and ``--float64`` (the default) to an argparse parser; the choice
    lands in ``args.float64``."""
    g = parser.add_mutually_exclusive_group()
    g.add_argument("--float32", dest="float64", action="store_false",
                   help="simulate in single precision: about 15%% faster a step, but stiff "
                   "fabrics on fine meshes shake in place and may miss the stop rule")  # fmt: skip
    g.add_argument("--float64", dest="float64", action="store_true",
                   help="simulate in double precision (the default)")  # fmt: skip
    parser.set_defaults(float64=DEFAULT_FLOAT64)
