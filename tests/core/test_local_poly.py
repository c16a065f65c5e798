"""Local polynomial surfaces (the polynomial filters' interpolation) on known surfaces."""

import numpy as np
import pytest

from aldpat.core.local_poly import PointSums, _window_counts, fit_surface
from aldpat.core.lowest_grid import CellGridSpec

SPEC = CellGridSpec(100.0, 200.0, 2.0, 20, 25)  # 50 x 40 m of 2 m nodes, not at the origin


def _points(n=3000, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(100.0, 150.0, n), rng.uniform(200.0, 240.0, n)


def _nodes():
    xc, yc = SPEC.centers()
    return np.meshgrid(xc, yc)


@pytest.mark.parametrize("degree", [1, 2])
def test_a_plane_is_reproduced_at_every_node(degree):
    x, y = _points()
    z = 5.0 + 0.1 * x - 0.05 * y
    surface = fit_surface(PointSums(SPEC, x, y, z, degree), 2)
    xn, yn = _nodes()
    assert np.allclose(surface, 5.0 + 0.1 * xn - 0.05 * yn, atol=1e-4)


def test_a_quadratic_needs_degree_two():
    x, y = _points()
    z = 0.01 * (x - 125.0) ** 2 + 0.02 * (x - 125.0) * (y - 220.0)
    xn, yn = _nodes()
    truth = 0.01 * (xn - 125.0) ** 2 + 0.02 * (xn - 125.0) * (yn - 220.0)
    assert np.allclose(fit_surface(PointSums(SPEC, x, y, z, 2), 2), truth, atol=1e-3)
    assert not np.allclose(fit_surface(PointSums(SPEC, x, y, z, 1), 2), truth, atol=0.05)


def test_sparse_windows_grow_and_a_lone_point_gives_its_height():
    # three points far apart: every node's window must grow to reach them; one point alone -> mean
    x = np.array([101.0, 148.0, 120.0])
    y = np.array([201.0, 201.0, 238.0])
    z = np.array([1.0, 2.0, 3.0])
    surface = fit_surface(PointSums(SPEC, x, y, z, 1), 1, min_points=3)
    assert np.isfinite(surface).all()
    one = fit_surface(PointSums(SPEC, x[:1], y[:1], z[:1], 1), 1)
    assert np.allclose(one, 1.0)


def test_no_points_is_all_nan():
    empty = np.zeros(0)
    assert np.isnan(fit_surface(PointSums(SPEC, empty, empty, empty, 1), 1)).all()


@pytest.mark.parametrize("degree", [1, 2])
def test_bands_of_rows_give_the_answer_of_one_band(monkeypatch, degree):
    from aldpat.core import local_poly

    spec = CellGridSpec(0.0, 0.0, 1.0, 150, 40)
    rng = np.random.default_rng(3)
    x, y = rng.uniform(0, 40, 4000), rng.uniform(0, 150, 4000)
    z = np.sin(x / 7.0) + np.cos(y / 11.0) + rng.normal(0, 0.1, x.size)
    whole = fit_surface(PointSums(spec, x, y, z, degree), 5)
    monkeypatch.setattr(local_poly, "BAND_CELLS", 1)  # bands of 64 rows: the windows cross them
    banded = fit_surface(PointSums(spec, x, y, z, degree), 5)
    # the same sums in another order (the box filter runs over a slice): rounding only
    assert np.allclose(banded, whole, rtol=0, atol=1e-7)


@pytest.mark.parametrize("degree", [1, 2])
def test_one_point_per_cell_gives_the_sums_of_those_points(degree):
    spec = CellGridSpec(0.0, 0.0, 1.0, 90, 30)
    rng = np.random.default_rng(4)
    rows, cols = spec.shape
    has = rng.random((rows, cols)) < 0.6
    r, c = np.nonzero(has)
    x = np.zeros((rows, cols))
    y = np.zeros((rows, cols))
    x[has] = c + rng.random(len(c))
    y[has] = r + rng.random(len(r))
    z = np.where(has, np.sin(x / 5.0) + 0.1 * y, np.nan)
    scattered = fit_surface(PointSums(spec, x[has], y[has], z[has], degree), 3)
    per_cell = fit_surface(PointSums.one_per_cell(spec, x, y, z, has, degree), 3)
    assert np.allclose(per_cell, scattered, rtol=0, atol=1e-7)


def test_a_grid_cut_from_another_gives_the_same_surface_inside():
    """The fit at a node depends on the points in its window, not on where the grid starts: a
    window of exactly three points is a plane in both grids (the box filter's roundoff once read
    3 as 2.9999999996 in one and fell back to their mean there), so a file filtered in chunks
    fits what the whole file fits."""
    from pathlib import Path

    rows = np.loadtxt(Path(__file__).resolve().parents[2] / "jobs" / "data" / "samp24.txt")
    x0, y0 = float(np.floor(rows[:, 0].min())), float(np.floor(rows[:, 1].min()))
    col = np.floor(rows[:, 0] - x0).astype(int)
    row = np.floor(rows[:, 1] - y0).astype(int)
    spec = CellGridSpec(x0, y0, 1.0, int(row.max()) + 1, int(col.max()) + 1)
    x, y, z = (np.zeros(spec.shape) for _ in range(3))
    has = np.zeros(spec.shape, bool)
    rng = np.random.default_rng(0)
    pick = rng.random(len(rows)) < 0.05  # sparse: many windows of a few points
    x[row[pick], col[pick]], y[row[pick], col[pick]], z[row[pick], col[pick]] = rows[pick, 0], rows[pick, 1], rows[pick, 2]
    has[row[pick], col[pick]] = True
    k = 5
    whole = fit_surface(PointSums.one_per_cell(spec, x, y, z, has, 1), k, min_points=3)
    r0, r1, c0, c1 = 11, 60, 17, 101
    part = CellGridSpec(spec.x0 + c0, spec.y0 + r0, 1.0, r1 - r0, c1 - c0)
    cut = fit_surface(PointSums.one_per_cell(part, x[r0:r1, c0:c1], y[r0:r1, c0:c1], z[r0:r1, c0:c1],
                                             has[r0:r1, c0:c1], 1), k, min_points=3)
    # nodes whose window is whole in both grids and needs no growing: 3 points or more at k
    counts = _window_counts(has.astype(float), k)[r0 + k:r1 - k, c0 + k:c1 - k]
    ready = counts >= 3
    assert ready.sum() > 50 and (counts[ready] == 3).sum() > 5  # the case that went wrong is there
    a = whole[r0 + k:r1 - k, c0 + k:c1 - k][ready]
    b = cut[k:-k, k:-k][ready]
    # the same to well under the data's 1 cm: what is left is roundoff in windows of almost
    # collinear points (0.1 mm at one node here); the miscount made it 137 m
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-3)
