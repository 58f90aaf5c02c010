"""Does Taichi's CPU backend vectorise our loops? (why the step is below its throughput target)

Usage: python benchmarks/bench_vectorise.py [--n 1048576]

Compiles two one-line loops, ``b[i] = √a[i]/(1 + a[i]) + √(a[i] + 1)/(2 + a[i])``,
once over Taichi fields and once over ndarrays, with ``print_kernel_llvm_ir_optimized``
on, and reports for each:
the number of SIMD float operations (``<k x float>``) in the optimised LLVM IR of the loop
body, how often the body reloads a base pointer (from the runtime or the kernel's argument
context) inside the loop, and the time per element, next to numpy's for the same
expression. A loop LLVM has vectorised shows SIMD operations; a scalar one shows none.

Why it matters: the explicit step needs about 15 ns per element on two cores to reach
20 M vertex-steps/s at 16k vertices (docs/validation.md, Throughput); scalar code takes
20-35 ns per triangle or hinge on one thread here. Every store in a Taichi loop body may,
as far as LLVM can tell, alias the context that holds the fields' base pointers, so the
pointers are loaded again after each store and the loop vectoriser gives up.
"""

import argparse
import os
import platform
import re
import tempfile
import time
from pathlib import Path

import numpy as np


def body_stats(ll_text: str) -> tuple[int, int]:
    """(SIMD float operations, pointer reloads) in the ``function_body`` of one .ll file."""
    match = re.search(r"define internal void @function_body.*?\n}\n", ll_text, re.S)
    body = match.group(0) if match else ""
    simd = len(re.findall(r"<\d+ x float>", body))
    reloads = len(re.findall(r"= load [^,]*\*\*?, ", body))
    return simd, reloads


def per_element_ns(fn, n: int, rounds: int = 5) -> float:
    fn()
    best = float("inf")
    for _ in range(rounds):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best / n * 1e9


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1 << 20)
    args = ap.parse_args()
    n = args.n
    work = tempfile.mkdtemp(prefix="bench_vectorise_")
    os.chdir(work)  # Taichi writes the .ll files into the working directory
    import taichi as ti

    ti.init(arch=ti.cpu, print_kernel_llvm_ir_optimized=True, cpu_max_num_threads=1,
            offline_cache=False, log_level=ti.WARN)  # fmt: skip
    a = ti.field(ti.f32, n)
    b = ti.field(ti.f32, n)

    @ti.kernel
    def fields():
        for i in range(n):
            b[i] = ti.sqrt(a[i]) / (1.0 + a[i]) + ti.sqrt(a[i] + 1.0) / (2.0 + a[i])

    @ti.kernel
    def arrays(x: ti.types.ndarray(ndim=1), y: ti.types.ndarray(ndim=1)):
        for i in range(n):
            y[i] = ti.sqrt(x[i]) / (1.0 + x[i]) + ti.sqrt(x[i] + 1.0) / (2.0 + x[i])

    rng = np.random.default_rng(0)
    xa = rng.random(n).astype(np.float32)
    ya = np.zeros(n, np.float32)
    a.from_numpy(xa)

    def run_fields():
        fields()
        ti.sync()

    def run_arrays():
        arrays(xa, ya)
        ti.sync()

    rows = []
    for name, fn in (("fields", run_fields), ("ndarrays", run_arrays)):
        for old in Path(work).glob("*.ll"):
            old.unlink()
        ns = per_element_ns(fn, n)
        simd, reloads = body_stats("".join(p.read_text() for p in Path(work).glob("*.ll")))
        rows.append((name, simd, reloads, ns))
    numpy_ns = per_element_ns(lambda: np.sqrt(xa) / (1.0 + xa) + np.sqrt(xa + 1.0) / (2.0 + xa), n)
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python "
          f"{platform.python_version()}, Taichi {'.'.join(map(str, ti.__version__))}, float32, "
          f"one thread")  # fmt: skip
    print(f"{'loop':>9} {'SIMD float ops':>15} {'pointer loads':>14} {'ns/element':>11}")
    for name, simd, reloads, ns in rows:
        print(f"{name:>9} {simd:15d} {reloads:14d} {ns:11.2f}")
    print(f"{'numpy':>9} {'(SIMD)':>15} {'':>14} {numpy_ns:11.2f}")


if __name__ == "__main__":
    main()
