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
