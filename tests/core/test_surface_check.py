"""SMRF's final test: every point judged against the filled provisional ground surface."""

from __future__ import annotations

import numpy as np
import pytest

from aldpat.core.lowest_grid import CellGridSpec
from aldpat.core.surface_check import (
    bilinear,
    provisional_surface,
    slope_of,
    within_surface,
)


def plane(spec: CellGridSpec, a=0.3, b=-0.1, c=50.0):
    xc, yc = spec.centers()
    return c + a * xc[None, :] + b * yc[:, None]


def test_a_building_footprint_is_spanned_from_the_ground_around_it():
    spec = CellGridSpec(0.0, 0.0, 1.0, 40, 50)
    truth = plane(spec)
    ground = np.ones(truth.shape, bool)
    ground[10:30, 15:35] = False  # the building's 20 x 20 cells
    z = truth + np.where(ground, 0.0, 8.0)
    surface = provisional_surface(z, ground, spec)
    np.testing.assert_array_equal(surface[ground], truth[ground])  # ground cells kept exactly
    hole = surface[~ground]
    rim = truth[10:30, 15:35]
    assert rim.min() - 0.25 <= hole.min() and hole.max() <= rim.max() + 0.25  # no roof leaks in
    assert np.abs(hole - truth[~ground]).max() < 0.25  # the claim in the docstring
    assert np.abs(slope_of(surface, 1.0)[ground] - np.hypot(0.3, 0.1)).mean() < 0.02


def test_isolated_ground_cells_of_sparse_data_fill_every_cell():
    spec = CellGridSpec(0.0, 0.0, 1.0, 30, 30)
    truth = plane(spec, a=0.0, b=0.0, c=12.0)
    ground = np.zeros(truth.shape, bool)
    ground[::5, ::5] = True  # one cell in 25 holds ground, as in 0.2 points/m2 on 1 m cells
    surface = provisional_surface(np.where(ground, truth, 99.0), ground, spec)
    np.testing.assert_allclose(surface, 12.0)
    assert np.isnan(provisional_surface(truth, np.zeros(truth.shape, bool), spec)).all()


@pytest.mark.parametrize("rows, cols", [(1, 400), (2, 400), (400, 1), (6, 4000)])
def test_a_long_narrow_grid_is_spanned_between_its_ground_cells(rows, cols):
    """Points along one line, a corridor, a sliver of a tile: the pyramid's coarsest level is
    still long, with runs of cells far from any ground. The membrane spans them from the ground
    at both ends instead of sagging towards 0 m between."""
    spec = CellGridSpec(0.0, 0.0, 1.0, rows, cols)
    truth = plane(spec, a=0.02 if cols > 1 else 0.0, b=0.02 if rows > 1 else 0.0, c=100.0)
    ground = np.zeros(truth.shape, bool)
    ground.reshape(-1)[::97] = True  # ground every 97 cells, as a sparse line of points
    ground.reshape(-1)[-1] = True
    surface = provisional_surface(np.where(ground, truth, 500.0), ground, spec)
    np.testing.assert_array_equal(surface[ground], truth[ground])
    assert np.abs(surface - truth).max() < 1.0  # 97 cells of a 2 % slope rise 1.9 m


def test_points_within_threshold_plus_slope_term():
    spec = CellGridSpec(0.0, 0.0, 1.0, 20, 20)
    surface = plane(spec, a=0.5, b=0.0)  # slope 0.5
    x = np.array([5.5, 5.5, 5.5, 5.5, 10.0])
    y = np.array([5.5, 5.5, 5.5, 5.5, 10.0])
    at = 50.0 + 0.5 * x
    z = at + np.array([0.0, 0.79, 0.81, -0.79, 2.0])
    # tolerance 0.3 + 1.0 x 0.5 = 0.8 m on either side
    got = within_surface(x, y, z, surface, spec, threshold=0.3, slope_scalar=1.0)
    assert got.tolist() == [True, True, False, True, False]
    assert bilinear(surface, spec, np.array([3.0]), np.array([7.0]))[0] == 50.0 + 0.5 * 3.0


def test_strips_give_the_surface_and_slope_of_the_whole_grid(monkeypatch):
    """The finest level relaxed a strip of rows at a time (in turn or on threads at once), and the
    slope taken a strip at a time, are bit for bit those of the whole grid at once; the float32 surface with exact ground heights
    of the surface test is the float64 surface."""
    import aldpat.core.surface_check as module

    rng = np.random.default_rng(11)
    spec = CellGridSpec(0.0, 0.0, 0.75, 131, 97)
    z = plane(spec) + rng.normal(0, 0.3, (131, 97))
    ground = rng.random(z.shape) < 0.3
    ground[40:80, 20:60] = False  # a building's footprint
    monkeypatch.setattr(module, "STRIP_ROWS", 10_000)
    surface = provisional_surface(z, ground, spec)
    slope = slope_of(surface, spec.cell)
    for rows in (2, 6, 64):
        monkeypatch.setattr(module, "STRIP_ROWS", rows)
        for threads in ("1", "3"):  # the strips taken in turn, or on threads at once
            monkeypatch.setenv("ALDPAT_THREADS", threads)
            np.testing.assert_array_equal(provisional_surface(z, ground, spec), surface)
        np.testing.assert_array_equal(slope_of(surface, spec.cell), slope)
    marks = np.where(ground, 0, 4).astype(np.int16)

    from aldpat.core.height_codes import FloatHeights

    cells = type("Cells", (), {"codes": z, "heights": FloatHeights(), "spec": spec})()
    test = module.SurfaceTest.build(cells, marks, threshold=0.3, slope_scalar=1.0)
    r, c = (i.ravel() for i in np.indices(z.shape))
    np.testing.assert_array_equal(test._at(r, c).reshape(z.shape), surface)
    assert test.slope is None  # taken at the cells the points read
    np.testing.assert_array_equal(test._slopes(r, c).reshape(z.shape), slope)
    order = rng.permutation(len(r))  # any order, cells met again and again: the same values
    np.testing.assert_array_equal(test._slopes(np.tile(r[order], 3), np.tile(c[order], 3)),
                                  np.tile(slope.ravel()[order], 3))
    x = rng.uniform(0, 97 * 0.75, 5000)
    y = rng.uniform(0, 131 * 0.75, 5000)
    h = rng.uniform(40, 60, 5000)
    np.testing.assert_array_equal(test.test(x, y, h), within_surface(x, y, h, surface, spec, threshold=0.3,
                                                                      slope_scalar=1.0))


def _reference_pull(value, weight):
    """The pyramid's step down in its former numpy form."""
    rows, cols = value.shape
    pr, pc = rows + rows % 2, cols + cols % 2
    v = np.zeros((pr, pc), np.float32)
    w = np.zeros((pr, pc), np.float32)
    v[:rows, :cols] = value * weight
    w[:rows, :cols] = weight
    ws = w.reshape(pr // 2, 2, pc // 2, 2).sum(axis=(1, 3))
    vs = v.reshape(pr // 2, 2, pc // 2, 2).sum(axis=(1, 3))
    return np.divide(vs, ws, out=np.zeros_like(vs), where=ws > 0), np.minimum(ws, np.float32(1.0))


def _reference_relax(value, fixed, sweeps):
    """Jacobi sweeps in their former numpy form (edges mirror, so a grid one cell wide is swept
    along its length)."""
    held = value[fixed]
    for _ in range(sweeps):
        padded = np.pad(value, 1, mode="edge")
        value = padded[:-2, 1:-1] + padded[2:, 1:-1]
        value += padded[1:-1, :-2]
        value += padded[1:-1, 2:]
        value *= np.float32(0.25)
        value[fixed] = held
    return value


def test_compiled_pyramid_and_slope_equal_the_numpy_form_bit_for_bit():
    """The compiled pull, Jacobi sweeps and slope give numpy's float32 / float64 results to the
    bit (its block sums' order, its gradient and hypot), on grids from one cell wide up."""
    from aldpat.core.surface_check import _pull, _relax

    rng = np.random.default_rng(5)
    for case in range(60):
        rows, cols = (int(n) for n in rng.integers(1, 40, 2))
        value = rng.normal(0, 50, (rows, cols)).astype(np.float32)
        value[rng.random((rows, cols)) < 0.2] = 0.0
        weight = (rng.random((rows, cols)) < rng.random()).astype(np.float32)
        for new, old in zip(_pull(value, weight), _reference_pull(value, weight), strict=True):
            assert new.dtype == old.dtype and np.array_equal(new.view(np.uint8), old.view(np.uint8))
        new, old = _relax(value, weight >= 1, 4), _reference_relax(value, weight >= 1, 4)
        assert new.dtype == old.dtype and np.array_equal(new.view(np.uint8), old.view(np.uint8))
        if min(rows, cols) >= 2:
            z = np.round(rng.normal(0, 5, (rows, cols)).cumsum(axis=case % 2), 2)
            gy, gx = np.gradient(z, 0.75)
            assert np.array_equal(slope_of(z, 0.75).view(np.uint8), np.hypot(gx, gy).astype(np.float32).view(np.uint8))


def test_compiled_point_test_equals_the_numpy_form_bit_for_bit(monkeypatch):
    """The surface test built over cells runs as one compiled loop over the points, split among
    threads: every point's answer is the numpy form's, for scaled codes and float heights, points
    on the tolerance's edge, outside the grid, on grids one cell wide, with and without the slope
    term, on one thread and on several."""
    import aldpat.core.surface_check as module
    from aldpat.core.height_codes import FloatHeights, ScaledHeights

    rng = np.random.default_rng(23)
    for case in range(40):
        rows, cols = (int(n) for n in rng.integers(1, 30, 2))
        spec = CellGridSpec(100.0, 200.0, 0.75, rows, cols)
        heights = ScaledHeights(0.01, 250.0) if case % 2 else FloatHeights()
        z = np.round(plane(spec) + rng.normal(0, 0.5, (rows, cols)), 2)
        codes = np.round((z - 250.0) / 0.01).astype(np.int32) if case % 2 else z
        marks = np.where(rng.random((rows, cols)) < 0.6, 0, 4).astype(np.int16)
        marks.flat[0] = 0
        cells = type("Cells", (), {"codes": codes, "heights": heights, "spec": spec})()
        n = 3000
        x = rng.uniform(99.0, 100.0 + 0.75 * cols + 1.0, n)  # some past every edge
        y = rng.uniform(199.0, 200.0 + 0.75 * rows + 1.0, n)
        for slope_scalar in (0.0, 1.5, -0.2):  # a negative scalar narrows: no shortcut then
            test = module.SurfaceTest.build(cells, marks, threshold=0.3, slope_scalar=slope_scalar)
            corners = module._corners(test.surface.shape, spec, x, y)
            at = module._blend(test._at, corners)
            h = at + rng.uniform(-1.5, 1.5, n)
            h[:50] = at[:50] + 0.3  # on the edge of the tolerance without the slope term
            expected = test.test_in_numpy(x, y, h)
            assert 0 < expected.sum() < n
            for threads in ("1", "3"):
                monkeypatch.setenv("ALDPAT_THREADS", threads)
                monkeypatch.setattr(module, "_POINTS_PER_THREAD", 100)
                np.testing.assert_array_equal(test.test(x, y, h), expected)


def test_hypot32_is_float32_of_hypot_to_the_bit():
    """The slope's length as float32 by the root of the squares equals float32(hypot) everywhere,
    also where the length lies on a float32 rounding boundary (hypot decides there) and for
    lengths too small, too large or not numbers."""
    import math

    from aldpat.core.surface_check import hypot32

    rng = np.random.default_rng(3)
    gx = rng.normal(0, 1, 200_000) * 10.0 ** rng.integers(-8, 8, 200_000)
    gy = rng.normal(0, 1, 200_000) * 10.0 ** rng.integers(-8, 8, 200_000)
    # lengths exactly halfway between two float32 values, and a hair either side of it
    f = rng.uniform(0.01, 50, 2000).astype(np.float32)
    halfway = (f.astype(np.float64) + np.nextafter(f, np.float32(np.inf)).astype(np.float64)) / 2
    edge = np.concatenate([halfway, np.nextafter(halfway, 0), np.nextafter(halfway, np.inf)])
    gx = np.concatenate([gx, edge, edge * 0.6, [0.0, 1e-300, 1e200, np.inf, np.nan, -3.0]])
    gy = np.concatenate([gy, np.zeros(len(edge)), edge * 0.8, [0.0, 1e-300, 1e200, 1.0, 1.0, -4.0]])
    for a, b in zip(gx, gy, strict=True):
        with np.errstate(over="ignore"):  # 1e200's length is float32's infinity
            want, got = np.float32(math.hypot(a, b)), np.float32(hypot32(a, b))  # a float32's value, exactly
        assert want.tobytes() == got.tobytes() or (np.isnan(want) and np.isnan(got)), (a, b, want, got)
