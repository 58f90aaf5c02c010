"""The drape pipeline: a garment on the mannequin (paper §2.3-2.5 and Fig. 7), from start to files.

pattern + mannequin -> :func:`~sandbox.garment.build.build_drape` (mesh, place, seams) ->
:func:`~sandbox.garment.sewing.sew` -> :func:`~sandbox.garment.repair.untangle_state` ->
:func:`~sandbox.scene.run.run_scene` (the paper's stop rule) ->
:func:`~sandbox.garment.repair.settle_repaired` -> :func:`~sandbox.garment.repair.settle_covered`
-> :func:`~sandbox.garment.metrics.drape_metrics`
-> :func:`~sandbox.garment.output.write_drape`.

The settings of every stage are one :class:`~sandbox.garment.config.DrapeConfig`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

from sandbox.errors import SandboxError
from sandbox.garment.build import build_drape, check_drape_size
from sandbox.garment.config import DrapeConfig
from sandbox.garment.fit import check_fit
from sandbox.garment.inputs import make_mannequin, material_for, resolve_pattern
from sandbox.garment.metrics import drape_metrics
from sandbox.garment.multilevel import drape_coarse_to_fine
from sandbox.garment.output import write_drape
from sandbox.garment.repair import settle_covered, settle_repaired, untangle_state
from sandbox.garment.sewing import sew


@dataclass
class DrapeResult:
    """A finished drape: the scene, the run, the metrics written and the files."""

    scene: object
    run: object
    metrics: dict
    paths: dict = field(default_factory=dict)


def drape(
    garment_or_path,
    *,
    out_dir,
    size: int | None = None,
    measurements: dict | None = None,
    fabric=None,
    edge_length_m: float | None = 0.01,
    config: DrapeConfig | None = None,
    render: bool = True,
    meshes: bool = True,
    progress: bool | None = None,
    mannequin=None,
    arm_angle_deg: float | None = None,
    head_length_cm: float | None = None,
) -> DrapeResult:
    """Drape a garment (library name, pattern file or dict) on a mannequin and write it.

    The mannequin is ``mannequin`` if given, else the database ``size`` (default 12)
    resized by ``measurements`` (cm), its arms at ``arm_angle_deg`` from the vertical (else as
    the pattern's ``meta.arm_angle_deg`` says, if it does), with a head ``head_length_cm``
    from nape to crown (else as its ``meta.head_length_cm`` asks; GarmentCode's imports
    record both: a hood rests on the head). ``config`` holds every setting of the simulation,
    the sewing, the repair and the acceptance (default :class:`DrapeConfig`). Writes into
    ``out_dir``: ``garment.obj`` / ``garment.ply`` (UVs = pattern coordinates [m]),
    ``body.obj``, ``render.png`` (front), ``render_back.png`` and ``metrics.json``
    (``meshes=False``: no meshes). Raises SandboxError on bad input and SimulationDiverged
    (nothing written) if the run blows up.
    """
    made = mannequin is None
    if made:
        mannequin = make_mannequin(size, measurements, arm_angle_deg=arm_angle_deg,
                                   head_length_cm=head_length_cm)  # fmt: skip
    pattern = resolve_pattern(garment_or_path, mannequin)
    pose = _meta_number(pattern, "arm_angle_deg") if arm_angle_deg is None else None
    head = _meta_number(pattern, "head_length_cm") if head_length_cm is None else None
    if made and (pose is not None or head is not None):
        # the pattern was drafted for a body in this pose, with a head (GarmentCode's imports)
        mannequin = make_mannequin(
            size, measurements,
            arm_angle_deg=arm_angle_deg if pose is None else pose,
            head_length_cm=head_length_cm if head is None else head)  # fmt: skip
    config = config or DrapeConfig()
    fit = check_fit(pattern, mannequin, material_for(pattern, fabric), config.fit)
    # refused before the coarse level runs (build_drape checks each level again)
    check_drape_size(pattern, edge_length_m, material_for(pattern, fabric), config, say=False)
    scene = fallback = None
    if config.method == "coarse_to_fine" and _finer(edge_length_m, pattern, config):
        scene, result, build_s = drape_coarse_to_fine(
            pattern, mannequin, fabric=fabric, edge_length_m=edge_length_m, config=config,
            progress=progress)  # fmt: skip
        if scene is None:  # the coarse level found no rest shape: drape directly
            fallback = _coarse_fallback(result.metrics, build_s)
    if scene is None:
        t0 = time.perf_counter()
        scene = build_drape(pattern, mannequin, fabric=fabric, edge_length_m=edge_length_m,
                            config=config)  # fmt: skip
        build_s = time.perf_counter() - t0
        result = run_drape(scene, progress=progress)
        result.metrics["method"] = "direct"
        if fallback:
            result.metrics.update(fallback)
            result.metrics["total_wall_time_s"] += fallback["coarse_wall_time_s"]
    metrics = drape_metrics(scene, result, build_s=build_s)
    metrics["fit"] = [f.as_dict() for f in fit]
    paths = write_drape(scene, result, metrics, out_dir, render=render, meshes=meshes)
    return DrapeResult(scene, result, metrics, paths)


def _meta_number(pattern, key: str) -> float | None:
    """A number from the pattern's ``meta`` (None when absent); SandboxError naming the file
    and the key for anything else."""
    v = pattern.meta.get(key)
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise SandboxError(f"{pattern.source}: meta.{key}: {v!r} is not a number")
    return float(v)


def _coarse_fallback(coarse_metrics: dict, coarse_wall_s: float) -> dict:
    """The metrics of a coarse level that found no rest shape (``coarse_to_fine`` then drapes
    directly): why, and what it cost, so the total wall time stays honest."""
    sim = coarse_metrics["sim_time_s"] + coarse_metrics.get("sew_sim_time_s", 0.0)
    return {
        "coarse_fallback": f"coarse level: {coarse_metrics['stop_reason']} "
        f"after {coarse_metrics['sim_time_s']:.2f} s simulated, not at rest; draped directly",
        "coarse_vertex_count": coarse_metrics["vertex_count"],
        "coarse_sim_time_s": sim,
        "coarse_converged": False,
        "coarse_wall_time_s": coarse_wall_s,
    }


def _finer(edge_length_m: float | None, pattern, config: DrapeConfig) -> bool:
    """Whether the drape's mesh is finer than the coarse level (else one level is enough)."""
    edge = pattern.mesh_edge_m if edge_length_m is None else float(edge_length_m)
    return edge < 0.75 * config.coarse_edge_m


def method_run(edge_length_m: float, config: DrapeConfig) -> str:
    """The method a drape on an ``edge_length_m`` [m] mesh runs (metrics' ``method``):
    ``config.method``, except that coarse to fine on a mesh no finer than its coarse level
    is direct. A coarse level that finds no rest shape also ends in a direct drape; its
    metrics say so (``coarse_fallback``)."""
    if config.method == "coarse_to_fine" and not _finer(edge_length_m, None, config):
        return "direct"
    return config.method


def run_drape(scene, *, progress: bool | None = None, cover: bool = True):
    """Sew, untangle, then drape under gravity to the paper's stop rule (``run_scene``),
    repairing a drape that ends tangled and, with ``cover``, one the body shows through
    (:func:`~sandbox.garment.repair.settle_covered`); the settings are the scene's
    ``garment.config``.

    The RunResult's metrics get the sewing phase's keys, the untangling passes
    (``untangle``, ``untangled_pairs``), the cover passes (``cover_passes``),
    ``strain_damping_s`` and ``total_wall_time_s``.
    """
    from sandbox.scene.run import run_scene

    config = scene.garment.config
    sewn = sew(scene, config.sewing)
    repairs = []
    if config.repair.after_sewing:
        repairs.append(untangle_state(scene, "after sewing", config.repair))
    result = run_scene(scene, progress=progress)
    result = settle_repaired(scene, result, repairs, config.repair, progress=progress)
    covered = []
    if cover:
        through = config.acceptance.body_through_m
        result, covered = settle_covered(scene, result, config.repair, through,
                                         progress=progress)  # fmt: skip
    result.metrics.update(sewn)
    result.metrics["cover_passes"] = covered
    result.metrics["untangle"] = repairs
    result.metrics["untangled_pairs"] = sum(r["pairs_before"] - r["pairs_after"] for r in repairs)
    result.metrics["strain_damping_s"] = float(scene.model.strain_damping_s[None])
    result.metrics["total_wall_time_s"] = result.metrics["wall_time_s"] + sewn["sew_wall_time_s"]
    return result
