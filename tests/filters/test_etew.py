"""Elevation threshold with expanding window (manual appendix ETEW, eqs. 1-3)."""

import numpy as np
import pytest

from aldpat.errors import ParamError
from aldpat.filters.etew import ETEWParams, etew


def _run(z, **kw):
    return etew(z, np.zeros(z.shape, bool), ETEWParams(**kw))


def test_block_removed_ring_by_ring():
    # 3 x 3 block 5 m high: window 3x3 (k=1, threshold 0.3*2*1 = 0.6 m) reaches the ground from
    # the edge cells; the centre needs the 5x5 window (k=2)
    z = np.zeros((11, 11))
    z[4:7, 4:7] = 5.0
    m = _run(z, slope=0.3, loop_times=3)
    expect = np.zeros((11, 11), int)
    expect[4:7, 4:7] = 1
    expect[5, 5] = 2
    assert m.tolist() == expect.tolist()


def test_threshold_grows_with_the_window():
    # a step of 1.0 m: above 0.6 (k=1) but the 1.2 m threshold of k=2 would keep it
    z = np.zeros((9, 9))
    z[4, 4] = 1.0
    assert _run(z, slope=0.3, loop_times=1)[4, 4] == 1
    z[4, 4] = 0.5
    assert _run(z, slope=0.3, loop_times=5).max() == 0


@pytest.mark.parametrize("direction", [(1, 0), (0, 1), (1, 1)])
def test_slopes_below_the_slope_parameter_are_kept(direction):
    r, c = np.mgrid[0:60, 0:60]
    z = 0.25 * (r * direction[0] + c * direction[1]) / np.hypot(*direction)
    assert _run(z, slope=0.3, loop_times=5).max() == 0


def test_elevation_limits_mark_one():
    z = np.array([[1.0, 2.0, 3.0, 100.0, -50.0]])
    m = _run(z, slope=100.0, min_z=0.0, max_z=50.0)
    assert m.tolist() == [[0, 0, 0, 1, 1]]
    with pytest.raises(ParamError, match="min_z"):
        _run(z, min_z=5.0, max_z=1.0)


def test_huge_loop_times_on_a_small_grid():
    z = np.zeros((4, 4))
    z[0, 0] = 9.0
    assert _run(z, loop_times=30)[0, 0] == 1
