"""Contact rows of the stability matrix: cloth on sharp edges, rims and corners, piled on a
floor, and dragged over an edge.

Each scene runs through the guard at the integrator's automatic dt (symplectic Euler: 0.9 ×
the stability estimate; implicit Euler: 1/60 s) in three fabrics: ``cotton``, ``denim``
with stretch and shear ×10, and ``silk``. The outcome is the stability matrix's (stable /
guarded / failed / wall limit, :mod:`sandbox.validate.stability`). The scenes:

- **box edge**: a 20 cm sheet lying on a box, half of it beyond the box's top edge;
- **cylinder rim**: a 20 cm disc, its centre (6 × 6 cm) pinned, on a cylinder of radius
  6 cm (the set-up of the Cusick drape test, scaled down);
- **box corner**: a 20 cm sheet centred over a box's top corner, three quarters hanging;
- **pile on a floor**: a 10 × 60 cm strip hanging 1 cm above a floor, released, with
  self-collision: it folds onto itself;
- **dragged over an edge**: a 20 cm sheet on a box top thrown at 2 m/s towards its edge.
"""

from __future__ import annotations

import math

from sandbox.validate.cases import INTEGRATORS, scaled_material
from sandbox.validate.stability import Cell, _build, _run, _sheet, _spec

FABRICS = [("cotton", 1.0), ("denim", 10.0), ("silk", 1.0)]
"""(preset, stretch and shear factor) of each contact row."""
THICKNESS_M = 0.002


def _flat(name: str, integrator: str, time_s: float, cloth: dict, collider: list,
          self_collision: bool = False) -> dict:  # fmt: skip
    """A scene dict: one horizontal piece (pattern plane onto y = const) and colliders."""
    cloth = {"rotation_deg": [-90.0, 0.0, 0.0], "pins": [], "edge_length_m": 0.015, **cloth}
    data = _sheet(
        name,
        integrator,
        time_s,
        cloth=cloth,
        collider=collider,  # fmt: skip
        collision={"thickness_m": THICKNESS_M, "self_collision": self_collision},
    )
    if "outline_m" in cloth:
        del data["cloth"][0]["size_m"]
    return data


def _box(center, size) -> dict:
    return {"name": "box", "shape": "box", "center_m": list(center), "size_m": list(size)}


def box_edge(integrator: str, time_s: float) -> dict:
    return _flat("box edge", integrator, time_s,
                 {"origin_m": [-0.1, THICKNESS_M, 0.1]},
                 [_box([-0.1, -0.05, 0.0], [0.2, 0.1, 0.3])])  # fmt: skip


def cylinder_rim(integrator: str, time_s: float) -> dict:
    r, n = 0.1, 36
    outline = [[r + r * math.cos(2 * math.pi * k / n), r + r * math.sin(2 * math.pi * k / n)]
               for k in range(n)]  # fmt: skip
    return _flat("cylinder rim", integrator, time_s,
                 {"shape": "polygon", "outline_m": outline, "origin_m": [-r, THICKNESS_M, r],
                  "pins": [{"region_m": [[r - 0.03, r - 0.03], [r + 0.03, r + 0.03]]}]},
                 [{"name": "support", "shape": "cylinder", "center_m": [0.0, -0.05, 0.0],
                   "radius_m": 0.06, "height_m": 0.1}])  # fmt: skip


def box_corner(integrator: str, time_s: float) -> dict:
    return _flat("box corner", integrator, time_s,
                 {"origin_m": [-0.1, THICKNESS_M, 0.1]},
                 [_box([-0.1, -0.05, -0.1], [0.2, 0.1, 0.2])])  # fmt: skip


def floor_pile(integrator: str, time_s: float) -> dict:
    return _flat("pile on a floor", integrator, time_s,
                 {"size_m": [0.1, 0.6], "origin_m": [-0.05, 0.01, 0.0],
                  "rotation_deg": [0.0, 0.0, 0.0]},
                 [{"name": "floor", "shape": "plane", "point_m": [0.0, 0.0, 0.0],
                   "normal": [0.0, 1.0, 0.0], "size_m": 2.0}],
                 self_collision=True)  # fmt: skip


def dragged_over_edge(integrator: str, time_s: float) -> dict:
    return _flat("dragged over an edge", integrator, time_s,
                 {"origin_m": [-0.25, THICKNESS_M, 0.1], "velocity_m_s": [2.0, 0.0, 0.0]},
                 [_box([-0.15, -0.05, 0.0], [0.3, 0.1, 0.3])])  # fmt: skip


SCENES = [box_edge, cylinder_rim, box_corner, floor_pile, dragged_over_edge]


def contact_matrix(integrators, time_s: float, wall: float, *, scenes=None, fabrics=None,
                   on_cell=None) -> list[Cell]:  # fmt: skip
    """Every contact scene (``scenes``: their names, default all) × fabric (default
    :data:`FABRICS`) × integrator at the automatic dt, through the guard."""
    cells = []
    chosen = [m for m in SCENES if scenes is None or m(INTEGRATORS[0], 0.1)["scene"]["name"]
              in scenes]  # fmt: skip
    for make in chosen:
        for preset, factor in fabrics or FABRICS:
            for integ in integrators:
                spec = _spec(make(integ, time_s))
                spec.cloths[0].material = scaled_material(preset, factor)
                scene = _build(spec)
                c = _run(scene, f"{spec.name} ({preset} x{factor:g})", wall)
                cells.append(c)
                if on_cell:
                    on_cell(c)
    return cells
