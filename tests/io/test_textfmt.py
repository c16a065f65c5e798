"""The array formatter writes exactly what %-formatting writes."""

import numpy as np
import pytest

from aldpat.io.table import PointTable
from aldpat.io.text import format_rows
from aldpat.io.textfmt import format_block


@pytest.mark.parametrize("decimals", [0, 1, 2, 3, 6])
def test_same_text_as_percent_formatting(decimals):
    rng = np.random.default_rng(decimals)
    n = 5000
    values = np.round(rng.uniform(-1e6, 1e7, n), decimals)
    values[:13] = [0, -0.5, 0.5, 9.999, 10, 99, 100, 999999, 1000000, -1, 0.001, -0.01, -0.0]
    values[:13] = np.round(values[:13], decimals)
    table = PointTable({"x": values, "y": np.round(rng.uniform(0, 1, n), decimals),
                        "z": np.round(rng.normal(0, 50, n), decimals),
                        "intensity": rng.integers(0, 70000, n).astype(float)})
    names = ("x", "y", "z", "intensity")
    dec = {"x": decimals, "y": decimals, "z": decimals}
    for delim in (" ", ","):
        expected = format_rows(table, names, delim, dec)
        got = format_block(table, names, delim, dec).tobytes().decode()
        assert got == expected


def test_powers_of_ten_and_integers():
    v = np.array([9.0, 10.0, 99.0, 100.0, 999.0, 1000.0, 1e15, 123456789012.0])
    t = PointTable({"x": v, "intensity": v})
    assert format_block(t, ("x", "intensity"), " ", {"x": 2}).tobytes().decode() == \
        format_rows(t, ("x", "intensity"), " ", {"x": 2})


@pytest.mark.parametrize("value, places", [
    (0.01, 2), (0.025, 3), (0.0025, 4), (1e-7, 7), (0.5, 1), (500000.0, 0), (512000.123, 3),
    (5403000.456, 3), (0.1 + 0.2, 1), (-81.0, 0), (300.789, 3), (26.12345678, 8), (0.0, 0),
])
def test_decimal_places_are_the_fewest_that_write_a_value_exactly(value, places):
    from aldpat.io.textfmt import decimal_places

    assert decimal_places(value) == places
    assert float(f"{value:.{places}f}") == pytest.approx(value, rel=1e-15, abs=1e-15)
