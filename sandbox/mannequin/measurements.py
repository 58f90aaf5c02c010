"""The paper's seven mannequin measurements (§2.1.4), the size database and its checks.

User-facing values are centimetres (CLI flags, ``measurements.json``, the size database);
everything inside the geometry code is metres. :class:`Measurements` holds centimetres.
"""

from __future__ import annotations

import dataclasses
import json
import math
from functools import lru_cache
from importlib import resources
from pathlib import Path

from sandbox.errors import SandboxError

#: The seven measurements of §2.1.4, in the paper's order (all girths/lengths in cm).
KEYS: tuple[str, ...] = (
    "bust_girth",
    "waist_girth",
    "hip_girth",
    "shoulder_width",
    "back_width",
    "shoulder_length",
    "back_length",
)

#: Supported range of each measurement [cm], inclusive. Chosen to cover the database
#: (Aldrich sizes 6-26) with a margin; outside it the body shape rules are not trusted.
SUPPORTED_RANGE_CM: dict[str, tuple[float, float]] = {
    "bust_girth": (72.0, 130.0),
    "waist_girth": (54.0, 115.0),
    "hip_girth": (80.0, 135.0),
    "shoulder_width": (34.0, 50.0),
    "back_width": (29.0, 45.0),
    "shoulder_length": (10.0, 15.5),
    "back_length": (37.0, 46.0),
}

#: The size database shipped in the package (``sandbox/data/mannequin_sizes.json``), loaded
#: through :mod:`importlib.resources` so a non-editable install finds it.
SIZE_TABLE_RESOURCE = ("sandbox", "data/mannequin_sizes.json")
#: The canonical copy in the repository (``mannequins/sizes.json``); both are written by
#: ``python -m sandbox.mannequin.database`` and kept identical (a test checks).
REPO_SIZE_TABLE_PATH = Path(__file__).resolve().parents[2] / "mannequins" / "sizes.json"


@dataclasses.dataclass(frozen=True)
class Measurements:
    """The seven measurements of §2.1.4 [cm].

    ``shoulder_width`` is the across-back shoulder width (tape from shoulder point over the
    back neck point to shoulder point), ``back_width`` the across-back width at half the
    armscye depth, ``shoulder_length`` side neck point to shoulder point, ``back_length``
    nape (back neck point) to waist along the centre back.
    """

    bust_girth: float
    waist_girth: float
    hip_girth: float
    shoulder_width: float
    back_width: float
    shoulder_length: float
    back_length: float

    @classmethod
    def from_dict(cls, data: dict, *, where: str = "measurements") -> Measurements:
        """Build from a mapping with exactly the seven keys (cm); unknown keys are an error."""
        unknown = sorted(set(data) - set(KEYS))
        missing = [k for k in KEYS if k not in data]
        if unknown or missing:
            raise SandboxError(f"{where}: unknown keys {unknown} / missing keys {missing}")
        values = {}
        for k in KEYS:
            v = data[k]
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise SandboxError(f"{where}: {k} must be a finite number of cm, got {v!r}")
            values[k] = float(v)
        return cls(**values)

    def to_dict(self) -> dict[str, float]:
        """The seven values as a plain ``{key: cm}`` dict, in :data:`KEYS` order."""
        return {k: getattr(self, k) for k in KEYS}

    def replace(self, **changes: float | None) -> Measurements:
        """A copy with the given values replaced; ``None`` values are ignored."""
        return dataclasses.replace(self, **{k: v for k, v in changes.items() if v is not None})


def validate(m: Measurements, *, flag_names: dict[str, str] | None = None) -> None:
    """Raise :class:`SandboxError` if ``m`` is outside the supported range or contradictory.

    ``flag_names`` maps a key to the name the user typed (e.g. ``--back-width``) so that the
    message names what the user can change.
    """
    names = flag_names or {}
    problems = []
    for k in KEYS:
        lo, hi = SUPPORTED_RANGE_CM[k]
        v = getattr(m, k)
        if not lo <= v <= hi:
            problems.append(f"{names.get(k, k)}={v:g} cm is outside the supported {lo:g}-{hi:g}")
    # Contradictions between measurements (each one a body the surface cannot represent).
    if m.back_width > m.shoulder_width - 1.5:
        problems.append(
            f"{names.get('back_width', 'back_width')}={m.back_width:g} cm must be at least 1.5 cm "
            f"less than {names.get('shoulder_width', 'shoulder_width')}={m.shoulder_width:g} cm "
            "(the back width is taken between the armhole creases, inside the shoulder points)"
        )
    neck_room = m.shoulder_width - 2.0 * m.shoulder_length
    if not 8.0 <= neck_room <= 22.0:
        problems.append(
            f"{names.get('shoulder_width', 'shoulder_width')}={m.shoulder_width:g} cm and "
            f"{names.get('shoulder_length', 'shoulder_length')}={m.shoulder_length:g} cm leave "
            f"{neck_room:.1f} cm for the back of the neck; it must be 8-22 cm"
        )
    if m.back_width > 0.42 * m.bust_girth:
        problems.append(
            f"{names.get('back_width', 'back_width')}={m.back_width:g} cm is wider than 0.42 x "
            f"{names.get('bust_girth', 'bust_girth')}={m.bust_girth:g} cm"
        )
    if m.back_width < 0.27 * m.bust_girth:
        problems.append(
            f"{names.get('back_width', 'back_width')}={m.back_width:g} cm is narrower than "
            f"0.27 x {names.get('bust_girth', 'bust_girth')}={m.bust_girth:g} cm"
        )
    if m.waist_girth > min(m.bust_girth, m.hip_girth) + 5.0:
        problems.append(
            f"{names.get('waist_girth', 'waist_girth')}={m.waist_girth:g} cm exceeds the bust "
            "and hip girths by more than 5 cm"
        )
    if problems:
        raise SandboxError("measurements: " + "; ".join(problems))


@dataclasses.dataclass(frozen=True)
class SizeEntry:
    """One size of the database: its label, the seven measurements and the extra table values.

    ``extra`` holds the other Aldrich values [cm] the shape rules use (neck size, armscye
    depth, waist to hip, body rise, waist to knee, waist to floor, top arm, wrist, sleeve).
    """

    size: int
    measurements: Measurements
    extra: dict[str, float]


@lru_cache(maxsize=4)
def _load_table(path: Path | None) -> tuple[SizeEntry, ...]:
    try:
        if path is None:
            package, name = SIZE_TABLE_RESOURCE
            where = f"{package}/{name}"
            text = (resources.files(package) / name).read_text(encoding="utf-8")
        else:
            where = str(path)
            text = path.read_text(encoding="utf-8")
        data = json.loads(text)
    except (OSError, json.JSONDecodeError) as exc:
        raise SandboxError(f"{where}: cannot read the size database: {exc}") from exc
    entries = []
    for row in data.get("sizes", []):
        entries.append(
            SizeEntry(
                size=int(row["size"]),
                measurements=Measurements.from_dict(row["measurements"], where=where),
                extra={k: float(v) for k, v in row["extra"].items()},
            )
        )
    if not entries:
        raise SandboxError(f"{where}: the size database has no sizes")
    return tuple(entries)


def load_size_table(path: str | Path | None = None) -> tuple[SizeEntry, ...]:
    """The size database, smallest size first.

    Without ``path``, the copy shipped in the package (``sandbox/data/mannequin_sizes.json``,
    identical to ``mannequins/sizes.json``), found through :mod:`importlib.resources`.
    """
    return _load_table(Path(path) if path is not None else None)


def size_entry(size: int, table: tuple[SizeEntry, ...] | None = None) -> SizeEntry:
    """The database entry of ``size`` (UK size label 6-26); unknown sizes are an error."""
    table = table or load_size_table()
    for e in table:
        if e.size == size:
            return e
    raise SandboxError(f"--size {size}: not in the size database (sizes {[e.size for e in table]})")


def closest_size(m: Measurements, table: tuple[SizeEntry, ...] | None = None) -> SizeEntry:
    """§2.1.4 step 1: the closest size in the database.

    Distance: sum over the seven keys of the squared relative difference, so girths and
    the short lengths weigh alike.
    """
    table = table or load_size_table()
    req = m.to_dict()

    def dist(e: SizeEntry) -> float:
        ref = e.measurements.to_dict()
        return sum(((req[k] - ref[k]) / ref[k]) ** 2 for k in KEYS)

    return min(table, key=dist)
