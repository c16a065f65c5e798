"""Gridding methods on surfaces with known values: planes exact for the TIN, hand-computed
small cases for nearest / idw / binning, a sampled analytic surface with a bounded error, and
blanks far from data instead of invented terrain."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from aldpat.core.grid_extent import GridSpec, from_bounds
from aldpat.core.interpolate import (
    METHODS,
    Binner,
    binned,
    idw,
    interpolate,
    linear,
    nearest,
)
from aldpat.errors import DataError, UsageError

SPEC = from_bounds(500000.0, 4000000.0, 500060.0, 4000050.0, 1.0)


def plane(x, y):
    return 12.5 + 0.3 * (x - 500000.0) - 0.2 * (y - 4000000.0)


def surface(x, y):
    return 5.0 * np.sin((x - 500000.0) / 9.0) + 3.0 * np.cos((y - 4000000.0) / 7.0)


def scattered(n=8000, seed=3, margin=3.0):
    rng = np.random.default_rng(seed)
    x = rng.uniform(SPEC.xmin - margin, SPEC.xmax + margin, n)
    y = rng.uniform(SPEC.ymin - margin, SPEC.ymax + margin, n)
    return x, y


def nodes():
    return np.meshgrid(SPEC.x_nodes(), SPEC.y_nodes())


def test_linear_is_exact_on_a_plane():
    x, y = scattered()
    vals = linear(x, y, plane(x, y), SPEC)
    assert not np.isnan(vals).any()
    np.testing.assert_allclose(vals, plane(*nodes()), atol=1e-9)


def test_linear_blocks_agree_with_one_triangulation():
    x, y = scattered()
    z = surface(x, y)
    whole = linear(x, y, z, SPEC, block_points=10**9)
    blocked = linear(x, y, z, SPEC, block_points=500)
    np.testing.assert_allclose(blocked, whole, atol=1e-9)


def test_linear_is_the_tin_of_every_point_across_building_sized_holes():
    """Ground under buildings leaves holes of 20-70 m, wider than the 8-spacing buffer each block
    of the TIN triangulates: a block took triangles across a hole at its edge that the TIN of
    every point does not hold (7.2 m off, 7,032 of 361,201 nodes more than 1 mm; 800 nodes left
    blank), so a DTM depended on where its blocks, or its tiles, fell. Against scipy's Delaunay
    TIN of every point (qhull), a curved terrain with 20 such holes: every node the same (the
    figures above: ``bench/bench_tin.py``'s scene of 60 holes)."""
    from scipy.interpolate import LinearNDInterpolator

    from tests.filters.terrain_scenes import ground_with_building_holes

    x, y, z = ground_with_building_holes(60_000, 330.0, 20)
    spec = from_bounds(0, 0, 330, 330, 1.0)
    ours = linear(x, y, z, spec, block_points=2_000)  # blocks of about 60 m: many edges cross holes
    gx, gy = np.meshgrid(spec.xmin + np.arange(spec.nx) * spec.dx, spec.ymin + np.arange(spec.ny) * spec.dy)
    exact = LinearNDInterpolator(np.column_stack([x, y]), z)(gx, gy)
    assert np.array_equal(np.isnan(ours), np.isnan(exact))
    assert np.nanmax(np.abs(ours - exact)) < 1e-9


def test_compiled_tin_gives_qhulls_nodes(monkeypatch):
    # random points (no co-circular four) with repeated positions, the grid reaching past the hull
    from aldpat.core import interpolate as module

    x, y = scattered(margin=-4.0)
    x, y = np.r_[x, x[:300]], np.r_[y, y[:300]]
    z = surface(x, y) + np.r_[np.zeros(len(x) - 300), np.full(300, 0.5)]
    spec = from_bounds(SPEC.xmin - 2, SPEC.ymin - 2, SPEC.xmax + 2, SPEC.ymax + 2, 0.5)
    compiled = linear(x, y, z, spec, block_points=2000)
    monkeypatch.setattr(module, "tin_block", lambda *args: False)  # every block by qhull
    by_qhull = linear(x, y, z, spec, block_points=2000)
    np.testing.assert_array_equal(np.isnan(compiled), np.isnan(by_qhull))
    np.testing.assert_allclose(compiled, by_qhull, atol=1e-9)
    assert np.isnan(compiled).any() and not np.isnan(compiled).all()


def test_linear_on_three_points_is_barycentric_and_blank_outside():
    spec = GridSpec(0.0, 0.0, 1.0, 1.0, 5, 5)
    vals = linear([0.0, 4.0, 0.0], [0.0, 0.0, 4.0], [0.0, 8.0, 4.0], spec)
    assert vals[0, 0] == pytest.approx(0.0)
    assert vals[1, 2] == pytest.approx(2 * 2 + 1 * 1)  # z = 2x + y
    assert vals[2, 2] == pytest.approx(6.0)  # on the hypotenuse
    assert np.isnan(vals[3, 3]) and np.isnan(vals[4, 4])  # outside the hull


def test_linear_takes_the_mean_height_of_points_sharing_a_position():
    # a first and a last return at one x, y: one vertex at their mean, whatever their order
    spec = GridSpec(0.0, 0.0, 1.0, 1.0, 5, 5)
    x, y, z = [0.0, 4.0, 0.0, 4.0, 4.0], [0.0, 0.0, 4.0, 4.0, 4.0], [0.0, 0.0, 0.0, 2.0, 4.0]
    for order in ([0, 1, 2, 3, 4], [4, 3, 2, 1, 0], [3, 0, 4, 1, 2]):
        vals = linear(np.take(x, order), np.take(y, order), np.take(z, order), spec)
        assert vals[4, 4] == pytest.approx(3.0)
        assert vals[2, 4] == pytest.approx(1.5)  # halfway up the east edge


def test_nearest_hand_case():
    spec = GridSpec(0.0, 0.0, 1.0, 1.0, 4, 1)
    vals = nearest([0.2, 2.9], [0.0, 0.0], [1.0, 7.0], spec)
    np.testing.assert_array_equal(vals, [[1.0, 1.0, 7.0, 7.0]])


def test_idw_hand_case_and_exact_hits():
    spec = GridSpec(0.0, 0.0, 1.0, 1.0, 4, 1)
    # node 1: distances 1 and 2 -> weights 1 and 1/4 -> (10 + 40/4) / 1.25 = 16
    vals = idw([0.0, 3.0], [0.0, 0.0], [10.0, 40.0], spec, power=2.0)
    np.testing.assert_allclose(vals, [[10.0, 16.0, 34.0, 40.0]])
    vals = idw([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], [10.0, 20.0, 40.0], spec, max_points=3)
    assert vals[0, 0] == 15.0  # coincident points are averaged


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e4])
def test_idw_at_a_large_power_is_the_nearest_point_not_a_blank(scale):
    """1 / d**power overflowed (d < 1) or underflowed (d > 1) at --power 1e9: every node was
    blank, with numpy's overflow warning; the weight of the nearest point dominates instead."""
    spec = GridSpec(0.0, 0.0, scale, scale, 4, 1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        vals = idw([0.0, 3.0 * scale], [0.0, 0.0], [10.0, 40.0], spec, power=1e9)
    np.testing.assert_allclose(vals, [[10.0, 10.0, 40.0, 40.0]])
    np.testing.assert_allclose(idw([0.0, 3.0 * scale], [0.0, 0.0], [10.0, 40.0], spec, power=2.0),
                               [[10.0, 16.0, 34.0, 40.0]])


def test_binning_hand_case():
    spec = GridSpec(0.0, 0.0, 1.0, 1.0, 3, 2)
    x = np.array([0.1, -0.2, 0.4, 2.0, 5.0])
    y = np.array([0.0, 0.3, -0.1, 1.2, 0.0])
    z = np.array([3.0, 1.0, 2.0, 9.0, 99.0])  # the last point lies outside every cell
    expect = {"min": 1.0, "max": 3.0, "mean": 2.0}
    for stat, first in expect.items():
        vals = binned(x, y, z, spec, statistic=stat)
        assert vals[0, 0] == first and vals[1, 2] == 9.0
        assert np.isnan(vals).sum() == 4


def test_binner_in_chunks_equals_all_at_once():
    x, y = scattered(3000)
    z = surface(x, y)
    for stat in ("min", "max", "mean"):
        binner = Binner(SPEC, stat)
        for part in np.array_split(np.arange(len(x)), 7):
            binner.add(x[part], y[part], z[part])
        np.testing.assert_allclose(binner.result(), binned(x, y, z, SPEC, statistic=stat), equal_nan=True)


@pytest.mark.parametrize("method, rms, worst", [
    ("nearest", 0.35, 1.2), ("linear", 0.02, 0.15), ("idw", 0.3, 0.8), ("kriging", 0.03, 0.2),
    ("mean", 0.5, 1.5)])
def test_analytic_surface_error_is_bounded(method, rms, worst):
    x, y = scattered(12000)
    vals = interpolate(x, y, surface(x, y), SPEC, method=method)
    err = vals - surface(*nodes())
    assert np.sqrt(np.nanmean(err**2)) < rms
    assert np.nanmax(np.abs(err)) < worst
    if method != "mean":
        assert not np.isnan(vals).any()


@pytest.mark.parametrize("method", ["nearest", "linear", "idw", "kriging"])
def test_max_distance_blanks_a_gap(method):
    x, y = scattered(6000)
    gap = (x > 500020) & (x < 500040) & (y > 4000015) & (y < 4000035)
    x, y = x[~gap], y[~gap]
    vals = interpolate(x, y, plane(x, y), SPEC, method=method, max_distance=3.0)
    gx, gy = nodes()
    centre = (gx > 500024) & (gx < 500036) & (gy > 4000019) & (gy < 4000031)
    assert np.isnan(vals[centre]).all()
    assert not np.isnan(vals[~((gx > 500018) & (gx < 500042) & (gy > 4000013) & (gy < 4000037))]).any()
    full = interpolate(x, y, plane(x, y), SPEC, method=method)
    assert not np.isnan(full[centre]).any()  # without the limit the gap is filled


def test_every_method_is_dispatched_and_unknown_is_refused():
    x, y = scattered(2000)
    for method in METHODS:
        vals = interpolate(x, y, plane(x, y), SPEC, method=method)
        assert vals.shape == SPEC.shape
    with pytest.raises(UsageError, match="did|use"):
        interpolate(x, y, plane(x, y), SPEC, method="spline")
    with pytest.raises(DataError):
        interpolate([], [], [], SPEC, method="nearest")


def test_linear_in_float32_is_the_float64_grid_rounded_once():
    x, y = scattered(margin=-4.0)
    z = 300.0 + surface(x, y)
    wide = linear(x, y, z, SPEC, block_points=2000)
    narrow = linear(x, y, z, SPEC, block_points=2000, dtype=np.float32)
    assert narrow.dtype == np.float32
    np.testing.assert_array_equal(narrow, wide.astype(np.float32))  # NaN where NaN
    assert np.isnan(narrow).any() and not np.isnan(narrow).all()


def test_block_order_is_the_stable_sort_of_the_block_numbers():
    # what the blocks gather by index: the points near the grid, by block, each block's points in
    # their own order (numpy's stable argsort of the block numbers)
    from aldpat.core.interpolate import _block_order

    rng = np.random.default_rng(5)
    x = np.round(rng.uniform(-20, 120, 5000), 2)
    y = np.round(rng.uniform(-20, 90, 5000), 2)
    x[:50] = np.round(x[:50])  # points on block edges
    spec = GridSpec(0.0, 0.0, 1.0, 1.0, 100, 70)
    lo_x, hi_x, lo_y, hi_y = -10.5, 109.5, -3.5, 72.5
    nbx, nby = 8, 5
    order, starts = _block_order(x, y, lo_x, hi_x, lo_y, hi_y, spec.xmin, spec.ymin, 0.5, 0.5, 13.0, 14.0, nbx, nby)
    near = np.flatnonzero((x >= lo_x) & (x <= hi_x) & (y >= lo_y) & (y <= hi_y))
    bx = np.clip(np.floor((x[near] - spec.xmin + 0.5) / 13.0).astype(np.int64), 0, nbx - 1)
    by = np.clip(np.floor((y[near] - spec.ymin + 0.5) / 14.0).astype(np.int64), 0, nby - 1)
    key = by * nbx + bx
    expected = np.argsort(key, kind="stable")
    np.testing.assert_array_equal(order, near[expected])
    np.testing.assert_array_equal(starts, np.searchsorted(key[expected], np.arange(nbx * nby + 1)))


def test_insertion_order_is_the_serpentine_of_squares():
    from aldpat.core.tin_raster import insertion_order

    rng = np.random.default_rng(2)
    for n, square in ((1, 1.0), (300, 0.01), (5000, 0.7), (5000, 3.0), (5000, 1e6)):
        x, y = np.round(rng.uniform(0, 50, n), 2), np.round(rng.uniform(0, 30, n), 2)
        row = np.floor((y - y.min()) / square).astype(np.int64)
        col = np.floor((x - x.min()) / square).astype(np.int64)
        col = np.where(row % 2 == 1, col.max() - col, col)
        np.testing.assert_array_equal(insertion_order(x, y, square), np.lexsort((col, row)))
