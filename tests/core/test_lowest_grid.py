"""Lowest-point gridding and nearest-neighbour filling (dissertation ch. 3, §4.2.1)."""

import numpy as np
import pytest

from aldpat.core.lowest_grid import MAX_CELLS, fill_nearest, grid_spec, lowest_grid
from aldpat.errors import DataError


def test_hand_case_keeps_lowest_and_marks_empty():
    # cells of 1 m; grid from x 10..12, y 20..21 -> 2 rows x 3 cols
    x = np.array([10.2, 10.8, 11.5, 12.1, 12.9, 10.5])
    y = np.array([20.1, 20.9, 20.5, 21.3, 21.7, 20.4])
    z = np.array([5.0, 4.0, 7.0, 3.0, 2.5, 4.0])
    g = lowest_grid(x, y, z, 1.0)
    assert (g.spec.x0, g.spec.y0, g.spec.rows, g.spec.cols) == (10.0, 20.0, 2, 3)
    # cell (0, 0) holds points 0, 1, 5 -> z 4.0 reached by 1 and 5: smallest index wins
    assert g.lowest[0, 0] == 1 and g.z[0, 0] == 4.0
    assert g.lowest[0, 1] == 2 and g.z[0, 1] == 7.0
    assert g.lowest[1, 2] == 4 and g.z[1, 2] == 2.5
    assert g.empty.tolist() == [[False, False, True], [True, True, False]]
    assert np.isnan(g.z[g.empty]).all()
    assert g.cell_index.tolist() == [0, 0, 1, 5, 5, 0]


def test_alignment_to_cell_multiples_and_origin():
    x = np.array([-3.7, 4.2])
    y = np.array([101.1, 99.0])
    s = grid_spec(x, y, 2.0)
    assert (s.x0, s.y0, s.cols, s.rows) == (-4.0, 98.0, 5, 2)
    s = grid_spec(x, y, 2.0, origin=(0.5, 0.25))
    assert (s.x0, s.y0) == (-5.5, 98.25)  # -3.7 lies in [-5.5, -3.5)


def test_subset_lands_in_same_absolute_cells():
    rng = np.random.default_rng(1)
    x = rng.uniform(0, 50, 2000)
    y = rng.uniform(0, 40, 2000)
    z = rng.normal(size=2000)
    full = lowest_grid(x, y, z, 1.5)
    sub = x > 20
    part = lowest_grid(x[sub], y[sub], z[sub], 1.5)
    dc = round((part.spec.x0 - full.spec.x0) / 1.5)
    dr = round((part.spec.y0 - full.spec.y0) / 1.5)
    fr, fc = np.divmod(full.cell_index[sub], full.spec.cols)
    pr, pc = np.divmod(part.cell_index, part.spec.cols)
    assert np.array_equal(fr, pr + dr) and np.array_equal(fc, pc + dc)


def test_matches_brute_force():
    rng = np.random.default_rng(2)
    n = 5000
    x = rng.uniform(100, 130, n)
    y = rng.uniform(-10, 5, n)
    z = np.round(rng.normal(size=n), 1)  # many ties
    g = lowest_grid(x, y, z, 0.7)
    expect = {}
    for i, c in enumerate(g.cell_index):
        if c not in expect or z[i] < z[expect[c]]:
            expect[c] = i
    flat = g.lowest.ravel()
    assert {c: flat[c] for c in expect} == expect
    assert (flat >= 0).sum() == len(expect)
    col = np.floor(x / 0.7).astype(int) - round(g.spec.x0 / 0.7)
    row = np.floor(y / 0.7).astype(int) - round(g.spec.y0 / 0.7)
    assert np.array_equal(g.cell_index, row * g.spec.cols + col)


def test_empty_input():
    g = lowest_grid(np.zeros(0), np.zeros(0), np.zeros(0), 1.0)
    assert g.z.shape == (0, 0) and len(g.cell_index) == 0


def test_too_large_grid_is_a_data_error():
    with pytest.raises(DataError, match="too large"):
        grid_spec(np.array([0.0, MAX_CELLS]), np.array([0.0, 10.0]), 0.5)


def test_fill_nearest_hand_case():
    z = np.array([[1.0, np.nan, np.nan, 4.0],
                  [np.nan, np.nan, np.nan, np.nan],
                  [np.nan, np.nan, np.nan, 9.0]])
    f = fill_nearest(z)
    # cells with a single nearest neighbour; (1, 3) is 1 from both 4.0 and 9.0
    assert f[0, 1] == 1.0 and f[0, 2] == 4.0 and f[1, 0] == 1.0 and f[2, 2] == 9.0 and f[1, 3] in (4.0, 9.0)
    assert not np.isnan(f).any()
    assert np.isnan(z[0, 1])  # input untouched


def test_fill_nearest_is_nearest():
    rng = np.random.default_rng(3)
    z = rng.uniform(0, 100, (30, 40))
    empty = rng.random((30, 40)) < 0.7
    f = fill_nearest(z, empty)
    assert np.array_equal(f[~empty], z[~empty])
    vr, vc = np.nonzero(~empty)
    for r, c in zip(*np.nonzero(empty), strict=False):
        d2 = (vr - r) ** 2 + (vc - c) ** 2
        candidates = z[vr[d2 == d2.min()], vc[d2 == d2.min()]]
        assert f[r, c] in candidates


def test_fill_nearest_all_or_nothing_empty():
    z = np.full((3, 3), np.nan)
    assert np.isnan(fill_nearest(z)).all()
    z = np.ones((2, 2))
    assert np.array_equal(fill_nearest(z), z)
    with pytest.raises(ValueError):
        fill_nearest(z, np.zeros((3, 3), bool))


@pytest.mark.parametrize("threads", [1, 2, 5])
@pytest.mark.parametrize("share", [0.1, 0.5, 0.9, 0.999])
def test_fill_nearest_takes_the_cell_of_scipys_feature_transform(share, threads, monkeypatch):
    """Every empty cell takes the value of the very cell scipy's exact Euclidean feature
    transform names, ties included, and its distance from it (cells, rounded up, at most 255);
    the same with the rows split into blocks filled on threads at once."""
    from scipy import ndimage

    import aldpat.core.nearest_fill

    monkeypatch.setenv("ALDPAT_THREADS", str(threads))
    monkeypatch.setattr(aldpat.core.nearest_fill, "MIN_BLOCK_ROWS", 7)
    rng = np.random.default_rng(7)
    for shape in ((211, 347), (1, 40), (40, 1), (5, 3)):
        empty = rng.random(shape) < share
        empty[::17, ::13] = False  # regular ties: cells halfway between two holders
        z = rng.integers(-10_000, 10_000, shape).astype(np.int32)
        rows, cols = ndimage.distance_transform_edt(empty, return_distances=False, return_indices=True)
        spacing = np.empty(shape, np.uint8)
        filled = fill_nearest(z, empty, spacing=spacing)
        assert np.array_equal(filled, z[rows, cols])
        r, c = np.indices(shape)
        distance = np.ceil(np.hypot((rows - r).astype(np.float32), (cols - c).astype(np.float32)))
        assert np.array_equal(spacing, np.minimum(distance, 255).astype(np.uint8))


def test_fill_nearest_in_place_on_height_codes():
    """In place (no second grid) and on integer codes: the values of the copy on float heights."""
    rng = np.random.default_rng(3)
    codes = rng.integers(-5000, 90000, (157, 203)).astype(np.int32)
    empty = rng.random(codes.shape) < 0.8
    expected = fill_nearest(np.where(empty, np.nan, codes * 0.01), empty)
    filled = fill_nearest(codes, empty, out=codes)
    assert filled is codes and filled.dtype == np.int32
    assert np.array_equal(codes * 0.01, expected)


def test_fill_nearest_reports_each_cells_distance_from_its_point():
    """``spacing``: 0 where a cell holds a value, else the distance to the cell it was filled
    from, in cells rounded up (scipy's distance transform), at most 255."""
    from scipy import ndimage

    rng = np.random.default_rng(5)
    z = rng.uniform(0, 10, (60, 80))
    empty = rng.random(z.shape) < 0.9
    spacing = np.full(z.shape, 99, np.uint8)
    fill_nearest(z, empty, spacing=spacing)
    expected = np.ceil(ndimage.distance_transform_edt(empty) - 1e-9)
    assert np.array_equal(spacing, expected)
    assert (spacing[~empty] == 0).all()
    far = np.ones((3, 600), bool)
    far[1, 0] = False
    capped = np.empty(far.shape, np.uint8)
    fill_nearest(np.zeros(far.shape), far, spacing=capped)
    assert capped[1, 100] == 100 and capped[1, 599] == 255
    full = np.empty((2, 2), np.uint8)
    fill_nearest(np.ones((2, 2)), spacing=full)
    assert (full == 0).all()


def test_millimetre_cells_far_from_the_origin_grid_the_data_alone():
    x = np.array([494200.051, 494200.5])
    y = np.array([5420300.021, 5420300.3])
    spec = grid_spec(x, y, 0.002)
    # floor(x / 0.002): 247,100,025 .. 247,100,250; floor(y / 0.002): 2,710,150,010 .. 2,710,150,150
    assert (spec.rows, spec.cols) == (141, 226)
    low = lowest_grid(x, y, np.array([1.0, 2.0]), 0.002)
    assert np.count_nonzero(~low.empty) == 2
