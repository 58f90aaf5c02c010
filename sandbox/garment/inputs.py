"""What a drape starts from: the garment's pattern, the mannequin and the fabric.

Each is resolved from what a user gives (a library name, a pattern file or dict; a database
size and measurements in cm; a preset name or table), with a one-line :class:`SandboxError`
for anything unknown or missing, before Taichi starts.
"""

from __future__ import annotations

from pathlib import Path

from sandbox.errors import SandboxError


def garment_names() -> list[str]:
    """Names of the library's garments."""
    from sandbox.drafting import garment_names as names

    return list(names())


def _unknown_garment(name: str) -> SandboxError:
    listed = ", ".join(garment_names())
    return SandboxError(f"unknown garment {name!r}: give a pattern .json file or one of the "
                        f"library's garments ({listed})")  # fmt: skip


def check_garment(garment) -> None:
    """Raise SandboxError early (before Taichi starts) for a missing file or unknown name."""
    path = Path(str(garment))
    if path.suffix.lower() == ".json" or path.exists():
        if not path.is_file():
            raise SandboxError(f"{path}: no such pattern file")
        return
    if str(garment) not in garment_names():
        raise _unknown_garment(str(garment))


def resolve_pattern(garment_or_path, mannequin=None):
    """A loaded :class:`~sandbox.pattern.spec.Pattern` from a path, a dict or a garment name.

    Library garments are drafted for the mannequin's measurements.
    """
    from sandbox.pattern.spec import Pattern, load_pattern

    if isinstance(garment_or_path, Pattern):
        return garment_or_path
    if isinstance(garment_or_path, dict):
        return load_pattern(garment_or_path)
    check_garment(garment_or_path)
    path = Path(str(garment_or_path))
    if path.is_file():
        return load_pattern(path)
    from sandbox.drafting import draft

    name = str(garment_or_path)
    measurements = mannequin.measurements_requested if mannequin is not None else None
    data = draft(name, measurements, mannequin=mannequin)
    return load_pattern(data, where=f"garment {name!r}")


def make_mannequin(size: int | None = None, measurements: dict | None = None,
                   arm_angle_deg: float | None = None,
                   head_length_cm: float | None = None):  # fmt: skip
    """The mannequin for a drape: a database size (default 12), resized by any
    measurements given in cm (keys of :data:`sandbox.mannequin.KEYS`), its arms at
    ``arm_angle_deg`` from the vertical (default: the A-pose), with a head whose crown is
    ``head_length_cm`` above the nape (default: none)."""
    from sandbox.mannequin import build_mannequin
    from sandbox.mannequin.cli import FLAGS
    from sandbox.mannequin.measurements import size_entry

    given = {k: float(v) for k, v in (measurements or {}).items() if v is not None}
    if not given:
        return build_mannequin(size=size if size is not None else 12, arm_angle_deg=arm_angle_deg,
                               head_length_cm=head_length_cm)  # fmt: skip
    base = size_entry(size if size is not None else 12).measurements
    return build_mannequin(base.replace(**given), size=size, flag_names=FLAGS,
                           arm_angle_deg=arm_angle_deg, head_length_cm=head_length_cm)  # fmt: skip


def material_for(pattern, fabric=None):
    """The cloth material: ``fabric`` (a preset name, a material table or a Material), else
    the pattern's own fabric."""
    from sandbox.sim.materials import Material, get_material, material_from_spec

    choice = pattern.fabric if fabric is None else fabric
    if isinstance(choice, Material):
        return choice
    where = f"{pattern.source}: fabric"
    if isinstance(choice, str):
        return get_material(choice, where=where)
    return material_from_spec(choice, where=where)


def measurements_dict(mannequin) -> dict | None:
    """The mannequin's requested measurements [cm] as a plain dict (None if it has none)."""
    meas = mannequin.measurements_requested
    if meas is None:
        return None
    return {k: float(v) for k, v in meas.to_dict().items()}
