"""Does a pattern close around the body? (sandbox.garment.fit, before any mesh is built)."""

import logging
from pathlib import Path

import numpy as np
import pytest

from sandbox.drafting.garments import garment_names
from sandbox.errors import SandboxError
from sandbox.garment.fit import FitConfig, _chord, check_fit, pattern_fit
from sandbox.garment.inputs import make_mannequin, material_for, resolve_pattern

GC = Path(__file__).parent / "data" / "garmentcode"


def test_the_cut_through_an_outline_is_its_width_inside():
    square = np.array([[0, 0], [2, 0], [2, 1], [0, 1]], float)
    assert _chord(square, np.array([0.0, 1.0]), 0.5) == pytest.approx(2.0)
    assert _chord(square, np.array([0.0, 1.0]), 1.5) == 0.0
    u = np.array([[0, 0], [3, 0], [3, 2], [2, 2], [2, 1], [1, 1], [1, 2], [0, 2]], float)
    assert _chord(u, np.array([0.0, 2.0]), 3.0) == pytest.approx(2.0)  # two prongs, a = 2


def test_every_library_garment_fits_the_body_it_was_drafted_for():
    body = make_mannequin(12)
    for name in garment_names():
        pattern = resolve_pattern(name, body)
        levels = check_fit(pattern, body, material_for(pattern))
        assert all(f.fits for f in levels), name
        assert any(f.judged for f in levels), name


def test_a_skirt_for_size_6_is_refused_on_size_26_naming_the_girths():
    small, large = make_mannequin(6), make_mannequin(26)
    pattern = resolve_pattern("pencil-skirt", small)
    with pytest.raises(SandboxError) as err:
        check_fit(pattern, large, material_for(pattern))
    text = str(err.value)
    assert "does not fit this body: at the hip" in text and "the body is 127.0 cm" in text
    assert "--no-fit-check" in text and "\n" not in text
    levels = check_fit(pattern, large, material_for(pattern), FitConfig(enabled=False))
    assert [f.name for f in levels if not f.fits] == ["hip"]  # the waist: at the skirt's top


def test_garmentcode_examples_are_not_refused_on_their_body(caplog):
    from sandbox.pattern.garmentcode import load_garmentcode
    from sandbox.pattern.garmentcode_body import load_garmentcode_body

    b = load_garmentcode_body(GC / "bodies" / "mean_all.yaml")
    body = make_mannequin(b.size, b.measurements)
    with caplog.at_level(logging.WARNING, logger="sandbox.garment"):
        for spec in sorted(GC.glob("*_specification.json")):
            pattern = load_garmentcode(spec)
            levels = check_fit(pattern, body, material_for(pattern))
            assert any(f.judged for f in levels), spec.name
    mine = [r for r in caplog.records if r.name == "sandbox.garment"]
    assert all("may not fit" in r.getMessage() for r in mine)


def test_a_halter_top_is_not_judged_at_the_bust():
    body = make_mannequin(12)
    pattern = resolve_pattern("halter-top", body)
    bust = next(f for f in pattern_fit(pattern, body, material_for(pattern)) if f.name == "bust")
    assert not bust.judged  # one front panel: it does not go round the body there
