"""Local polynomial surfaces (the polynomial filters' interpolation) on known surfaces."""

import numpy as np
import pytest

from aldpat.core.local_poly import PointSums, fit_surface
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
