"""Kriging: hand-solvable systems, exactness at data points, planes exact with linear drift,
variogram fitting on local neighbourhoods, neighbours missing within a radius."""

from __future__ import annotations

import numpy as np
import pytest

from aldpat.core.grid_extent import GridSpec, from_bounds
from aldpat.core.kriging import (
    MODELS,
    Variogram,
    experimental_variogram,
    fit_variogram,
    krige,
)

LIN = Variogram("linear", 0.0, 1.0, 0.0)


def test_two_points_hand_case():
    spec = GridSpec(0.0, 0.0, 1.0, 1.0, 3, 1)
    vals = krige([0.0, 2.0], [0.0, 0.0], [1.0, 3.0], spec, variogram=LIN)
    np.testing.assert_allclose(vals, [[1.0, 2.0, 3.0]], atol=1e-12)


def test_three_points_hand_case():
    # points (0,0)=0, (2,0)=6, (0,2)=12; node (0,1): by symmetry of the linear variogram
    # gamma = [1, sqrt5, 1] -> weights solve [[0,2,2,1],[2,0,2.828,1],[2,2.828,0,1],[1,1,1,0]]
    spec = GridSpec(0.0, 1.0, 1.0, 1.0, 2, 2)
    vals = krige([0.0, 2.0, 0.0], [0.0, 0.0, 2.0], [0.0, 6.0, 12.0], spec, variogram=LIN)
    a = np.array([[0, 2, 2, 1], [2, 0, 2 * np.sqrt(2), 1], [2, 2 * np.sqrt(2), 0, 1], [1, 1, 1, 0]])
    w = np.linalg.solve(a, [1, np.sqrt(5), 1, 1])[:3]
    assert vals[0, 0] == pytest.approx(w @ [0.0, 6.0, 12.0], abs=1e-12)


def test_honours_data_points_and_reproduces_planes_with_drift():
    rng = np.random.default_rng(5)
    spec = from_bounds(1000.0, 2000.0, 1040.0, 2030.0, 1.0)
    x = rng.uniform(998, 1042, 5000)
    y = rng.uniform(1998, 2032, 5000)
    z = 4.0 + 0.25 * (x - 1000) + 0.5 * (y - 2000)
    gx, gy = np.meshgrid(spec.x_nodes(), spec.y_nodes())
    truth = 4.0 + 0.25 * (gx - 1000) + 0.5 * (gy - 2000)
    for model in MODELS:
        vals = krige(x, y, z, spec, model=model, drift="linear")
        np.testing.assert_allclose(vals, truth, atol=1e-8)
        ordinary = krige(x, y, z, spec, model=model)
        assert np.max(np.abs(ordinary - truth)) < 0.2  # ordinary kriging: close, not exact
    on_points = GridSpec(float(x[0]), float(y[0]), 1.0, 1.0, 1, 1)
    assert krige(x, y, z, on_points)[0, 0] == pytest.approx(z[0], abs=1e-9)


def test_fitted_linear_variogram_of_a_ramp():
    # z = x on a dense random cloud: gamma(h) = E[(dx)^2] / 2 = h^2 / 4 on average; the slope
    # fitted through the origin lies between the smallest and largest h/4 of the lags.
    rng = np.random.default_rng(1)
    x, y = rng.uniform(0, 100, (2, 20000))
    h, g, _n = experimental_variogram(x, y, x)
    # each bin averages d^2/4 over its pairs, which equals (mean d)^2/4 once bins are narrow
    # relative to their distance: all but the first bin
    np.testing.assert_allclose(g[1:], h[1:] ** 2 / 4, rtol=0.05)
    vg = fit_variogram(x, y, x)
    assert h.min() / 4 < vg.sill < h.max() / 4
    assert vg(np.array([0.0]))[0] == 0.0


@pytest.mark.parametrize("model", ["spherical", "exponential"])
def test_bounded_models_fit_a_stationary_surface(model):
    # sparse points (neighbourhoods reach ~15 m) on a surface of 12.6 m wavelength: the local
    # variogram levels off at the surface's variance, which is the sill a bounded model finds
    rng = np.random.default_rng(2)
    x, y = rng.uniform(0, 200, (2, 2000))
    z = np.sin(x / 2) + np.cos(y / 2)
    vg = fit_variogram(x, y, z, model=model)
    assert vg.sill == pytest.approx(z.var(), rel=0.15)
    assert 2.0 < vg.range < 15.0


def test_radius_leaves_nodes_without_neighbours_blank_and_duplicates_do_not_break():
    spec = GridSpec(0.0, 0.0, 1.0, 1.0, 10, 1)
    x = np.array([0.0, 0.0, 1.0, 2.0])
    y = np.zeros(4)
    z = np.array([1.0, 3.0, 2.0, 2.0])  # two points at (0, 0)
    vals = krige(x, y, z, spec, variogram=LIN, radius=2.5)
    assert np.isfinite(vals[0, :5]).all() and np.isnan(vals[0, 5:]).all()
    assert vals[0, 0] == pytest.approx(2.0)  # the coincident points share the weight


def test_many_neighbours_are_solved_in_batches_of_bounded_memory():
    """The systems of 8,192 nodes were solved together whatever ``max_points``: at 1,024 (the
    largest it takes) one batch asked for 137 GB, at 128 a 101 x 101 grid ran out of 4 GB. The
    batch shrinks as the systems grow, and the values are those of one batch of every node."""
    import tracemalloc

    from aldpat.core.kriging import _BATCH_BYTES, nodes_per_batch

    rng = np.random.default_rng(1)
    x, y = rng.uniform(0, 100, 3000), rng.uniform(0, 100, 3000)
    z = np.sin(x / 10) + y / 50 + rng.normal(0, 0.05, 3000)
    spec = GridSpec(20, 20, 3, 3, 21, 21)
    vg = fit_variogram(x, y, z)
    tracemalloc.start()
    try:
        wide = krige(x, y, z, spec, max_points=256, variogram=vg, workers=1)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 2 * _BATCH_BYTES  # 441 nodes in one batch took 1.6 GB
    assert nodes_per_batch(1024, 3) >= 1 and nodes_per_batch(16, 1) == 8192
    one = krige(x, y, z, spec, max_points=16, variogram=vg, workers=1)
    assert np.isfinite(wide).all() and np.abs(wide - one).max() < 0.5  # the same surface, more neighbours
