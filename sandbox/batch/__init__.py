"""Batch drapes on Ray: many garments × bodies × fabrics, resumable, with quality gates.

``python -m sandbox batch SPEC.toml --out DIR`` (docs/batch.md). From Python::

    from sandbox.batch import load, load_spec, run_batch

    summary = run_batch(load_spec("examples/batch_small.toml"), "out/batch")
    df = load("out/batch")  # the manifest: one row per task, a pandas DataFrame

Modules, one concern each: :mod:`~sandbox.batch.spec` (the spec file and its tasks),
:mod:`~sandbox.batch.gates` (quality gates), :mod:`~sandbox.batch.worker` (a worker that
drapes tasks), :mod:`~sandbox.batch.pool` (workers as Ray actors), :mod:`~sandbox.batch.run`
(the scheduler), :mod:`~sandbox.batch.store` (task folders, plan, lock),
:mod:`~sandbox.batch.manifest` (the manifest), :mod:`~sandbox.batch.estimate`
(``--dry-run``), :mod:`~sandbox.batch.report` (``--report``), :mod:`~sandbox.batch.cli`.
"""

from sandbox.batch.manifest import load
from sandbox.batch.spec import BatchSpec, Task, expand_tasks, load_spec


def run_batch(spec, out_dir, **kwargs):
    """Run a batch (:func:`sandbox.batch.run.run_batch`)."""
    from sandbox.batch.run import run_batch as run

    return run(spec, out_dir, **kwargs)


__all__ = ["BatchSpec", "Task", "expand_tasks", "load", "load_spec", "run_batch"]
