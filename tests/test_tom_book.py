"""Unit tests of the TOM-IMM chapter's private presentation helpers."""

import math

import pytest

from trackcore.scenarios._tom_book import below_or_sci, tom_discretization_errors


def test_discretization_errors_small():
    for phi, T, sf, ss in [(0.3, 1.0, 1.0, 3.0), (math.pi / 2, 2.0, 1.0, 1.0)]:
        e_phi, e_d, e_c = tom_discretization_errors(phi, T, sf, ss)
        assert e_phi <= 1e-12, f"transition differs from expm by {e_phi}"
        assert e_d <= 1e-9, f"DWNA noise differs by {e_d}"
        assert e_c <= 1e-9, f"CWNA noise differs by {e_c}"


def test_discretization_errors_bad_input():
    with pytest.raises(ValueError, match="T"):
        tom_discretization_errors(0.3, 0.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="sf"):
        tom_discretization_errors(0.3, 1.0, -1.0, 1.0)


def test_below_or_sci():
    assert below_or_sci(1e-13, "1e-12") == "< 1e-12", "below the floor"
    assert below_or_sci(2.5e-8, "1e-9") == "2.5e-08", "above the floor"
