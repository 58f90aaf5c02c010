"""Small scene builders shared by the tests."""

from sandbox.scene.spec import scene_from_dict


def sheet_scene(**over):
    """A small hanging sheet as a scene dict; keyword arguments override top-level tables."""
    data = {
        "scene": {"name": "test_sheet"},
        "simulation": {"dt_s": "auto", "frame_rate_hz": 30, "damping_per_s": 2.0},
        "stop": {"time_limit_s": 2.0},
        "cloth": [
            {
                "name": "sheet",
                "shape": "rectangle",
                "size_m": [0.2, 0.2],
                "edge_length_m": 0.02,
                "material": "jersey",
                "origin_m": [-0.1, 0.3, 0.0],
                "rotation_deg": [-20.0, 0.0, 0.0],
                "pins": [{"side": "top"}],
            }
        ],
    }
    for key, value in over.items():
        if key == "cloth":
            data["cloth"][0].update(value)
        else:
            data.setdefault(key, {}).update(value)
    return data


def sheet_spec(**over):
    return scene_from_dict(sheet_scene(**over), source="test.toml")


SMALL_SHEET_TOML = """
[scene]
name = "small_sheet"
[stop]
time_limit_s = 0.1
[[cloth]]
name = "sheet"
size_m = [0.2, 0.2]
edge_length_m = 0.05
material = {material}
pins = [{pins}]
{cloth_extra}
{after}
"""


def small_sheet_toml(material='"denim"', pins='{ corners = "top" }', cloth_extra="",
                     after="") -> str:  # fmt: skip
    """A 20 cm sheet pinned at its top corners for 0.1 s, as scene-file text: ``material``,
    ``pins`` and ``cloth_extra`` (more keys) go into its cloth table, ``after`` (more
    tables: colliders, seams) follows it."""
    return SMALL_SHEET_TOML.format(material=material, pins=pins, cloth_extra=cloth_extra,
                                   after=after)  # fmt: skip
