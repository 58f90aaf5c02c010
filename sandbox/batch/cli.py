"""``python -m sandbox batch``: batch drapes on Ray (docs/batch.md).

::

    python -m sandbox batch SPEC.toml --out DIR [--workers N] [--address HOST:PORT]
    python -m sandbox batch SPEC.toml --out DIR --dry-run
    python -m sandbox batch --report DIR

Bad input (the spec, the flags, the folder) is one line on stderr and exit status 2, like
every command (:class:`~sandbox.errors.SandboxError`, printed by :func:`sandbox.cli.main`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from sandbox.errors import SandboxError


def add_cli(sub) -> None:
    """Register ``batch`` on the top-level parser's sub-commands."""
    p = sub.add_parser(
        "batch",
        help="drape many garments x bodies x fabrics on Ray, resumable, with quality gates",
        description="Run the tasks of a batch spec (the product of its garments, bodies, "
        "fabrics, mesh edges and integrators; docs/batch.md) on Ray workers, one per core "
        "(or per CPU of a cluster with --address). Each task is written to DIR/tasks/<id>/ "
        "whole or not at all; run the same command again after an interruption and only "
        "the missing tasks run. The manifest (DIR/manifest.parquet, .jsonl) lists every "
        "task with its inputs, status, gates, metrics and timings.",
    )
    p.add_argument("spec", nargs="?", type=Path, help="the batch spec (.toml)")
    p.add_argument("--out", type=Path, default=None, help="the batch folder (created)")
    p.add_argument("--dry-run", action="store_true",
                   help="check the spec, print the task count and an estimated wall "
                   "time")  # fmt: skip
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="workers to start (default: one per core, or per CPU of the cluster, "
                   "over threads_per_worker)")  # fmt: skip
    p.add_argument("--address", default=None, metavar="HOST:PORT",
                   help="join this Ray cluster (default: RAY_ADDRESS, else a local "
                   "Ray)")  # fmt: skip
    p.add_argument("--retry-failed", action="store_true",
                   help="run the tasks that failed (crash, error, killed) again")  # fmt: skip
    p.add_argument("--report", type=Path, default=None, metavar="DIR",
                   help="print the counts per status and per gate of the batch in DIR and "
                   "write its contact sheets")  # fmt: skip
    p.add_argument("--no-sheets", action="store_true", help="--report: no contact sheets")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress bar or summary")
    p.set_defaults(func=cmd_batch)


def cmd_batch(args: argparse.Namespace) -> int:
    """The ``batch`` command; returns the exit status."""
    if args.report is not None:
        if args.spec is not None or args.out is not None or args.dry_run:
            raise SandboxError("batch --report DIR takes no spec, --out or --dry-run")
        return _report(args.report, sheets=not args.no_sheets)
    if args.spec is None:
        raise SandboxError("batch: give a spec file (batch SPEC.toml --out DIR) or --report DIR")
    if args.out is None:
        raise SandboxError("batch: --out DIR is required")
    if args.workers is not None and args.workers < 1:
        raise SandboxError(f"--workers {args.workers}: must be at least 1")
    if args.address is not None and not args.address.strip():
        raise SandboxError("--address: an empty address")
    from sandbox import preflight
    from sandbox.batch.spec import load_spec

    spec = load_spec(args.spec)
    preflight.check_output_dir(args.out, "--out")
    for line in spec.warnings:
        print(f"warning: {line}")
    from sandbox.batch.estimate import check_sizes, drafted_patterns
    from sandbox.batch.spec import expand_tasks

    patterns = drafted_patterns(spec)
    check_sizes(spec, expand_tasks(spec), patterns)  # [drape.limits], before Ray starts
    if args.dry_run:
        return _dry_run(spec, args, patterns)
    from sandbox.batch.run import run_batch

    summary = run_batch(spec, args.out, workers=args.workers, address=args.address,
                        retry_failed=args.retry_failed, progress=not args.quiet)  # fmt: skip
    if not args.quiet:
        for line in summary.lines():
            print(line)
        print(f"manifest: {args.out / 'manifest.parquet'} (sandbox.batch.load({str(args.out)!r}))")
    return 0


def _dry_run(spec, args, patterns) -> int:
    from sandbox.batch import store
    from sandbox.batch.estimate import estimate
    from sandbox.batch.pool import local_workers, ray_address
    from sandbox.batch.spec import expand_tasks

    tasks = expand_tasks(spec)
    done = {}
    for t in tasks:
        data = store.read_task(store.task_dir(args.out, t.task_id))
        if data is not None:
            done[t.task_id] = float(data["batch"]["timings"]["task_wall_s"])
    workers = args.workers or local_workers(spec.threads_per_worker)
    est = estimate(spec, tasks, workers=workers, done=done, patterns=patterns)
    print(f"batch {spec.name}: {len(spec.garments)} garments x {len(spec.bodies)} bodies x "
          f"{len(spec.fabrics)} fabrics x {len(spec.edges_m)} mesh edges x "
          f"{len(spec.integrators)} integrators = {spec.task_count} tasks")  # fmt: skip
    if ray_address(args.address) and args.workers is None:
        print(f"(a cluster: assumed {workers} workers as on this machine; give --workers)")
    for line in est.lines():
        print(line)
    return 0


def _report(root: Path, *, sheets: bool) -> int:
    from sandbox.batch.report import report

    if not root.is_dir():
        raise SandboxError(f"--report {root}: no such folder")
    lines, _ = report(root, sheets=sheets)
    for line in lines:
        print(line)
    return 0
