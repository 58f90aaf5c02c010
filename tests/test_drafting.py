"""Garment library (paper Fig. 7): every garment drafts for every database size, outlines
are simple and counter-clockwise, sewn edges match, girths = body + ease, panels face the
right way, the patterns load, the CLI writes them."""

from __future__ import annotations

import copy
import dataclasses
import json
from functools import cache

import numpy as np
import pytest

from sandbox.drafting import draft, garment_names, load_garment
from sandbox.drafting.cli import main as cli_main
from sandbox.drafting.garments import GARMENT_DIR
from sandbox.drafting.geometry import (
    edges_of,
    is_simple,
    length,
    outline_polyline,
    signed_area,
    width_at,
)
from sandbox.errors import SandboxError
from sandbox.mannequin.measurements import load_size_table, size_entry
from sandbox.pattern import spec

SIZES = [e.size for e in load_size_table()]
NAMES = garment_names()
SEAM_TOL = 0.005  # relative length difference of plain seams
CAP_EASE_MAX = 0.05  # sleeve caps may be longer than the armhole by at most this


@cache
def drafted(name: str, size: int) -> dict:
    return draft(name, size_entry(size).measurements)


def _seam_length(pattern: dict, side: list[dict]) -> float:
    return sum(length(edges_of(pattern["panels"][r["panel"]])[r["edge"]]) for r in side)


def test_library_matches_fig7():
    cats = [load_garment(n).category for n in NAMES]
    assert len(NAMES) == 14
    assert cats == ["sleeved top"] * 4 + ["sleeveless top"] * 5 + ["dress"] * 2 + ["skirt"] * 3
    files = sorted(p.stem for p in GARMENT_DIR.glob("*.json"))
    assert files == sorted(NAMES)
    for n in NAMES:
        data = json.loads((GARMENT_DIR / f"{n}.json").read_text())
        assert data["name"] == n


@pytest.mark.parametrize("name", NAMES)
def test_every_size_drafts_with_valid_outlines(name):
    cat = load_garment(name).category
    for size in SIZES:
        d = drafted(name, size)
        n_panels = len(d["panels"])
        assert 2 <= n_panels <= 4, (size, n_panels)
        if cat == "sleeved top":
            assert n_panels == 4
        for pn, p in d["panels"].items():
            poly = outline_polyline(p, 0.5)
            assert is_simple(poly), (size, pn)
            assert signed_area(poly) > 20.0, (size, pn)  # counter-clockwise, > 20 cm^2
            assert p["grain"] == [0.0, 1.0]


@pytest.mark.parametrize("name", NAMES)
def test_sewn_edges_have_matching_lengths(name):
    for size in SIZES:
        d = drafted(name, size)
        sewn = set()
        for s in d["seams"]:
            assert s["direction"] == "auto"
            la, lb = _seam_length(d, s["a"]), _seam_length(d, s["b"])
            for r in (*s["a"], *s["b"]):
                key = (r["panel"], r["edge"])
                assert key not in sewn
                sewn.add(key)
            if s["name"].startswith("sleeve"):  # cap (a) = armhole (b) x (1 + cap ease)
                assert lb * (1 - 1e-4) <= la <= lb * (1 + CAP_EASE_MAX), (size, s["name"], la, lb)
            else:
                assert abs(la - lb) <= SEAM_TOL * min(la, lb), (size, s["name"], la, lb)


@pytest.mark.parametrize("name", NAMES)
def test_multi_edge_seam_lines_are_continuous(name):
    """Each side of a seam is one line: same-panel edges follow each other head to tail,
    and an armhole line passes from the back to the front panel at the shoulder seam."""
    d = drafted(name, 12)
    for s in d["seams"]:
        for side in (s["a"], s["b"]):
            for r0, r1 in zip(side, side[1:], strict=False):
                e0 = edges_of(d["panels"][r0["panel"]])[r0["edge"]]
                e1 = edges_of(d["panels"][r1["panel"]])[r1["edge"]]
                if r0["panel"] == r1["panel"]:
                    assert np.allclose(e0["p1"], e1["p0"]), (s["name"], r0, r1)
                else:  # armhole: e0 ends and e1 starts at the shoulder seam's outer end
                    sh0 = r0["edge"].replace("armhole", "shoulder")
                    sh1 = r1["edge"].replace("armhole", "shoulder")
                    s0 = edges_of(d["panels"][r0["panel"]])[sh0]
                    s1 = edges_of(d["panels"][r1["panel"]])[sh1]
                    assert any(np.allclose(e0["p1"], q) for q in (s0["p0"], s0["p1"]))
                    assert any(np.allclose(e1["p0"], q) for q in (s1["p0"], s1["p1"]))


@pytest.mark.parametrize("name", NAMES)
def test_girths_are_body_plus_ease(name):
    g = load_garment(name)
    ease = g.params["ease_cm"]
    checked = 0
    for size in SIZES:
        m = size_entry(size).measurements
        body = {"bust": m.bust_girth, "waist": m.waist_girth, "hip": m.hip_girth}
        d = drafted(name, size)
        for key, gi in d["meta"]["girths_cm"].items():
            if key == "biceps":
                continue
            assert gi["garment"] == pytest.approx(body[key] + ease[key], abs=1e-6)
            total = 0.0
            for p in d["panels"].values():
                meta = p.get("meta", {})
                if key in meta.get("girth_levels", {}):
                    total += width_at(outline_polyline(p, 0.2), meta["girth_levels"][key])
                for en in meta.get("girth_edges", {}).get(key, []):
                    total += length(edges_of(p)[en])
            assert total == pytest.approx(body[key] + ease[key], abs=1.0), (size, key, total)
            checked += 1
    assert checked >= len(SIZES)  # at least one girth per size for every garment


@pytest.mark.parametrize("name", ["t-shirt", "long-sleeve-shirt", "blouse"])
def test_cap_top_meets_the_shoulder_seam(name):
    """Parametric matching of the merged cap line: the cap top is at the same fraction of
    the cap line as the shoulder point of the armhole line (front and back eased alike)."""
    for size in (SIZES[0], 12, SIZES[-1]):
        d = drafted(name, size)
        for s in ("left", "right"):
            sl = edges_of(d["panels"][f"sleeve_{s}"])
            cf, cb = length(sl["cap_front"]), length(sl["cap_back"])
            af = length(edges_of(d["panels"]["front"])[f"armhole_{s}"])
            ab = length(edges_of(d["panels"]["back"])[f"armhole_{s}"])
            assert cf / (cf + cb) == pytest.approx(af / (af + ab), abs=1e-4)


@pytest.mark.parametrize("name", ["t-shirt", "long-sleeve-shirt", "raglan-top", "blouse"])
def test_sleeve_biceps_is_top_arm_plus_ease(name):
    from sandbox.drafting.body import body_dims

    ease = load_garment(name).params["sleeve"]["bicep_ease_cm"]
    for size in SIZES:
        top_arm = body_dims(size_entry(size).measurements).top_arm
        for s in ("left", "right"):
            p = drafted(name, size)["panels"][f"sleeve_{s}"]
            w = width_at(outline_polyline(p, 0.2), -0.01)  # biceps line: y = 0
            assert w == pytest.approx(top_arm + ease, abs=0.2), (size, s)


def test_girths_follow_ease_and_measurements():
    g = load_garment("sheath-dress")
    params = copy.deepcopy(g.params)
    params["ease_cm"]["bust"] += 4.0
    looser = dataclasses.replace(g, params=params)
    m = size_entry(12).measurements
    bigger = m.replace(bust_girth=95.0)

    def bust(d):
        return sum(width_at(outline_polyline(d["panels"][pn], 0.2),
                            d["panels"][pn]["meta"]["girth_levels"]["bust"])
                   for pn in ("front", "back"))  # fmt: skip

    base = bust(draft(g, m))
    assert bust(draft(looser, m)) - base == pytest.approx(4.0, abs=0.1)
    assert bust(draft(g, bigger)) - base == pytest.approx(7.0, abs=0.1)


@pytest.mark.parametrize("fullness", [0.5, 0.75, 1.0])
def test_circle_skirt_fullness_keeps_the_waist_and_widens_the_hem(fullness):
    """The circle skirt's ``fullness``: the four waist arcs still make waist + ease, and the
    hem is a fraction ``fullness`` of a full circle of radius (waist radius + length)."""
    g = load_garment("circle-skirt")
    params = copy.deepcopy(g.params)
    params["fullness"] = fullness
    m = size_entry(12).measurements
    d = draft(dataclasses.replace(g, params=params), m)
    waist = sum(length(edges_of(p)["waist"]) for p in d["panels"].values())
    hem = sum(length(edges_of(p)["hem"]) for p in d["panels"].values())
    assert waist == pytest.approx(m.waist_girth + params["ease_cm"]["waist"], abs=0.2)
    r = waist / (2 * np.pi * fullness)
    side = length(edges_of(d["panels"]["front"])["to_left"])  # the skirt's length
    assert hem == pytest.approx(2 * np.pi * fullness * (r + side), rel=0.01)
    params["fullness"] = 1.5
    with pytest.raises(SandboxError, match="fullness 1.5"):
        draft(dataclasses.replace(g, params=params), m)


@pytest.mark.parametrize("name", NAMES)
def test_panels_face_the_right_way_and_are_placed(name):
    """Front x -> body's left, back x -> body's right, right sleeve x -> front; anchors at
    the documented landmarks."""
    d = drafted(name, 12)
    for pn, p in d["panels"].items():
        pl = p["placement"]
        es = edges_of(p)

        def mean_x(part, es=es):
            xs = [np.r_[e["p0"][0], e["p1"][0]].mean() for n, e in es.items() if part in n]
            return float(np.mean(xs))

        if pn == "front":
            assert (pl["body"], pl["side"]) == ("torso", "front")
            assert pl["landmark"] in ("front_neck_point", "waist_front")
            if any("_left" in n for n in es):
                assert mean_x("_left") > 0 > mean_x("_right")
        elif pn in ("back", "neckband"):
            assert (pl["body"], pl["side"]) == ("torso", "back")
            assert pl["landmark"] in ("back_neck_point", "waist_back")
            if any("_left" in n for n in es):
                assert mean_x("_left") < 0 < mean_x("_right")
        elif pn.startswith("sleeve_"):
            s = pn.removeprefix("sleeve_")
            assert pl == {**pl, "body": f"arm_{s}", "side": "outer",
                          "landmark": f"shoulder_point_{s}"}  # fmt: skip
            front = mean_x("_front")
            assert front > 0 if s == "right" else front < 0
        else:  # circle-skirt side gores
            assert pl["side"] == pn and pn in ("left", "right")
        assert pl["wrap"] is True
        # the anchor is on the centre line, inside the panel's height range
        ys = np.asarray(p["vertices"])[:, 1]
        assert pl["anchor"][0] == 0.0
        assert ys.min() - 1e-9 <= pl["anchor"][1] <= ys.max() + 1e-9


def test_every_pattern_loads():
    for name in NAMES:
        for size in (SIZES[0], 12, SIZES[-1]):
            pat = spec.load_pattern(drafted(name, size), where=f"{name} size {size}")
            assert len(pat.panels) == len(drafted(name, size)["panels"])
            assert pat.units_to_m == 0.01
            for p in pat.panels.values():
                for lm in [p.placement["landmark"]]:
                    assert lm in spec.LANDMARKS


def test_mannequin_landmarks_give_the_heights():
    from sandbox.drafting.body import body_dims
    from sandbox.mannequin import build_mannequin

    man = build_mannequin(size=12)
    m = man.measurements_requested
    a, b = body_dims(m), body_dims(m, man)
    assert b.source == "mannequin landmarks"
    for key in ("armscye_depth", "waist_to_hip", "neck_half_width", "shoulder_slope_deg"):
        assert getattr(b, key) == pytest.approx(getattr(a, key), rel=0.1), key
    lm = man.landmarks
    assert b.waist_to_hip == pytest.approx(100 * (lm["waist_front"][1] - lm["hip_front"][1]))
    for name in ("t-shirt", "camisole", "pencil-skirt"):
        d = draft(name, m, mannequin=man)
        spec.load_pattern(d)
        for p in d["panels"].values():
            assert p["placement"]["landmark"] in lm


def test_bad_garment_definitions_are_reported():
    with pytest.raises(SandboxError, match="no file"):
        load_garment("no-such-garment")
    g = load_garment("t-shirt")
    bad = dataclasses.replace(g, params={**g.params, "hem": {"level": "ankle"}})
    with pytest.raises(SandboxError, match="hem level 'ankle'"):
        draft(bad, size_entry(12).measurements)


def test_cli_lists_and_writes(tmp_path, capsys):
    assert cli_main(["--list"]) == 0
    assert capsys.readouterr().out.split() == NAMES
    out = tmp_path / "p" / "skirt.json"
    assert cli_main(["a-line-skirt", "--size", "14", "--waist", "80", "--out", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["format"] == "sandbox-pattern/1"
    assert data["meta"]["measurements_cm"]["waist_girth"] == 80.0
    assert data["meta"]["girths_cm"]["waist"]["garment"] == 81.0
    assert cli_main(["a-line-skirt", "--bust", "300", "--out", str(out)]) == 2
    assert "outside the supported" in capsys.readouterr().err


def test_draft_rules_neck_ease_widens_the_neck_only():
    """DraftRules: 1 cm more neck ease moves the side neck points (and the shoulder points
    with them) 1 cm out on each side of the T-shirt front; the hem and the side seams stay."""
    from sandbox.drafting.blocks import BLOCKS
    from sandbox.drafting.body import body_dims
    from sandbox.drafting.torso import DraftRules

    g = load_garment("t-shirt")
    b = body_dims(size_entry(12).measurements)
    base = np.array(BLOCKS[g.block](g.params, b).panels["front"]["vertices"])
    wider = BLOCKS[g.block](g.params, b, DraftRules(neck_ease_cm=1.5)).panels["front"]
    shift = np.array(wider["vertices"]) - base
    names = [e["name"] for e in wider["edges"]]
    neck = [names.index("shoulder_left"), names.index("neckline_left")]
    assert np.allclose(shift[:, 1], 0.0, atol=1e-9)
    assert np.allclose(shift[neck, 0], 1.0, atol=1e-9)  # and the mirror images 1 cm to -x:
    assert np.sum(np.abs(shift[:, 0]) > 1e-9) == 4 and np.allclose(np.sort(shift[:, 0])[:2], -1.0)
