"""The classes the grid stage gives points: the compiled loop against numpy's form of it."""

from __future__ import annotations

import numpy as np
import pytest

from aldpat.core.height_codes import FloatHeights, ScaledHeights
from aldpat.core.lowest_grid import CellGridSpec, flat_cell_indices
from aldpat.filters.classify import CellClasses, CellHeights
from aldpat.filters.marks import MARK_GROUND, MARK_INTERPOLATED, MARK_NON_GROUND


def numpy_classes(classes: CellClasses, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The marks of points as numpy finds them, array by array: a point that is not its cell's
    lowest is ground within the tolerance of the bilinear blend of the ground cells around it."""
    spec, heights = classes.cells.spec, classes.cells.heights
    flat_marks, codes = classes.marks.ravel(), classes.cells.codes.ravel()
    ci = flat_cell_indices(x, y, spec)
    cm = flat_marks[ci]
    pm = cm.astype(np.int32)
    other = np.flatnonzero((z != heights.decode(codes[ci])) | (cm == MARK_INTERPOLATED))
    xo, yo = x[other], y[other]
    fc = np.clip((xo - spec.x0) / spec.cell - 0.5, 0.0, spec.cols - 1.0)
    fr = np.clip((yo - spec.y0) / spec.cell - 0.5, 0.0, spec.rows - 1.0)
    c0 = np.minimum(fc.astype(np.int64), max(spec.cols - 2, 0))
    r0 = np.minimum(fr.astype(np.int64), max(spec.rows - 2, 0))
    tc, tr = fc - c0, fr - r0
    dc = 1 if spec.cols > 1 else 0
    dr = spec.cols if spec.rows > 1 else 0
    i00 = r0 * spec.cols + c0
    num, den = np.zeros(len(other)), np.zeros(len(other))
    for offset, wr, wc in ((0, 1.0 - tr, 1.0 - tc), (dc, 1.0 - tr, tc), (dr, tr, 1.0 - tc), (dr + dc, tr, tc)):
        ground = flat_marks[i00 + offset] == MARK_GROUND
        w = wr * wc * ground
        den += w
        height = heights.decode(codes[i00 + offset])
        height[~ground] = 0.0
        num += w * height
    with np.errstate(invalid="ignore", divide="ignore"):
        ok = z[other] - num / den <= classes.tolerance
    pm[other] = np.where(ok, MARK_GROUND, np.maximum(pm[other], MARK_NON_GROUND))
    return pm


def _scene(rng: np.random.Generator, rows: int, cols: int, scaled: bool, mark_dtype: type):
    """A grid of lowest heights (a tenth of the cells empty, a third removed) and points over it,
    some beyond its edges, some their cell's lowest, some sitting on cell centres and edges."""
    spec = CellGridSpec(100.0, 200.0, 1.5, rows, cols)
    marks = rng.choice(np.array([MARK_GROUND, MARK_GROUND, 3, 7, MARK_INTERPOLATED]), size=(rows, cols))
    marks = marks.astype(mark_dtype)
    marks.flat[0] = MARK_GROUND  # a 1 x 1 grid has ground too
    if scaled:
        heights = ScaledHeights(0.01, 50.0)
        codes = rng.integers(-500, 3000, size=(rows, cols)).astype(np.int32)
    else:
        heights = FloatHeights()
        codes = rng.uniform(40.0, 80.0, size=(rows, cols))
        codes[marks == MARK_INTERPOLATED] = np.nan
    n = 4000
    x = rng.uniform(spec.x0 - 2.0, spec.x0 + cols * spec.cell + 2.0, n)
    y = rng.uniform(spec.y0 - 2.0, spec.y0 + rows * spec.cell + 2.0, n)
    x[:200] = spec.x0 + (rng.integers(0, cols, 200) + rng.choice([0.0, 0.5, 1.0], 200)) * spec.cell
    y[:200] = spec.y0 + (rng.integers(0, rows, 200) + rng.choice([0.0, 0.5, 1.0], 200)) * spec.cell
    ci = flat_cell_indices(x, y, spec)
    own = heights.decode(codes.ravel()[ci])
    z = own + rng.choice([0.0, 0.0, 0.05, 0.3, 0.31, 2.0, -0.4], n)  # some the lowest, some on the limit
    z = np.where(np.isnan(z), 60.0, z)
    return CellClasses(CellHeights(spec, codes, heights), marks, tolerance=0.3), x, y, z


@pytest.mark.parametrize("scaled", [True, False])
@pytest.mark.parametrize("mark_dtype", [np.int16, np.int32])
@pytest.mark.parametrize("shape", [(23, 31), (1, 17), (19, 1), (1, 1), (2, 2)])
def test_compiled_classes_are_numpys_to_the_bit(scaled, mark_dtype, shape):
    rng = np.random.default_rng(sum(shape) + 7 * scaled)
    classes, x, y, z = _scene(rng, *shape, scaled, mark_dtype)
    marks, ground = classes.classify(x, y, z)
    expected = numpy_classes(classes, x, y, z)
    np.testing.assert_array_equal(marks, expected)
    np.testing.assert_array_equal(ground, expected == MARK_GROUND)
    # the scene exercises every branch: lowest points, points taken as ground above them, refused
    lowest = marks == classes.marks.ravel()[flat_cell_indices(x, y, classes.cells.spec)]
    assert lowest.any() and (marks == MARK_GROUND).any() and (marks == MARK_NON_GROUND).any()


def test_a_point_with_no_ground_cell_around_is_not_ground():
    spec = CellGridSpec(0.0, 0.0, 1.0, 2, 2)
    codes = np.array([[1000, 1000], [1000, 1000]], np.int32)
    classes = CellClasses(CellHeights(spec, codes, ScaledHeights(0.01, 0.0)),
                          np.full((2, 2), 5, np.int32), tolerance=0.5)
    marks, ground = classes.classify(np.array([0.5, 1.2]), np.array([0.5, 0.7]), np.array([10.0, 10.1]))
    assert marks.tolist() == [5, 5] and not ground.any()  # the lowest keeps its mark; the other has no surface


def test_a_point_within_the_tolerance_of_the_blend_is_ground():
    # four ground cells at 10, 12, 14, 16 m; a point at the grid's centre sees their mean, 13 m
    spec = CellGridSpec(0.0, 0.0, 2.0, 2, 2)
    codes = np.array([[1000, 1200], [1400, 1600]], np.int32)
    classes = CellClasses(CellHeights(spec, codes, ScaledHeights(0.01, 0.0)), np.zeros((2, 2), np.int32),
                          tolerance=0.5)
    marks, ground = classes.classify(np.array([2.0, 2.0]), np.array([2.0, 2.0]), np.array([13.5, 13.51]))
    assert ground.tolist() == [True, False]
    assert marks.tolist() == [MARK_GROUND, MARK_NON_GROUND]
