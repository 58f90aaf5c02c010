"""Plausibility of scene files and fabrics: valid values that are almost surely a mistake.

A value outside the bands of :class:`PlausibleRanges` is accepted (it is valid) but earns
one warning (``logging``, logger ``sandbox.scene``, printed by the CLI as
``WARNING sandbox.scene: ...``) that says what is odd, the value, the usual range and the
likely cause: most often a unit (centimetres as metres, g/m² as kg/m², µN·m as N·m).
``load_scene`` runs these checks on every scene file, before any mesh is built or Taichi
starts; ``drape`` and ``gui`` check a pattern file's fabric the same way (logger
``sandbox.pattern``). The bands lie a decade or more beyond the fabric presets
(``python -m sandbox fabrics``) and every packaged scene passes them.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, fields

import numpy as np

log = logging.getLogger("sandbox.scene")


@dataclass(frozen=True)
class PlausibleRanges:
    """Bands outside which a scene value earns a warning (SI units). Each ``min_``/``max_``
    pair is a closed band; a value of 0 where 0 switches something off (bending, gravity)
    is not warned about."""

    max_speed_m_s: float = 20.0
    """Fastest initial speed of a cloth [m/s]: cloth dropped from 2 m lands at 6 m/s, a
    flicked sheet moves at a few m/s."""
    min_piece_extent_m: float = 0.01
    """Smallest width or height of a piece [m]: the library's smallest panel is 3.5 cm."""
    max_piece_extent_m: float = 4.0
    """Largest width or height of a piece [m]: the library's largest panel is 1.1 m, the
    largest packaged sheet 1 m (pattern files refuse panels over 4 m)."""
    min_edges_across: float = 2.0
    """Fewest mesh edges across a piece's largest extent (``edge_length_m`` at most half
    of it); fewer leaves a mesh of a handful of triangles."""
    max_position_m: float = 20.0
    """Farthest a cloth's ``origin_m`` or a collider's centre may lie from the world's
    origin [m]."""
    min_density_kg_m2: float = 0.01
    """Lightest areal density [kg/m²]: a decade under the lightest preset (silk, 0.113);
    nets and tulle weigh 0.01-0.02, woven fabrics 0.05-0.6."""
    max_density_kg_m2: float = 2.0
    """Heaviest areal density [kg/m²]: six times the heaviest preset (denim, 0.324); heavy
    canvas and leather weigh up to about 1.5."""
    min_stretch_N_m: float = 0.5
    """Softest stretch or shear stiffness E_u, E_v, E_s [N/m]: a decade under the softest
    preset (6.5 N/m, the sweater's weft; shear 7.2 N/m, silk)."""
    max_stretch_N_m: float = 5e4
    """Stiffest stretch or shear stiffness [N/m]: a decade over the stiffest preset
    (4,070 N/m, cotton)."""
    min_bend_Nm: float = 1e-7
    """Softest non-zero bending rigidity B [N·m]: 36 times under the softest preset
    (3.6e-6 N·m, jersey's warp)."""
    max_bend_Nm: float = 1e-3
    """Stiffest bending rigidity B [N·m]: 32 times the stiffest preset (3.1e-5 N·m,
    cotton)."""
    min_gravity_m_s2: float = 2.0
    """Weakest non-zero gravity [m/s²] (0 is a deliberate choice: no gravity)."""
    max_gravity_m_s2: float = 20.0
    """Strongest gravity [m/s²] (standard gravity is 9.80665)."""
    max_time_limit_s: float = 300.0
    """Longest simulated time limit [s]: packaged scenes settle within 20 s, drapes 8 s."""
    max_wall_limit_s: float = 7 * 86400.0
    """Longest wall-clock limit [s] (a week)."""
    min_frame_rate_hz: float = 1.0
    """Lowest frame rate [Hz]: the stop rule is measured over one frame."""
    max_frame_rate_hz: float = 1000.0
    """Highest frame rate [Hz]: over a frame this short the stop rule's 1.5 mm passes for
    cloth still moving at 1.5 m/s."""
    min_thickness_m: float = 1e-4
    """Thinnest contact thickness ``[collision] thickness_m`` [m] (0.1 mm)."""
    max_thickness_m: float = 0.02
    """Thickest contact thickness [m] (2 cm; the packaged scenes use 2-4 mm)."""
    min_collider_extent_m: float = 1e-3
    """Smallest size of a collider [m] (a sphere's diameter, a box's side, ...)."""
    max_collider_extent_m: float = 50.0
    """Largest size of a collider [m] (a floor plane is 10 m by default)."""

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, int | float) or not value > 0:
                raise ValueError(f"PlausibleRanges.{f.name} must be a positive number, "
                                 f"got {value!r}")  # fmt: skip
        for lo, hi in _PAIRS:
            if getattr(self, lo) >= getattr(self, hi):
                raise ValueError(f"PlausibleRanges.{lo} must be below {hi}")


_PAIRS = [("min_piece_extent_m", "max_piece_extent_m"),
          ("min_density_kg_m2", "max_density_kg_m2"), ("min_stretch_N_m", "max_stretch_N_m"),
          ("min_bend_Nm", "max_bend_Nm"), ("min_gravity_m_s2", "max_gravity_m_s2"),
          ("min_frame_rate_hz", "max_frame_rate_hz"), ("min_thickness_m", "max_thickness_m"),
          ("min_collider_extent_m", "max_collider_extent_m")]  # fmt: skip

PLAUSIBLE = PlausibleRanges()
"""The default bands."""

# Likely causes, tried in order: (factor, text, usual band of value × factor). The first
# whose converted value lands in the usual band is named; {v} is the value, {w} the
# converted value.
_LONG = [(1e-2, "centimetres given as metres ({v:g} cm = {w:g} m)", (0.01, 4.0)),
         (1e-3, "millimetres given as metres ({v:g} mm = {w:g} m)", (0.01, 4.0))]  # fmt: skip
_SHORT = [(1e2, "a length divided by 100 twice ({v:g} m for {w:g} m)", (0.01, 4.0))]
_THIN = [(1e-3, "millimetres given as metres ({v:g} mm = {w:g} m)", (1e-4, 0.02)),
         (1e-2, "centimetres given as metres ({v:g} cm = {w:g} m)", (1e-4, 0.02))]  # fmt: skip
_FAST = [(1e-2, "cm/s given as m/s ({v:g} cm/s = {w:g} m/s)", (0.0, 10.0)),
         (1e-3, "mm/s given as m/s ({v:g} mm/s = {w:g} m/s)", (0.0, 10.0))]  # fmt: skip
_HEAVY = [(1e-3, "g/m² given as kg/m² ({v:g} g/m² = {w:g} kg/m²)", (0.01, 2.0))]
_LIGHT = [(1e3, "a value divided by 1000 once too often ({w:g} kg/m² meant)", (0.01, 2.0))]
_STIFF = [(None, "a Young's modulus in Pa (N/m²) rather than a stiffness per width in N/m "
          "(modulus × thickness: 1e8 Pa × 0.5 mm = 5e4 N/m)", None)]  # fmt: skip
_SOFT = [(1e3, "kN/m or N/mm given as N/m ({v:g} kN/m = {w:g} N/m)", (0.5, 5e4))]
_BENDY = [(1e-6, "µN·m (the unit of `python -m sandbox fabrics`) given as N·m "
           "({v:g} µN·m = {w:g} N·m)", (1e-6, 1e-4)),
          (1e-3, "N·mm given as N·m ({v:g} N·mm = {w:g} N·m)", (1e-6, 1e-4)),
          (9.80665e-5, "KES gf·cm²/cm given as N·m ({v:g} gf·cm²/cm = {w:.3g} N·m)",
           (1e-6, 1e-4))]  # fmt: skip
_LIMP = [(None, "a rigidity per hinge rather than per unit width, or meant as 0 (bending "
          "off)", None)]  # fmt: skip
_STRONG = [(1e-2, "cm/s² given as m/s² ({v:g} cm/s² = {w:g} m/s²)", (9.0, 10.5))]
_WEAK = [(9.80665, "multiples of g given as m/s² ({v:g} g = {w:.4g} m/s²)", (9.0, 10.5))]
_LONG_TIME = [(1e-3, "milliseconds given as seconds ({v:g} ms = {w:g} s)", (0.1, 60.0)),
              (None, "a wall-clock budget (that is [stop] wall_limit_s) given as simulated "
               "time", None)]  # fmt: skip
_LONG_WALL = [(1e-3, "milliseconds given as seconds ({v:g} ms = {w:g} s)", (1.0, 86400.0))]


def _cause(value: float, causes) -> str:
    for factor, text, band in causes:
        if factor is None:
            return f": likely {text}"
        w = value * factor
        if band[0] <= w <= band[1]:
            return f": likely {text.format(v=_round(value), w=_round(w))}"
    return ": check the unit"


def _round(x: float) -> float:
    """``x`` to four significant digits, for messages."""
    return float(f"{x:.4g}")


def _band(where: str, key: str, value: float, lo: float, hi: float, unit: str, usual: str,
          high, low) -> list[str]:  # fmt: skip
    """One message if ``value`` lies outside [lo, hi] (``high``/``low``: the likely causes)."""
    if lo <= value <= hi:
        return []
    side, bound, causes = ("above", hi, high) if value > hi else ("below", lo, low)
    return [
        f"{where}{key} = {value:g} {unit} is {side} {bound:g} {unit} ({usual})"
        f"{_cause(value, causes)}"
    ]


# ---------------------------------------------------------------------------- materials
def material_warnings(material, where: str, ranges: PlausibleRanges = PLAUSIBLE) -> list[str]:
    """Messages on a :class:`~sandbox.sim.materials.Material`'s odd constants; ``where``
    (e.g. ``"scene.toml: cloth[0].material"``) starts each."""
    r, m, at = ranges, material, f"{where}: "
    out = _band(at, "density_kg_m2", m.density_kg_m2, r.min_density_kg_m2,
                r.max_density_kg_m2, "kg/m²", "woven fabrics weigh 0.05-0.6 kg/m², the "
                "presets 0.11-0.32", _HEAVY, _LIGHT)  # fmt: skip
    for key in ("stretch_u_N_m", "stretch_v_N_m", "shear_N_m"):
        out += _band(at, key, getattr(m, key), r.min_stretch_N_m, r.max_stretch_N_m, "N/m",
                     "the presets span 6.5-4,070 N/m", _STIFF, _SOFT)  # fmt: skip
    bends = {k: getattr(m, k) for k in ("bend_warp_Nm", "bend_weft_Nm", "bend_bias_Nm")}
    if len(set(bends.values())) == 1:  # one value (bend_Nm): one message
        bends = {"bend_Nm": m.bend_warp_Nm}
    for key, value in bends.items():
        if value > 0:  # 0 switches bending off
            out += _band(at, key, value, r.min_bend_Nm, r.max_bend_Nm, "N·m", "the presets "
                         "span 3.6e-6-3.1e-5 N·m", _BENDY, _LIMP)  # fmt: skip
    return out


# ---------------------------------------------------------------------------- scenes
def scene_warnings(spec, ranges: PlausibleRanges = PLAUSIBLE) -> list[str]:
    """Messages on a checked :class:`~sandbox.scene.spec.SceneSpec`'s odd values, each
    starting with the file and the entry."""
    r, src = ranges, spec.source
    sim, stop = spec.simulation, spec.stop
    out: list[str] = []
    g = float(np.linalg.norm(sim.gravity_m_s2))
    if g > 0:
        out += _band(f"{src}: [simulation] ", "|gravity_m_s2|", g, r.min_gravity_m_s2,
                     r.max_gravity_m_s2, "m/s²", "standard gravity is 9.81 m/s²; 0 switches "
                     "it off", _STRONG, _WEAK)  # fmt: skip
    rate = sim.frame_rate_hz
    if rate < r.min_frame_rate_hz:
        out.append(f"{src}: [simulation] frame_rate_hz = {rate:g} Hz is below "
                   f"{r.min_frame_rate_hz:g} Hz (output is usually 24-60 Hz): likely a frame "
                   f"time in s given as a rate (1/{rate:g} s = {1 / rate:.3g} Hz)")  # fmt: skip
    elif rate > r.max_frame_rate_hz:
        speed = stop.max_displacement_m * rate
        out.append(f"{src}: [simulation] frame_rate_hz = {rate:g} Hz is above "
                   f"{r.max_frame_rate_hz:g} Hz (output is usually 24-60 Hz): the stop rule "
                   f"is measured over one frame, so its {stop.max_displacement_m:g} m passes "
                   f"for cloth moving at {speed:.3g} m/s")  # fmt: skip
    out += _band(f"{src}: [stop] ", "time_limit_s", stop.time_limit_s, 0.0, r.max_time_limit_s,
                 "s", "scenes settle in seconds of simulated time; the packaged ones within "
                 "20 s", _LONG_TIME, [])  # fmt: skip
    out += _band(f"{src}: [stop] ", "wall_limit_s", stop.wall_limit_s, 0.0, r.max_wall_limit_s,
                 "s", "the default is 3600 s", _LONG_WALL, [])  # fmt: skip
    if stop.min_time_s > stop.time_limit_s:
        out.append(f"{src}: [stop] min_time_s = {stop.min_time_s:g} s is past time_limit_s = "
                   f"{stop.time_limit_s:g} s: the stop rule never gets to hold, and the run "
                   f"always ends unconverged at the time limit")  # fmt: skip
    out += _band(f"{src}: [collision] ", "thickness_m", spec.collision.thickness_m,
                 r.min_thickness_m, r.max_thickness_m, "m", "the packaged scenes use "
                 "0.002-0.004 m", _THIN, [])  # fmt: skip
    for c in spec.cloths:
        out += _cloth_warnings(c, r)
    for c in spec.colliders:
        out += _collider_warnings(c, r)
    return out


def _cloth_warnings(c, r: PlausibleRanges) -> list[str]:
    at = f"{c.where}."
    out = []
    speed = float(np.linalg.norm(c.velocity_m_s))
    if speed > r.max_speed_m_s:
        out.append(f"{at}velocity_m_s = {list(c.velocity_m_s)}: a speed of {speed:g} m/s is "
                   f"above {r.max_speed_m_s:g} m/s (falling or flicked cloth moves at 0-10 "
                   f"m/s){_cause(speed, _FAST)}")  # fmt: skip
    pts = np.asarray(c.outline_m, float)
    extent = float(np.ptp(pts, axis=0).max())
    span = (f"the outline spans u {pts[:, 0].min():g}..{pts[:, 0].max():g} m, "
            f"v {pts[:, 1].min():g}..{pts[:, 1].max():g} m")  # fmt: skip
    if extent > r.max_piece_extent_m or extent < r.min_piece_extent_m:
        big = extent > r.max_piece_extent_m
        side, bound = ("above", r.max_piece_extent_m) if big else ("below", r.min_piece_extent_m)
        out.append(
            f"{c.where}: the piece is {extent:g} m across, {side} {bound:g} m ({span}; "
            f"garment panels are 0.03-1.5 m){_cause(extent, _LONG if big else _SHORT)}"
        )
    elif c.edge_length_m * r.min_edges_across > extent:
        out.append(
            f"{at}edge_length_m = {c.edge_length_m:g} m is more than "
            f"1/{r.min_edges_across:g} of the piece's {extent:g} m: the mesh has "
            f"hardly a vertex inside{_cause(c.edge_length_m, _edge_causes(extent))}"
        )
    out += _position(at, "origin_m", c.origin_m, r)
    return out + material_warnings(c.material, f"{c.where}.material", r)


def _edge_causes(extent: float):
    """Causes of an edge too long for its piece: the edge in cm (or mm) given as m."""
    usual = (extent / 200.0, extent / 2.0)
    return [(1e-2, "centimetres given as metres ({v:g} cm = {w:g} m)", usual),
            (1e-3, "millimetres given as metres ({v:g} mm = {w:g} m)", usual)]  # fmt: skip


def _position(at: str, key: str, point, r: PlausibleRanges) -> list[str]:
    d = float(np.linalg.norm(point))
    if d <= r.max_position_m:
        return []
    return [f"{at}{key} = {list(point)} is {d:.4g} m from the world's origin, farther than "
            f"{r.max_position_m:g} m (scenes fit in a few metres)"
            f"{_cause(d, [(f, t, (0.0, 4.0)) for f, t, _ in _LONG])}"]  # fmt: skip


def _collider_warnings(c, r: PlausibleRanges) -> list[str]:
    p, at = c.params, f"{c.where} "
    out = []
    for key in ("center_m", "point_m", "origin_m"):
        if key in p:
            out += _position(at, key, p[key], r)
    for key, what, extent in _collider_sizes(c):
        if extent > r.max_collider_extent_m or extent < r.min_collider_extent_m:
            big = extent > r.max_collider_extent_m
            bound = r.max_collider_extent_m if big else r.min_collider_extent_m
            if c.shape == "mesh":
                hint = _mesh_hint(extent, p["scale"]) if big else ": check its scale"
            else:
                hint = _cause(extent, _LONG if big else _SHORT)
            out.append(f"{at}{key}: the {c.shape}'s {what} is {extent:g} m, "
                       f"{'above' if big else 'below'} {bound:g} m (bodies and props are "
                       f"0.01-10 m){hint}")  # fmt: skip
    return out


def _collider_sizes(c) -> list[tuple[str, str, float]]:
    """(key, what, size [m]) of a collider: a sphere's or cylinder's diameter, a
    cylinder's height, a box's largest and smallest side, a plane's side, a mesh's largest
    bounding-box side after its scale (a mannequin's measurements are range-checked)."""
    p = c.params
    if c.shape in ("sphere", "cylinder"):
        sizes = [("radius_m", "diameter", 2.0 * p["radius_m"])]
        return sizes + ([("height_m", "height", p["height_m"])] if c.shape == "cylinder" else [])
    if c.shape == "box":
        return [("size_m", "largest side", max(p["size_m"])),
                ("size_m", "smallest side", min(p["size_m"]))]  # fmt: skip
    if c.shape == "plane":
        return [("size_m", "side", p["size_m"])]
    if c.shape == "mesh":
        return _mesh_extent(p)
    return []


def _mesh_extent(p) -> list[tuple[str, str, float]]:
    """A mesh collider's largest bounding-box side [m] after its scale (the file is read;
    a file that cannot be read is left to the build, which names the problem)."""
    from sandbox.errors import SandboxError
    from sandbox.render.meshio import read_mesh

    try:
        v, _ = read_mesh(p["path"])
    except SandboxError:
        return []
    if not len(v) or not np.all(np.isfinite(v)):
        return []
    return [("scale", "largest side", float(np.ptp(v, axis=0).max()) * p["scale"])]


def _mesh_hint(extent: float, scale: float) -> str:
    for factor, unit in ((1e-2, "centimetres"), (1e-3, "millimetres")):
        if 0.01 <= extent * factor <= 4.0:
            return f": likely a model in {unit} (try scale = {scale * factor:g})"
    return ": check its scale"


def warn_scene(spec, ranges: PlausibleRanges = PLAUSIBLE) -> list[str]:
    """Log each of :func:`scene_warnings`' messages as a warning (logger ``sandbox.scene``)
    and return them."""
    messages = scene_warnings(spec, ranges)
    for text in messages:
        log.warning("%s", text)
    return messages
