"""The garment library (paper Fig. 7): definitions in ``garments/<name>.json``, drafted to a
body's measurements as ``sandbox-pattern/1`` dicts (cm).

>>> from sandbox.mannequin.measurements import size_entry        # doctest: +SKIP
>>> pattern = draft("t-shirt", size_entry(12).measurements)       # doctest: +SKIP
"""

from __future__ import annotations

import copy
import dataclasses
import json
import site
import sys
from pathlib import Path

from sandbox.drafting.blocks import BLOCKS
from sandbox.drafting.body import body_dims
from sandbox.errors import SandboxError
from sandbox.mannequin.measurements import Measurements


def _garment_dir() -> Path:
    """The repository's ``garments/`` folder, or its installed copy.

    A checkout (or an editable install) reads the repository's folder; a wheel installs
    the same files under ``<prefix>/share/garment-sandbox/garments`` (pyproject's
    data-files), which is used when the repository folder is not there.
    """
    repo = Path(__file__).resolve().parents[2] / "garments"
    if repo.is_dir():
        return repo
    for prefix in (sys.prefix, sys.base_prefix, site.getuserbase()):
        shared = Path(prefix) / "share" / "garment-sandbox" / "garments"
        if shared.is_dir():
            return shared
    return repo


#: The garment definitions (data only): the repository's ``garments/`` folder.
GARMENT_DIR = _garment_dir()

#: Fig. 7 order: 4 sleeved tops, 5 sleeveless tops, 2 dresses, 3 skirts.
GARMENT_ORDER: tuple[str, ...] = (
    "t-shirt",
    "long-sleeve-shirt",
    "raglan-top",
    "blouse",
    "tank-top",
    "camisole",
    "sleeveless-blouse",
    "vest",
    "halter-top",
    "sheath-dress",
    "a-line-dress",
    "pencil-skirt",
    "a-line-skirt",
    "circle-skirt",
)
CATEGORIES = ("sleeved top", "sleeveless top", "dress", "skirt")
DEF_KEYS = ("name", "title", "category", "fabric", "block", "mesh_edge_cm", "description",
            "params")  # fmt: skip


@dataclasses.dataclass(frozen=True)
class GarmentDef:
    """One library garment: ``block`` (a key of :data:`sandbox.drafting.blocks.BLOCKS`),
    ``params`` (the block's drafting parameters, cm), default ``fabric`` preset, target
    ``mesh_edge_cm``, and where it was read from."""

    name: str
    title: str
    category: str
    fabric: str
    block: str
    params: dict
    mesh_edge_cm: float = 1.5
    description: str = ""
    source: str = "<garment>"


def garment_names() -> list[str]:
    """The 14 garments, grouped by category in the paper's Fig. 7 order."""
    return list(GARMENT_ORDER)


def garment_path(name: str) -> Path:
    return GARMENT_DIR / f"{name}.json"


def load_garment(name: str | Path) -> GarmentDef:
    """A garment definition by library name (``garments/<name>.json``) or by path."""
    path = Path(name) if str(name).endswith(".json") else garment_path(str(name))
    if not path.is_file():
        known = ", ".join(garment_names())
        raise SandboxError(f"garment {str(name)!r}: no file {path} (known garments: {known})")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise SandboxError(f"{path}: not valid JSON (line {exc.lineno}: {exc.msg})") from None
    return garment_from_dict(data, where=str(path))


def garment_from_dict(data: dict, *, where: str = "<garment>") -> GarmentDef:
    """Validate a garment definition dict (the JSON file's content)."""
    if not isinstance(data, dict):
        raise SandboxError(f"{where}: a garment definition is a JSON object")
    unknown = sorted(set(data) - set(DEF_KEYS))
    if unknown:
        raise SandboxError(f"{where}: unknown keys {unknown}; allowed: {', '.join(DEF_KEYS)}")
    for k in ("name", "title", "category", "fabric", "block", "params"):
        if k not in data:
            raise SandboxError(f"{where}: {k!r} is missing")
    if data["category"] not in CATEGORIES:
        raise SandboxError(f"{where}: category {data['category']!r}: use one of {CATEGORIES}")
    if data["block"] not in BLOCKS:
        raise SandboxError(f"{where}: block {data['block']!r}: use one of {', '.join(BLOCKS)}")
    if not isinstance(data["params"], dict):
        raise SandboxError(f"{where}: 'params' must be an object")
    from sandbox.sim.materials import material_from_spec

    material_from_spec(data["fabric"], where=f"{where}: fabric")
    return GarmentDef(
        name=data["name"],
        title=data["title"],
        category=data["category"],
        fabric=data["fabric"],
        block=data["block"],
        params=_strip_docs(copy.deepcopy(data["params"])),
        mesh_edge_cm=float(data.get("mesh_edge_cm", 1.5)),
        description=data.get("description", ""),
        source=where,
    )


def _strip_docs(v):
    """Parameters may be written as {"value": x, "unit": ..., "meaning": ...}: keep x.
    Keys starting with "_" are comments."""
    if isinstance(v, dict):
        if "value" in v and set(v) <= {"value", "unit", "meaning", "range"}:
            return _strip_docs(v["value"])
        return {k: _strip_docs(x) for k, x in v.items() if not k.startswith("_")}
    if isinstance(v, list):
        return [_strip_docs(x) for x in v]
    return v


def draft(name_or_def: str | GarmentDef, measurements: Measurements, *, mannequin=None) -> dict:
    """Draft a garment for a body: a ``sandbox-pattern/1`` dict in cm.

    Args:
        name_or_def: a library name (see :func:`garment_names`) or a :class:`GarmentDef`.
        measurements: the seven measurements [cm].
        mannequin: optional :class:`sandbox.mannequin.Mannequin` of that body; its
            landmarks then give the heights, neck and shoulder slope (else the size table).

    Returns the pattern dict (panels with landmark placements, seams with "auto"
    direction, ``meta`` with the measurements, the derived body dimensions and the
    garment's designed girths).
    """
    g = name_or_def if isinstance(name_or_def, GarmentDef) else load_garment(name_or_def)
    b = body_dims(measurements, mannequin)
    try:
        d = BLOCKS[g.block](g.params, b)
    except (KeyError, TypeError, ValueError) as exc:
        msg = f"{g.source}: params: cannot draft ({type(exc).__name__}: {exc})"
        raise SandboxError(msg) from None
    except SandboxError as exc:
        raise SandboxError(f"{g.source}: {exc}") from None
    return {
        "format": "sandbox-pattern/1",
        "name": g.name,
        "description": f"{g.title} ({g.category}), drafted by sandbox.drafting ({g.block} block)",
        "units": "cm",
        "fabric": g.fabric,
        "mesh_edge": g.mesh_edge_cm,
        "panels": d.panels,
        "seams": d.seams,
        "meta": {
            "garment": g.name,
            "title": g.title,
            "category": g.category,
            "block": g.block,
            "measurements_cm": measurements.to_dict(),
            "body_cm": b.to_dict(),
            "girths_cm": d.girths,
        },
    }
