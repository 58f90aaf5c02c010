"""Cloth materials: the constants of the paper's energy (Leong, Kuo, Fang 2011, Eq. 6-7).

Per triangle the membrane energy per rest area is

    E_u/2 (S_u - 1)^2 + E_v/2 (S_v - 1)^2 + E_s/2 (2θ_s)^2      [J/m^2]

with S_u, S_v the stretch ratios of the warp (u) and weft (v) directions and 2θ_s the shear
angle, so E_u, E_v, E_s are in N/m. There is no Poisson coupling. Bending uses a continuum
flexural rigidity B [N·m] per unit width that may depend on direction (see
:func:`bend_rigidity_at`). Areal density ρ_A is in kg/m^2.

Presets come from the ten fabrics measured by Wang, O'Brien and Ramamoorthi (2011) as shipped
with ARCSim (``sandbox/data/fabrics_wang2011.json``), converted by :func:`from_wang2011`, plus
everyday names that point at one of them. ``docs/fabrics.md`` explains the conversion and the
direction mapping; its table is printed by ``python -m sandbox.sim.materials``.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import json
import math
import numbers
import sys
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from sandbox.errors import SandboxError

GRAVITY_M_S2 = 9.80665
"""Standard gravity [m/s^2], used for bending lengths."""

DATA_FILE = "fabrics_wang2011.json"
"""The Wang 2011 data inside the package (``sandbox/data/``)."""

TABLE_BEGIN = "<!-- BEGIN materials table (python -m sandbox.sim.materials) -->"
TABLE_END = "<!-- END materials table -->"


@dataclass(frozen=True)
class Material:
    """Constants of one cloth material, in SI units.

    Attributes:
        name: preset or user name.
        density_kg_m2: areal density ρ_A [kg/m^2], > 0.
        stretch_u_N_m: E_u, warp (u) stretch stiffness [N/m]: energy per rest area
            E_u/2 (S_u − 1)^2.
        stretch_v_N_m: E_v, weft (v) stretch stiffness [N/m].
        shear_N_m: E_s, shear stiffness [N/m] (per radian^2): energy E_s/2 (2θ_s)^2.
        bend_warp_Nm: B_warp [N·m], flexural rigidity per unit width of a strip cut along
            the warp (u) and bent along its length (curvature along u; its hinge edges run
            along v).
        bend_weft_Nm: B_weft [N·m], the same for a strip cut along the weft (v).
        bend_bias_Nm: B_bias [N·m], the same for a strip cut at 45° (bias).
        source: one line saying where the numbers come from.

    All stiffnesses are finite and >= 0 (0 switches that energy off); the density is > 0.
    """

    name: str
    density_kg_m2: float
    stretch_u_N_m: float
    stretch_v_N_m: float
    shear_N_m: float
    bend_warp_Nm: float
    bend_weft_Nm: float
    bend_bias_Nm: float
    source: str

    def __post_init__(self) -> None:
        for f in _NUMERIC_FIELDS:
            value = getattr(self, f)
            if not _is_number(value) or not math.isfinite(value) or value < 0:
                raise SandboxError(
                    f"material {self.name!r}: {f} must be a finite number >= 0, got {value!r}"
                )
            object.__setattr__(self, f, float(value))
        if self.density_kg_m2 <= 0:
            raise SandboxError(f"material {self.name!r}: density_kg_m2 must be > 0, got 0")

    def bend_for_hinge_angle(self, phi_rad):
        """B [N·m] for a hinge whose edge makes angle ``phi_rad`` with u; see
        :func:`bend_rigidity_at`."""
        return bend_rigidity_at(self, phi_rad)

    def bending_lengths_m(self) -> tuple[float, float, float]:
        """Bending lengths c = (B/(ρ_A g))^(1/3) [m] for warp, weft and bias strips."""
        return (
            bending_length_m(self.bend_warp_Nm, self.density_kg_m2),
            bending_length_m(self.bend_weft_Nm, self.density_kg_m2),
            bending_length_m(self.bend_bias_Nm, self.density_kg_m2),
        )


_NUMERIC_FIELDS = (
    "density_kg_m2",
    "stretch_u_N_m",
    "stretch_v_N_m",
    "shear_N_m",
    "bend_warp_Nm",
    "bend_weft_Nm",
    "bend_bias_Nm",
)


def _is_number(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)


# --------------------------------------------------------------------------------------
# Direction-dependent bending


def bend_rigidity_at(material: Material, phi):
    """Flexural rigidity B(φ) [N·m] for a hinge whose EDGE makes angle φ [rad] with u.

    φ is measured in the pattern plane from the u (warp) axis to the hinge edge. A hinge
    bends the cloth across its edge, so the curvature runs perpendicular to the edge:

    * φ = 90° (edge along v, curvature along u, as in a strip cut along the warp): B_warp;
    * φ = 0° (edge along u, curvature along v, a strip cut along the weft): B_weft;
    * φ = 45° (bias): B_bias.

    Between these the rigidity is the smooth, period-π, mirror-symmetric blend

        B(φ) = B_weft cos²φ + B_warp sin²φ + (B_bias − (B_warp + B_weft)/2) sin²2φ,

    clamped at 0 (it can only dip below 0 for extreme anisotropy, B_bias much smaller than
    the mean of B_warp and B_weft; none of the presets does). The sign and the half-turn of
    the edge do not matter, so ``phi = np.arctan2(dv, du)`` of the rest edge vector works
    directly. ``phi`` may be a float or a numpy array; the result has the same shape (a
    float for a scalar).
    """
    p = np.asarray(phi, dtype=np.float64)
    c2 = np.cos(p) ** 2
    s2 = 1.0 - c2
    s22 = np.sin(2.0 * p) ** 2
    warp, weft, bias = material.bend_warp_Nm, material.bend_weft_Nm, material.bend_bias_Nm
    b = weft * c2 + warp * s2 + (bias - 0.5 * (warp + weft)) * s22
    b = np.maximum(b, 0.0)
    if b.ndim == 0:
        return float(b)
    return b


def bending_length_m(bend_Nm: float, density_kg_m2: float) -> float:
    """Bending length c = (B / (ρ_A g))^(1/3) [m] (Peirce; ASTM D1388)."""
    return float((bend_Nm / (density_kg_m2 * GRAVITY_M_S2)) ** (1.0 / 3.0))


# --------------------------------------------------------------------------------------
# Wang, O'Brien, Ramamoorthi 2011 (ARCSim materials)


@functools.cache
def _wang_data() -> dict:
    ref = resources.files("sandbox") / "data" / DATA_FILE
    try:
        text = ref.read_text(encoding="utf-8")
    except OSError as exc:
        raise SandboxError(f"sandbox/data/{DATA_FILE}: cannot read the fabric data: {exc}") from exc
    try:
        data = json.loads(text)
        tables = data["fabrics_raw_arcsim_tables"]
    except (ValueError, KeyError) as exc:
        raise SandboxError(
            f"sandbox/data/{DATA_FILE}: not the expected fabric data ({exc})"
        ) from exc
    return {"tables": tables, "summary": data.get("fabrics_small_strain_summary", {})}


def wang2011_names() -> list[str]:
    """The ten Wang 2011 fabric names, in the order of the data file."""
    return list(_wang_data()["tables"])


def _wang_table(name: str) -> dict:
    tables = _wang_data()["tables"]
    if name not in tables:
        raise SandboxError(
            f"sandbox/data/{DATA_FILE}: no fabric {name!r}; known: {', '.join(tables)}"
        )
    return tables[name]


def wang2011_arcsim_coefficients(name: str) -> dict[str, float]:
    """ARCSim's effective small-strain coefficients of one Wang 2011 fabric.

    Stretching: row 0 (zero strain) of the 6x4 table with ARCSim's treatment
    (``evaluate_stretching_sample`` in ``dde.cpp``): negative entries clamped to 0, then
    multiplied by 2. Keys ``k0_uu, k1_uv, k2_vv, k3_shear`` [N/m], meaning the energy per
    rest area ½(k0 G00² + k2 G11² + 2 k1 G00 G11 + k3 G01²) with G the Green strain.

    Bending: column 0 (zero curvature) of the 3x5 table, ``ke_edge_0deg``,
    ``ke_edge_45deg``, ``ke_edge_90deg`` [N·m], rows indexed by the hinge EDGE direction
    in material space (``bending_stiffness`` in ``dde.cpp``).
    """
    t = _wang_table(name)
    row0 = [2.0 * max(float(x), 0.0) for x in t["stretching"][0]]
    ke = [float(t["bending"][i][0]) for i in range(3)]
    return {
        "k0_uu": row0[0],
        "k1_uv": row0[1],
        "k2_vv": row0[2],
        "k3_shear": row0[3],
        "ke_edge_0deg": ke[0],
        "ke_edge_45deg": ke[1],
        "ke_edge_90deg": ke[2],
    }


def from_wang2011(name: str) -> Material:
    """Convert one Wang 2011 / ARCSim fabric to this model's constants (small strain).

    From the ARCSim coefficients of :func:`wang2011_arcsim_coefficients` (row 0, clamped,
    ×2):

    * E_u = Y_u = k0 − k1²/k2 and E_v = Y_v = k2 − k1²/k0 [N/m]: the uniaxial stiffness
      with free lateral contraction. Pulling along u with the v direction free of stress,
      ARCSim's energy ½(k0 ε_u² + 2 k1 ε_u ε_v + k2 ε_v²) is minimised by ε_v = −(k1/k2) ε_u
      and becomes ½(k0 − k1²/k2) ε_u². Our model has no Poisson coupling, so its energy in
      the same test is ½ E_u ε_u² (S_u − 1 ≈ G00 ≈ ε_u at small strain). Matching the
      force-per-width against strain of a free strip, which is what hanging and draping
      cloth mostly does, gives E_u = Y_u. (Under biaxial constraint our model is then
      softer than ARCSim by k1²/k2; for most of the ten fabrics k1 is small.)
    * E_s = k3/4 [N/m]: at small strain G01 ≈ γ/2 with γ = 2θ_s the shear angle, so
      ½ k3 G01² = ½ (k3/4) γ².
    * B = ke/4 [N·m] with ke at zero curvature: ARCSim's hinge energy
      ke l² θ²/(8 (A0 + A1)) equals the continuum ½ B κ² per area with B ≈ ke/4 on
      equilateral meshes (``validation.md`` §6g). ARCSim indexes the bending rows by the
      direction of the hinge edge in material space, so the 0° row (edge along u,
      curvature along v) is B_weft, the 90° row is B_warp, and 45° is B_bias.

    Strain and curvature dependence (the other rows and columns) is dropped.
    """
    t = _wang_table(name)
    k = wang2011_arcsim_coefficients(name)
    k0, k1, k2, k3 = k["k0_uu"], k["k1_uv"], k["k2_vv"], k["k3_shear"]
    return Material(
        name=name,
        density_kg_m2=float(t["density"]),
        stretch_u_N_m=k0 - k1 * k1 / k2 if k2 > 0 else k0,
        stretch_v_N_m=k2 - k1 * k1 / k0 if k0 > 0 else k2,
        shear_N_m=k3 / 4.0,
        bend_warp_Nm=k["ke_edge_90deg"] / 4.0,
        bend_weft_Nm=k["ke_edge_0deg"] / 4.0,
        bend_bias_Nm=k["ke_edge_45deg"] / 4.0,
        source=(
            f"Wang, O'Brien, Ramamoorthi 2011 '{name}' ({t.get('use', '?')}, "
            f"{t.get('fiber', '?')}), ARCSim data, small-strain conversion (docs/fabrics.md)"
        ),
    )


# --------------------------------------------------------------------------------------
# Presets

EVERYDAY_PRESETS: dict[str, tuple[str, str]] = {
    "cotton": (
        "royal-target",
        "65% cotton 35% polyester trouser fabric; woven-like stretch (~4000 N/m both ways), "
        "0.220 kg/m^2: the closest of the ten to a plain cotton woven (a poly-cotton blend, "
        "heavier than a shirting)",
    ),
    "denim": ("11oz-black-denim", "11 oz jeans denim, 99% cotton 1% spandex, 0.324 kg/m^2"),
    "silk": (
        "tango-red-jet-set",
        "NO silk was measured: this is the lightest (0.113 kg/m^2) and on average the most "
        "flexible (B 3.6-5.5 µN·m) of the ten, a 100% polyester jacket fabric whose stretch "
        "(52/206 N/m) is knit-like, far softer in-plane than a silk woven",
    ),
    "jersey": ("gray-interlock", "60% cotton 40% polyester interlock (double jersey) T-shirt knit"),
    "knit": ("ivory-rib-knit", "95% cotton 5% spandex rib knit (underwear)"),
    "polyester": (
        "white-dots-on-blk",
        "100% polyester tablecloth fabric, light (0.128 kg/m^2), woven-like stretch "
        "(~4000 N/m both ways)",
    ),
    "sweater": ("navy-sparkle-sweat", "96% polyester 4% spandex sweater knit"),
    "ponte": ("camel-ponte-roma", "60% polyester 40% rayon ponte di Roma double knit (jacket)"),
    "swimwear": ("white-swim-solid", "87% nylon 13% spandex swimsuit fabric"),
    "blanket": ("pink-ribbon-brown", "100% polyester blanket fabric (use given as blanket)"),
}
"""Everyday names -> (Wang 2011 fabric, why). There is no wool among the ten, so no ``wool``."""


@functools.cache
def _presets() -> dict[str, Material]:
    out: dict[str, Material] = {}
    for alias, (wang, why) in EVERYDAY_PRESETS.items():
        base = from_wang2011(wang)
        out[alias] = dataclasses.replace(
            base, name=alias, source=f"Wang 2011 '{wang}' via ARCSim ({why})"
        )
    for wang in wang2011_names():
        out[wang] = from_wang2011(wang)
    return out


def _normalise(name: str) -> str:
    return name.strip().lower().replace("_", "-")


def list_presets() -> list[str]:
    """All preset names: the everyday names, then the ten Wang 2011 fabrics."""
    return list(_presets())


def get_material(name: str, *, where: str | None = None) -> Material:
    """The preset called ``name`` (case-insensitive, ``_`` and ``-`` alike).

    Raises SandboxError listing the known names on a miss; ``where`` (e.g.
    ``"scene.toml: cloth[0].material"``) prefixes the message.
    """
    presets = _presets()
    key = _normalise(name) if isinstance(name, str) else None
    if key not in presets:
        prefix = f"{where}: " if where else ""
        raise SandboxError(
            f"{prefix}unknown material preset {name!r}; known presets: {', '.join(presets)}"
        )
    return presets[key]


# --------------------------------------------------------------------------------------
# Materials from scene specs

_SPEC_KEYS = ("preset", "name", *_NUMERIC_FIELDS, "bend_Nm")
_DIRECTIONAL_BEND = ("bend_warp_Nm", "bend_weft_Nm", "bend_bias_Nm")
_MEMBRANE = ("stretch_u_N_m", "stretch_v_N_m", "shear_N_m")


def _check_number(value, key: str, where: str) -> float:
    if not _is_number(value):
        raise SandboxError(f"{where}: {key!r} must be a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise SandboxError(f"{where}: {key!r} must be finite, got {value!r}")
    if v < 0:
        raise SandboxError(f"{where}: {key!r} must be >= 0, got {value!r}")
    if key == "density_kg_m2" and v == 0:
        raise SandboxError(f"{where}: {key!r} must be > 0 (areal density in kg/m^2), got 0")
    if key in _MEMBRANE and v == 0:
        raise SandboxError(f"{where}: {key!r} must be > 0: without stretch and shear "
                           f"stiffness nothing holds the cloth together, got 0")  # fmt: skip
    return v


def material_from_spec(spec, *, where: str) -> Material:
    """Build a Material from a scene entry.

    ``spec`` is a preset name (see :func:`list_presets`) or a dict (e.g. a TOML table)
    with the keys:

    * ``preset``: optional base preset; the other keys override it;
    * ``name``: optional name (default: the preset's name, or ``"custom"``);
    * ``density_kg_m2`` [kg/m^2, > 0], ``stretch_u_N_m``, ``stretch_v_N_m``,
      ``shear_N_m`` [N/m];
    * bending [N·m]: either ``bend_Nm`` (one value for all directions) or any of
      ``bend_warp_Nm``, ``bend_weft_Nm``, ``bend_bias_Nm``, not both kinds.

    Without ``preset`` every quantity must be given (bending as ``bend_Nm`` or all three
    directions). Values must be finite numbers >= 0; the stretch and shear stiffnesses
    must be > 0 (a cloth without them falls apart), a zero bending stiffness switches
    bending off. Every error is a SandboxError whose message starts with ``where`` (e.g.
    ``"scene.toml: cloth[0].material"``) and names the offending key.
    """
    if isinstance(spec, Material):
        return spec
    if isinstance(spec, str):
        return get_material(spec, where=where)
    if not isinstance(spec, dict):
        raise SandboxError(
            f"{where}: a material is a preset name or a table of keys "
            f"({', '.join(_SPEC_KEYS)}), got {type(spec).__name__} {spec!r}"
        )
    unknown = [k for k in spec if k not in _SPEC_KEYS]
    if unknown:
        raise SandboxError(
            f"{where}: unknown key{'s' if len(unknown) > 1 else ''} "
            f"{', '.join(repr(k) for k in unknown)}; allowed keys: {', '.join(_SPEC_KEYS)}"
        )

    base: Material | None = None
    if "preset" in spec:
        preset = spec["preset"]
        if not isinstance(preset, str):
            raise SandboxError(f"{where}: 'preset' must be a preset name, got {preset!r}")
        base = get_material(preset, where=where)

    name = spec.get("name")
    if name is not None and (not isinstance(name, str) or not name.strip()):
        raise SandboxError(f"{where}: 'name' must be a non-empty string, got {name!r}")

    values: dict[str, float] = {}
    for key in (*_NUMERIC_FIELDS, "bend_Nm"):
        if key in spec:
            values[key] = _check_number(spec[key], key, where)

    if "bend_Nm" in values:
        both = [k for k in _DIRECTIONAL_BEND if k in values]
        if both:
            raise SandboxError(
                f"{where}: give either 'bend_Nm' or {', '.join(repr(k) for k in both)}, not both"
            )
        b = values.pop("bend_Nm")
        values.update(dict.fromkeys(_DIRECTIONAL_BEND, b))

    if base is None:
        missing = [repr(k) for k in _NUMERIC_FIELDS if k not in values]
        if all(k not in values for k in _DIRECTIONAL_BEND):
            missing = [*missing[:-3], "'bend_Nm' (or the three 'bend_*_Nm')"]
        if missing:
            raise SandboxError(
                f"{where}: missing {', '.join(missing)} "
                "(or give 'preset' to start from a known material)"
            )
        return Material(
            name=name or "custom",
            source=f"user-defined in {where}",
            **values,
        )

    if not values:
        return base if name is None else dataclasses.replace(base, name=name)
    return dataclasses.replace(
        base,
        name=name or base.name,
        source=f"{base.source}; overridden in {where}: {', '.join(sorted(values))}",
        **values,
    )


def scale(material: Material, stretch: float = 1.0, bend: float = 1.0) -> Material:
    """A copy with the stretch and shear stiffnesses × ``stretch`` and B × ``bend``."""
    for key, f in (("stretch", stretch), ("bend", bend)):
        if not _is_number(f) or not math.isfinite(f) or f < 0:
            raise SandboxError(
                f"scale({material.name!r}): {key} must be finite and >= 0, got {f!r}"
            )
    return dataclasses.replace(
        material,
        stretch_u_N_m=material.stretch_u_N_m * stretch,
        stretch_v_N_m=material.stretch_v_N_m * stretch,
        shear_N_m=material.shear_N_m * stretch,
        bend_warp_Nm=material.bend_warp_Nm * bend,
        bend_weft_Nm=material.bend_weft_Nm * bend,
        bend_bias_Nm=material.bend_bias_Nm * bend,
        source=f"{material.source}; stretch x{stretch:g}, bend x{bend:g}",
    )


# --------------------------------------------------------------------------------------
# Documentation table


def materials_table_markdown() -> str:
    """The preset table of ``docs/fabrics.md`` (Markdown, ends with a newline)."""
    head = (
        "| preset | from | ρ_A (kg/m²) | E_u (N/m) | E_v (N/m) | E_s (N/m) "
        "| B_warp (µN·m) | B_weft (µN·m) | B_bias (µN·m) "
        "| c_warp (cm) | c_weft (cm) | c_bias (cm) |"
    )
    lines = [head, "|" + "---|" * 12]
    for name, m in _presets().items():
        origin = EVERYDAY_PRESETS[name][0] if name in EVERYDAY_PRESETS else "Wang 2011"
        c = [100.0 * x for x in m.bending_lengths_m()]
        lines.append(
            f"| {name} | {origin} | {m.density_kg_m2:.3f} | {m.stretch_u_N_m:.1f} "
            f"| {m.stretch_v_N_m:.1f} | {m.shear_N_m:.2f} "
            f"| {m.bend_warp_Nm * 1e6:.2f} | {m.bend_weft_Nm * 1e6:.2f} "
            f"| {m.bend_bias_Nm * 1e6:.2f} | {c[0]:.2f} | {c[1]:.2f} | {c[2]:.2f} |"
        )
    return "\n".join(lines) + "\n"


def replace_table(text: str, table: str) -> str:
    """``text`` with the part between TABLE_BEGIN and TABLE_END replaced by ``table``."""
    start = text.find(TABLE_BEGIN)
    end = text.find(TABLE_END)
    if start < 0 or end < start:
        raise SandboxError(f"no '{TABLE_BEGIN}' ... '{TABLE_END}' markers in the document")
    return text[: start + len(TABLE_BEGIN)] + "\n\n" + table + "\n" + text[end:]


def main(argv: list[str] | None = None) -> int:
    """Print the preset table, or rewrite it inside a document with ``--write-doc``."""
    parser = argparse.ArgumentParser(
        prog="python -m sandbox.sim.materials", description=main.__doc__
    )
    parser.add_argument("--write-doc", metavar="PATH", help="e.g. docs/fabrics.md")
    args = parser.parse_args(argv)
    table = materials_table_markdown()
    if args.write_doc is None:
        sys.stdout.write(table)
        return 0
    from sandbox.atomic import write_text

    path = Path(args.write_doc)
    try:
        text = path.read_text(encoding="utf-8")
        new = replace_table(text, table)
    except (OSError, SandboxError) as exc:
        print(f"{path}: {exc}", file=sys.stderr)
        return 2
    write_text(path, new)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
