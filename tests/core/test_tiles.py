"""Tile layout (manual task 7): corners on the lattice, at most one core per point, buffers on
every side."""

import numpy as np
import pytest

from aldpat.core.tiles import TileLayout
from aldpat.io.tile_parameters import number_text


def members(layout, x, y):
    out = {}
    cores = {}
    for ti, tj, rows, core in layout.memberships(x, y):
        for a, b, k in zip(ti.tolist(), tj.tolist(), rows.tolist(), strict=False):
            assert (a, b) not in out.setdefault(k, set()), "a (point, tile) pair listed twice"
            out[k].add((a, b))
            if core:
                assert k not in cores, "a point in two cores"
                cores[k] = (a, b)
    return out, cores


def test_xy_layout_cores_and_buffers_by_hand():
    # the area 0..200 x 0..100 of 100 m tiles: two tiles, the area's upper edges are no points
    layout = TileLayout.build((0, 0, 200, 100), 100, 100, 10, "xy", upper_included=False)
    assert (layout.nx, layout.ny) == (2, 1)
    assert layout.core(1, 0) == (100.0, 200.0, 0.0, 100.0)
    x = np.array([50.0, 95.0, 105.0, 199.9, 0.0, -5.0, 215.0, 200.0])
    y = np.array([50.0, 50.0, 50.0, 99.9, 0.0, 50.0, 50.0, 50.0])
    ci, _cj = layout.core_index(x, y)
    assert ci.tolist() == [0, 0, 1, 1, 0, -1, -1, -1]  # half-open: x = 200 is the next tile's
    got, cores = members(layout, x, y)
    assert got[0] == {(0, 0)}
    assert got[1] == {(0, 0), (1, 0)}  # 5 m from the edge: in the neighbour's buffer
    assert got[2] == {(0, 0), (1, 0)} and cores[2] == (1, 0)
    assert got[5] == {(0, 0)} and 5 not in cores  # outside every core, inside the first buffer
    assert got[7] == {(1, 0)} and 7 not in cores
    assert 6 not in got  # beyond every buffer


def test_corners_on_whole_multiples_of_the_tile_size_and_origin():
    # the data's extent: its maximum is a point, which the last tile holds
    layout = TileLayout.build((493650.0, 5419770.01, 495250.59, 5421031.39), 500, 500, 30)
    assert (layout.nx, layout.ny) == (4, 4)
    assert layout.core(0, 0) == (493500.0, 494000.0, 5419500.0, 5420000.0)
    assert layout.core(3, 3) == (495000.0, 495500.0, 5421000.0, 5421500.0)
    shifted = TileLayout.build((493650.0, 5419770.01, 495250.59, 5421031.39), 500, 500, 30, origin=(100, 250))
    assert shifted.core(0, 0) == (493600.0, 494100.0, 5419750.0, 5420250.0)
    # a maximum on a lattice line opens a tile of its own, as any point there would
    layout = TileLayout.build((0, 0, 200, 100), 100, 100, 0)
    assert (layout.nx, layout.ny) == (3, 2)


def test_points_on_edges_follow_the_edge_values_of_the_parameter_file():
    """Edges that are not exact binary numbers (tiles of 0.1 from 0.3): a point is in the core
    whose edges, read back from their text, hold it: x0 <= x < x1."""
    layout = TileLayout.build((0.3, 0.3, 2.0, 2.0), 0.1, 0.1, 0.05, origin=(0.3, 0.3))
    edges = [layout.xs.edge(k) for k in range(layout.nx + 1)]
    x = np.array(edges[:-1] + [np.nextafter(e, -1) for e in edges[1:-1]])
    y = np.full(len(x), 0.35)
    ci, _ = layout.core_index(x, y)
    for xv, i in zip(x, ci, strict=False):
        x0, x1, _, _ = layout.core(int(i), 0)
        assert float(number_text(x0)) <= xv < float(number_text(x1))


@pytest.mark.parametrize("direction", ["xy", "x", "y"])
@pytest.mark.parametrize("buffer", [0.0, 7.5, 130.0])
def test_every_point_in_exactly_one_core_and_in_the_buffers_it_falls_in(direction, buffer):
    rng = np.random.default_rng(3)
    x, y = rng.uniform(1000, 1450, 4000), rng.uniform(2000, 2310, 4000)
    x[:4], y[:4] = [1000, 1450, 1000, 1100], [2000, 2310, 2310, 2100]  # corners and tile edges
    layout = TileLayout.build((x.min(), y.min(), x.max(), y.max()), 100, 100, buffer, direction)
    ci, cj = layout.core_index(x, y)
    assert (ci >= 0).all() and (cj >= 0).all()
    got, cores = members(layout, x, y)
    for k in range(len(x)):
        expected = set()
        for i in range(layout.nx):
            for j in range(layout.ny):
                x0, x1, y0, y1 = layout.core(i, j)
                if (x0 - buffer <= x[k] < x1 + buffer) and (y0 - buffer <= y[k] < y1 + buffer):
                    expected.add((i, j))
                if x0 <= x[k] < x1 and y0 <= y[k] < y1:
                    assert cores[k] == (i, j)
        assert got[k] == expected


def test_x_direction_spans_the_y_range_in_whole_metres_and_ignores_the_height():
    layout = TileLayout.build((0, 0.5, 250, 40.2), 100, 5, 0, "x")
    assert (layout.nx, layout.ny) == (3, 1)
    assert layout.core(2, 0) == (200.0, 300.0, 0.0, 41.0)
    layout = TileLayout.build((0, 0, 40, 250), 5, 100, 0, "y")
    assert (layout.nx, layout.ny) == (1, 3)
    assert layout.core(0, 1) == (0.0, 41.0, 100.0, 200.0)


def test_bad_bounds_and_absurd_sizes_are_refused():
    with pytest.raises(ValueError, match="max >= min"):
        TileLayout.build((10, 0, 0, 10), 1, 1, 0)
    with pytest.raises(ValueError, match="tiles along one axis"):
        TileLayout.build((0, 0, 1e6, 1e6), 1e-3, 1e-3, 0)
    with pytest.raises(ValueError, match="too far"):
        TileLayout.build((0, 0, 1, 1), 1e-300, 1e-300, 0)
    with pytest.raises(ValueError, match="buffer"):
        TileLayout.build((0, 0, 10, 10), 1, 1, 1000)


def test_copies_count_the_tiles_a_point_falls_in_on_average():
    """The disk a tiling needs is its input times these copies: (100 + 2 x 10) / 100 tiles along
    each tiled axis, one along an axis of one tile, and never more tiles than there are."""
    rng = np.random.default_rng(2)
    x, y = rng.uniform(0, 1000, 200_000), rng.uniform(0, 1000, 200_000)
    layout = TileLayout.build((0, 0, 999.99, 999.99), 100, 100, 10)
    assert layout.copies == pytest.approx(1.2 * 1.2)
    held = sum(len(rows) for _, _, rows, _ in layout.memberships(x, y))
    # an upper bound: the buffers at the data's edges have no neighbour to copy into (1.18 per axis here)
    assert 0.95 * layout.copies < held / len(x) <= layout.copies
    assert TileLayout.build((0, 0, 999.99, 999.99), 100, 100, 10, "x").copies == pytest.approx(1.2)
    assert TileLayout.build((0, 0, 150, 150), 100, 100, 400).copies == 4.0  # two tiles a side hold everything
