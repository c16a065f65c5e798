"""One point per aligned cell: lowest, median, centre -- hand-computed cases."""

import numpy as np
import pytest

from aldpat.core.cells import cell_of, select_per_cell


def test_cells_are_aligned_to_whole_multiples_of_the_cell_size():
    i, j = cell_of(np.array([0.0, 1.99, 2.0, -0.01, 10.5]), np.array([0.0, 0.5, 2.9, -3.0, 7.0]), 2.0, 3.0)
    assert i.tolist() == [0, 0, 1, -1, 5]
    assert j.tolist() == [0, 0, 0, -1, 2]


def test_origin_moves_the_grid():
    i, j = cell_of(np.array([0.5, 1.5]), np.array([0.5, 1.5]), 1.0, 1.0, origin=(0.5, 0.5))
    assert i.tolist() == [0, 1] and j.tolist() == [0, 1]


# one 2 x 2 m cell holding five points, and a second cell with one point
X = np.array([0.1, 1.0, 1.9, 0.9, 1.2, 5.0])
Y = np.array([0.1, 1.0, 1.9, 1.2, 0.3, 5.0])
Z = np.array([10.0, 12.0, 11.0, 14.0, 13.0, 7.0])


@pytest.mark.parametrize("method, expected", [
    ("lowest", [0, 5]),   # z 10 is the lowest of the first cell
    ("median", [1, 5]),   # z sorted 10 11 12 13 14: the median 12 is point 1
    ("center", [1, 5]),   # (1.0, 1.0) is the centre of cell (0, 0)
])
def test_select_per_cell(method, expected):
    assert select_per_cell(X, Y, Z, 2.0, 2.0, method=method).tolist() == expected


def test_median_of_an_even_count_is_the_lower_middle_point():
    x = np.array([0.1, 0.2, 0.3, 0.4])
    z = np.array([4.0, 1.0, 3.0, 2.0])
    # sorted z: 1 (idx 1), 2 (idx 3), 3 (idx 2), 4 (idx 0): lower middle is z = 2
    assert select_per_cell(x, x, z, 1.0, 1.0, method="median").tolist() == [3]


def test_ties_go_to_the_earlier_point():
    x = np.array([0.5, 0.5, 0.2])
    z = np.array([1.0, 1.0, 1.0])
    assert select_per_cell(x, x, z, 1.0, 1.0, method="lowest").tolist() == [0]
    assert select_per_cell(x, x, z, 1.0, 1.0, method="center").tolist() == [0]


def test_every_occupied_cell_keeps_exactly_one_point():
    rng = np.random.default_rng(1)
    x, y, z = rng.uniform(0, 50, 5000), rng.uniform(0, 30, 5000), rng.normal(size=5000)
    for method in ("lowest", "median", "center"):
        keep = select_per_cell(x, y, z, 2.5, 1.5, method=method)
        i, j = cell_of(x, y, 2.5, 1.5)
        cells = set(zip(i.tolist(), j.tolist(), strict=False))
        assert len(keep) == len(cells)
        assert set(zip(i[keep].tolist(), j[keep].tolist(), strict=False)) == cells
        if method == "lowest":
            lowest = {}
            for k in range(len(x)):
                c = (i[k], j[k])
                lowest[c] = min(lowest.get(c, np.inf), z[k])
            assert sorted(z[keep].tolist()) == sorted(lowest.values())


def test_unknown_method_is_refused():
    with pytest.raises(ValueError, match="unknown method"):
        select_per_cell(X, Y, Z, 1.0, 1.0, method="highest")


def test_cells_too_small_to_tell_apart_are_refused_not_wrapped():
    """At 1e-15 m cells a UTM easting is 5e20 cells from the origin, past int64: the columns
    wrapped to one value and every point fell into one cell."""
    from aldpat.errors import DataError

    x = np.array([500000.0, 500001.0])
    with pytest.raises(DataError, match=r"5e\+20 cells of 1e-15 m from the origin in x.*use a larger cell"):
        cell_of(x, x, 1e-15, 1.0)
    with pytest.raises(DataError, match="in y"):
        cell_of(x, np.array([np.nan, 0.0]), 1.0, 1.0)
    i, _ = cell_of(x, x, 1e-6, 1e-6)  # small, but cells still apart
    assert i.tolist() == [500000000000, 500001000000]
