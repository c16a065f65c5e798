"""Tile layout (manual task 7): exactly one core per point, buffers on every side."""

import numpy as np
import pytest

from aldpat.core.tiles import TileLayout


def members(layout, x, y):
    out = {}
    for ti, tj, rows in layout.memberships(x, y):
        for a, b, k in zip(ti.tolist(), tj.tolist(), rows.tolist()):
            assert (a, b) not in out.setdefault(k, set()), "a (point, tile) pair listed twice"
            out[k].add((a, b))
    return out


def test_xy_layout_cores_and_buffers_by_hand():
    layout = TileLayout.build((0, 0, 200, 100), 100, 100, 10, "xy")
    assert (layout.nx, layout.ny) == (2, 1)
    assert layout.core(1, 0) == (100.0, 200.0, 0.0, 100.0)
    x = np.array([50.0, 95.0, 105.0, 200.0, 0.0, -5.0, 215.0])
    y = np.array([50.0, 50.0, 50.0, 100.0, 0.0, 50.0, 50.0])
    ci, _cj = layout.core_index(x, y)
    assert ci.tolist() == [0, 0, 1, 1, 0, -1, -1]
    got = members(layout, x, y)
    assert got[0] == {(0, 0)}
    assert got[1] == {(0, 0), (1, 0)}  # 5 m from the edge: in the neighbour's buffer
    assert got[2] == {(0, 0), (1, 0)}
    assert got[3] == {(1, 0)}  # the upper right corner belongs to the last tile
    assert got[5] == {(0, 0)}  # outside the bounds but inside the first tile's buffer
    assert 6 not in got  # beyond every buffer


@pytest.mark.parametrize("direction", ["xy", "x", "y"])
@pytest.mark.parametrize("buffer", [0.0, 7.5, 130.0])
def test_every_point_in_exactly_one_core_and_in_the_buffers_it_falls_in(direction, buffer):
    rng = np.random.default_rng(3)
    x, y = rng.uniform(1000, 1450, 4000), rng.uniform(2000, 2310, 4000)
    x[:4], y[:4] = [1000, 1450, 1000, 1100], [2000, 2310, 2310, 2100]  # corners and tile edges
    layout = TileLayout.build((x.min(), y.min(), x.max(), y.max()), 100, 100, buffer, direction)
    ci, cj = layout.core_index(x, y)
    assert (ci >= 0).all() and (cj >= 0).all()
    got = members(layout, x, y)
    for k in range(len(x)):
        expected = set()
        for i in range(layout.nx):
            for j in range(layout.ny):
                x0, x1, y0, y1 = layout.core(i, j)
                if (x0 - buffer <= x[k] < x1 + buffer) and (y0 - buffer <= y[k] < y1 + buffer):
                    expected.add((i, j))
        expected.add((int(ci[k]), int(cj[k])))
        assert got[k] == expected


def test_x_direction_spans_the_y_range_and_ignores_the_height():
    layout = TileLayout.build((0, 0, 250, 40), 100, 5, 0, "x")
    assert (layout.nx, layout.ny) == (3, 1)
    assert layout.core(2, 0) == (200.0, 300.0, 0.0, 40.0)
    layout = TileLayout.build((0, 0, 40, 250), 5, 100, 0, "y")
    assert (layout.nx, layout.ny) == (1, 3)
    assert layout.core(0, 1) == (0.0, 40.0, 100.0, 200.0)


def test_bad_bounds_are_refused():
    with pytest.raises(ValueError, match="max >= min"):
        TileLayout.build((10, 0, 0, 10), 1, 1, 0)
