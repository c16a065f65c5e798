"""The low-outlier test on lowest-point grids (``aldpat.core.low_points``): hand-checked
minima, and scenes whose low points are known -- pits to find, streets, ditches and gaps
among roofs to leave alone."""

from __future__ import annotations

import numpy as np
import pytest

from aldpat.core.low_points import (
    NO_LOW_POINTS,
    LowPoints,
    band_minimum,
    block_factor,
    block_lowest,
    find_low_points,
    point_spacing,
)
from aldpat.core.lowest_grid import CellGridSpec


def _brute_band(z: np.ndarray, d: int) -> np.ndarray:
    rows, cols = z.shape
    out = np.full(z.shape, np.inf)
    for r in range(rows):
        for c in range(cols):
            for dr in range(-2 * d, 2 * d + 1):
                for dc in range(-2 * d, 2 * d + 1):
                    if max(abs(dr), abs(dc)) >= d and 0 <= r + dr < rows and 0 <= c + dc < cols:
                        out[r, c] = min(out[r, c], z[r + dr, c + dc])
    return out


@pytest.mark.parametrize("shape", [(13, 17), (3, 4), (1, 9), (31, 26)])
@pytest.mark.parametrize("d", [1, 2, 4, 7])
def test_band_minimum_is_the_lowest_cell_d_to_2d_away(shape, d):
    z = np.random.default_rng(d).random(shape)
    assert np.array_equal(band_minimum(z, d, np.inf), _brute_band(z, d))
    codes = (z * 1000).astype(np.int32)
    top = np.iinfo(np.int32).max
    assert np.array_equal(band_minimum(codes, d, top), np.where(np.isinf(_brute_band(codes, d)), top,
                                                                 _brute_band(codes, d)))


def test_a_band_wider_than_the_grid_holds_nothing_and_costs_the_grid_only():
    """A band ``d`` cells away, with ``d`` far beyond a small grid, finds no cell; its scratch is
    the grid's, not the band's (a band of 10**7 cells would need gigabytes)."""
    z = np.random.default_rng(5).random((6, 9))
    assert np.array_equal(band_minimum(z, 10**7, np.inf), np.full(z.shape, np.inf))
    assert np.array_equal(band_minimum(z, 5, np.inf), _brute_band(z, 5))


def test_block_lowest_takes_the_lowest_point_of_each_block():
    rng = np.random.default_rng(3)
    codes = rng.integers(0, 1000, (7, 11)).astype(np.int32)
    real = rng.random((7, 11)) < 0.6
    for offset in ((0, 0), (1, 2), (2, 1)):
        low, has = block_lowest(codes, real, 3, offset)
        for br in range(low.shape[0]):
            for bc in range(low.shape[1]):
                r0, c0 = br * 3 - offset[0], bc * 3 - offset[1]
                rs, cs = slice(max(r0, 0), r0 + 3), slice(max(c0, 0), c0 + 3)
                vals = codes[rs, cs][real[rs, cs]]
                assert has[br, bc] == bool(len(vals))
                if len(vals):
                    assert low[br, bc] == vals.min()


def test_spacing_sets_the_blocks():
    assert point_spacing(100, (0.0, 0.0, 30.0, 30.0)) == pytest.approx(3.0)
    assert point_spacing(0, (0.0, 0.0, 1.0, 1.0)) is None
    assert block_factor(None, 1.0) == 1 and block_factor(0.7, 1.0) == 1
    assert block_factor(3.0, 1.0) == 3 and block_factor(7.4, 1.0) == 7


def _find(z, real=None, spacing=None, **kw):
    real = np.isfinite(z) if real is None else real
    spec = CellGridSpec(0.0, 0.0, 1.0, *z.shape)
    params = {"threshold": 2.0, "window": 2, "reach": 20.0} | kw
    return find_low_points(z, lambda c: c, real, spec, spacing=spacing, **params)


def _slope(rows=80, cols=80, seed=0):
    rng = np.random.default_rng(seed)
    r, c = np.mgrid[0:rows, 0:cols].astype(float)
    return 100.0 + 0.3 * c + 0.1 * r + rng.normal(0, 0.05, (rows, cols))


def test_single_pits_and_a_clump_on_a_slope_are_found_and_nothing_else():
    z = _slope()
    z[20, 30] -= 4.0  # a single low point (the slope takes 0.8 m of it: the band reaches 2 cells)
    z[60, 15] -= 40.0
    z[40:43, 50:53] -= 6.0  # a clump 3 cells across
    z[43, 56] -= 5.0  # a single one beside it: neither hides the other
    low = _find(z)
    want = {20 * 80 + 30, 60 * 80 + 15, 43 * 80 + 56} | {r * 80 + c for r in range(40, 43) for c in range(50, 53)}
    assert set(low.cells.tolist()) == want
    assert (low.limits > z.ravel()[low.cells]).all()
    assert (low.limits < _slope().ravel()[low.cells]).all()  # the ground there is above the limit


def test_streets_ditches_and_gaps_among_roofs_are_terrain():
    """Ground far below the cells around it -- a street between roofs, a ditch, a hollow wider
    than a clump, the ground seen between wagons -- is no outlier: it reaches out of the band
    around it, or lies at the level of the ground elsewhere."""
    z = _slope()
    ground = z.copy()
    z[:, 10:30] += 8.0  # a row of buildings...
    z[:, 19:21] = ground[:, 19:21]  # ...with a 2 m lane between them
    z[50:53, 30:] -= 3.0  # a ditch from the buildings to the scene's edge
    z[10:20, 60:70] -= 4.0  # a hollow 10 m across
    z[60:78, 40:78] += 4.0  # a train of wagons...
    for c in range(44, 78, 6):  # ...with the ground seen between them
        z[62:76, c] = ground[62:76, c]
    z[70, 47] = ground[70, 47]  # and through one of them
    assert len(_find(z)) == 0


def test_sparse_points_are_tested_on_blocks_of_their_spacing():
    """Points 3 cells apart, the empty cells between them: a single low point is found among
    the points around it when the test is told their spacing, not among empty cells."""
    z = np.full((90, 90), np.nan)
    base = _slope(90, 90)
    z[::3, ::3] = base[::3, ::3]
    z[45, 45] -= 10.0
    found = _find(z, spacing=3.0)
    assert found.cells.tolist() == [45 * 90 + 45]
    assert found.below(np.array([45 * 90 + 45, 45 * 90 + 45, 0]), np.array([z[45, 45], base[45, 45], 0.0])
                       ).tolist() == [True, False, False]


def test_below_looks_up_each_points_cell():
    low = LowPoints(np.array([3, 9]), np.array([10.0, 20.0]))
    cells = np.array([3, 3, 9, 4, 12])
    z = np.array([9.0, 11.0, 19.0, 0.0, 0.0])
    assert low.below(cells, z).tolist() == [True, False, True, False, False]
    assert not NO_LOW_POINTS.below(cells, z).any()


@pytest.mark.parametrize("spacing", [None, 3.0])
def test_strips_on_threads_find_what_one_strip_finds(monkeypatch, spacing):
    """The grid's strips are tested on threads at once: the cells and limits found, in order, are
    those of the whole grid taken as one strip."""
    import aldpat.core.low_points as module

    rng = np.random.default_rng(8)
    z = _slope(120, 90)
    pits = rng.integers(0, z.size, 60)
    z.ravel()[pits] -= rng.uniform(3, 30, len(pits))
    if spacing:
        z[np.arange(120) % 3 != 0] = np.nan
        z[:, np.arange(90) % 3 != 0] = np.nan
    whole = _find(z, spacing=spacing)
    assert len(whole) > 5
    monkeypatch.setattr(module, "rows_per_block", lambda cols, cells=0: 7)
    for threads in ("1", "3"):
        monkeypatch.setenv("ALDPAT_THREADS", threads)
        strips = _find(z, spacing=spacing)
        assert np.array_equal(strips.cells, whole.cells) and np.array_equal(strips.limits, whole.limits)
