"""The one progressive-opening engine every progressive filter runs (pm, pm2d, pmcircle,
cluster-pm, multipass): first removal kept, skipped cells never marked, recovery after an opening,
and the surface precision an argument; along lines in float64 the compiled pass gives the numpy
loop's marks, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from aldpat.core import progressive
from aldpat.core.height_codes import ScaledHeights
from aldpat.core.progressive import progressive_opening


def test_building_removed_at_the_first_window_wider_than_it():
    # a profile along x: 5-cell wide building, 4 m high on flat ground
    z = np.zeros((3, 30))
    z[:, 10:15] = 4.0
    marks = progressive_opening(z, (1, 2, 4), (0.3, 0.9, 1.5), (("line", 1),))
    assert (marks[:, 10:15] == 4).all()  # full windows 3 and 5 fit on the roof: removed by 9
    assert (marks[:, :10] == 0).all() and (marks[:, 15:] == 0).all()
    # a first removal is never overwritten by a later window
    z[:, 20] = 4.0
    marks = progressive_opening(z, (1, 2, 4), (0.3, 0.9, 1.5), (("line", 1),))
    assert (marks[:, 20] == 1).all() and (marks[:, 10:15] == 4).all()


def test_skipped_cells_support_the_openings_but_are_never_marked():
    z = np.zeros((3, 30))
    z[:, 10:15] = 4.0
    skip = np.zeros(z.shape, bool)
    skip[:, 12] = True
    marks = progressive_opening(z, (1, 2, 4), (0.3, 0.9, 1.5), (("line", 1),), skip=skip)
    assert (marks[:, 12] == 0).all() and (marks[:, [10, 11, 13, 14]] == 4).all()


def test_recovered_cells_are_ground_and_the_opened_surface_goes_on():
    z = np.zeros((1, 40))
    z[0, 10:13] = 2.0  # removed by the first window wider than 3 cells (k = 2)
    calls = []

    def recover(k):
        def back(before, candidates, removed, axis):
            calls.append((k, int(removed.sum())))
            return removed if k == 2 else np.zeros_like(removed)  # set everything back at k = 2

        return back

    marks = progressive_opening(z, (1, 2, 4), (0.3, 0.9, 1.5), (("line", 1),), recover=recover)
    # set back at k = 2; the surface opened at k = 2 goes on (Cui 2013, §5.2.2 line 17), so no
    # later window sees the block again
    assert calls == [(1, 0), (2, 3), (4, 0)]
    assert (marks == 0).all()
    plain = progressive_opening(z, (1, 2, 4), (0.3, 0.9, 1.5), (("line", 1),))
    assert (plain[0, 10:13] == 2).all()


def test_precision_decides_a_height_equal_to_the_threshold():
    # 290.25 - 289.95 is 0.3 in decimals; rounding decides a tie, and differently in each
    # precision (float64: 0.30000000000001 > 0.3, removed; float32: not above, kept), which is
    # why the precision is an argument of the one loop and each filter states its own
    z = np.full((1, 9), 289.95)
    z[0, 4] = 290.25
    assert progressive_opening(z, (1,), (0.3,), (("line", 1),), dtype=np.float64)[0, 4] == 1
    assert progressive_opening(z, (1,), (0.3,), (("line", 1),), dtype=np.float32)[0, 4] == 0


def _codes(rng: np.random.Generator, shape: tuple[int, int]) -> np.ndarray:
    """Codes of a rough slope with buildings, pits and runs of equal cells (ties)."""
    z = rng.normal(0, 40, shape).cumsum(axis=1) + rng.normal(0, 40, shape).cumsum(axis=0)
    z[rng.random(shape) < 0.1] += rng.uniform(300, 1_500)
    z[rng.random(shape) < 0.03] -= rng.uniform(100, 600)
    z[:, 7:12] = z[:, 7:8]
    return np.round(z).astype(np.int32)


@pytest.mark.parametrize("axes", [(1, 0), (0,), (1,)])
@pytest.mark.parametrize("codes", [True, False])
@pytest.mark.parametrize("with_skip", [True, False])
def test_compiled_line_passes_give_the_numpy_loops_marks(monkeypatch, axes, codes, with_skip):
    rng = np.random.default_rng(3 + len(axes) + 2 * codes + 4 * with_skip)
    heights = ScaledHeights(0.01, 250.0)
    windows, thresholds = (1, 2, 4, 8, 16), (0.3, 0.5, 1.0, 2.0, 3.0)
    passes = [("line", axis) for axis in axes]
    for shape in ((37, 53), (70, 9), (5, 41)):
        grid = _codes(rng, shape)
        z = grid if codes else heights.decode(grid)
        decode = heights.decode if codes else None
        skip = rng.random(shape) < 0.2 if with_skip else None
        before = z.copy()
        got = progressive.progressive_opening(z, windows, thresholds, passes, dtype=np.float64, skip=skip,
                                              decode=decode)
        assert np.array_equal(z, before)  # the caller's grid is not opened
        with monkeypatch.context() as m:
            m.setattr(progressive, "_compiled_lines", lambda *args: None)
            want = progressive.progressive_opening(z, windows, thresholds, passes, dtype=np.float64, skip=skip,
                                                   decode=decode)
        assert got.dtype == want.dtype and np.array_equal(got, want), shape
        assert (got > 0).any() and (skip is None or not got[skip].any())


def test_heights_with_nan_take_the_numpy_loop():
    z = np.arange(60.0).reshape(6, 10)
    z[2, 3] = np.nan
    assert progressive._compiled_lines(z, (1,), (0.5,), (1,), None, None, False) is None
