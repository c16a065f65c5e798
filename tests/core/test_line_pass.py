"""The compiled pass of gapm over a block of lines gives numpy's surface and marks, bit for bit."""

import math

import numpy as np
import pytest

from aldpat.core import line_pass
from aldpat.core.height_codes import ScaledHeights
from aldpat.filters.gapm import StepRules, adaptive_step, decision_band


def _terrain(rng, shape):
    """Codes of a rough slope with spikes, pits and plateaus (ties), as a LAS z would hold them."""
    z = rng.normal(0, 300, shape).cumsum(axis=1) + rng.normal(0, 300, shape).cumsum(axis=0)
    z[rng.random(shape) < 0.08] += rng.uniform(2_000, 12_000)
    z[rng.random(shape) < 0.03] -= rng.uniform(500, 3_000)
    z[:, 5:9] = z[:, 5:6]  # a run of equal cells
    return np.round(z).astype(np.int32)


@pytest.mark.parametrize("edges", ["nearest", "trend"])
@pytest.mark.parametrize("axis", [1, 0])
@pytest.mark.parametrize("codes", [True, False])
def test_a_pass_equals_numpys(edges, axis, codes):
    rng = np.random.default_rng(7 + axis + 2 * codes)
    heights = ScaledHeights(0.01, -12.5)
    rules = StepRules(init_thresh_bin=4, max_threshold_divisor=4.0, edges=edges)
    for shape, k, ct in (((13, 90), 1, 0.3), ((11, 70), 4, 1.0), ((9, 60), 8, 1.0), ((10, 23), 12, 2.0),
                         ((12, 5), 3, 1.0), ((7, 3), 2, 0.5), ((6, 40), 0, 0.5)):
        grid = _terrain(rng, shape)
        if not codes:
            grid = heights.decode(grid)
        mark = np.where(rng.random(shape) < 0.15, 1, 0).astype(np.int16)
        decode = heights.decode if codes else None
        lines = shape[0] if axis == 1 else shape[1]
        want_surface, want_mark = grid.copy(), mark.copy()
        removed, opened = adaptive_step(grid, mark == 0, k, ct, rules, axis=axis, decode=decode)
        want_surface[...] = opened
        want_mark[removed] = 9
        cap, floor = decision_band(k, ct, rules)
        adaptive = (ct, rules.max_threshold_divisor) if k >= rules.init_thresh_bin else None
        for first in range(0, lines, 5):  # blocks of lines, as the filter's threads take them
            line_pass.filter_lines(grid, mark, first, min(first + 5, lines), axis, k, 9, cap, floor, adaptive,
                                   edges == "trend", (heights.scale, heights.offset) if codes else None)
        assert np.array_equal(mark, want_mark), (shape, k)
        assert np.array_equal(grid.view(np.uint8), want_surface.view(np.uint8)), (shape, k)


def test_a_window_wider_than_the_lines_sees_the_whole_line():
    rng = np.random.default_rng(2)
    grid = _terrain(rng, (4, 30))
    rules = StepRules(init_thresh_bin=1000)
    want = adaptive_step(grid, np.ones(grid.shape, bool), 500, 1.0, rules, decode=ScaledHeights(0.01, 0.0).decode)
    mark = np.zeros(grid.shape, np.int16)
    line_pass.filter_lines(grid, mark, 0, 4, 1, 500, 3, 1.0, math.inf, None, False, (0.01, 0.0))
    assert np.array_equal(grid, want[1]) and np.array_equal(mark == 3, want[0])
