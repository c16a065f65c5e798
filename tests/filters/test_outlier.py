"""Morphological outlier removal (dissertation §4.1.1)."""

from __future__ import annotations

import numpy as np
import pytest

from aldpat.filters import ground_filter
from aldpat.filters.outlier import OutlierParams, outlier, outlier_marks


def test_spike_and_pit_removed_terrain_kept():
    r, c = np.mgrid[0:40, 0:40].astype(float)
    z = 0.2 * c + np.sin(r / 5.0)
    z[10, 10] += 30.0   # a bird
    z[25, 30] -= 20.0   # multipath
    m = outlier(z, np.zeros(z.shape, bool), OutlierParams())
    assert m[10, 10] == 1 and m[25, 30] == 1
    assert (m > 0).sum() == 2


def test_thresholds_can_be_switched_off():
    z = np.zeros((9, 9))
    z[4, 4] = 10.0
    z[1, 1] = -10.0
    assert outlier_marks(z, high_threshold=None)[4, 4] == 0
    assert outlier_marks(z, low_threshold=None)[1, 1] == 0
    assert outlier_marks(z, window=2, shape="disk").tolist() == (2 * (z != 0)).tolist()


def test_points_end_to_end():
    x, y = np.meshgrid(np.arange(0.5, 20), np.arange(0.5, 20))
    x, y = x.ravel(), y.ravel()
    z = np.full(x.size, 100.0)
    z[57] = 150.0
    r = ground_filter(x, y, z, "outlier", OutlierParams())
    assert not r.is_ground[57]
    assert r.is_ground.sum() == x.size - 1


@pytest.mark.parametrize("shape", ["square", "disk"])
def test_slabs_of_rows_and_height_codes_give_the_whole_grids_marks(shape, monkeypatch):
    """The test runs on slabs of rows with ``4 window`` rows of margin, on height codes: every
    mark is the one the whole grid of heights gives (slabs of 1 to 5 rows against one slab)."""
    from aldpat.core.height_codes import ScaledHeights
    from aldpat.filters import outlier as module

    heights = ScaledHeights(0.01, 300.0)
    rng = np.random.default_rng(2)
    codes = (np.cumsum(rng.integers(-30, 30, (47, 39)), axis=1) + 400).astype(np.int32)
    spikes = rng.random(codes.shape) < 0.06
    codes[spikes] += (rng.choice([-1, 1], spikes.sum()) * rng.integers(150, 2000, spikes.sum())).astype(np.int32)
    for window in (1, 2, 3):
        whole = outlier_marks(heights.decode(codes), window=window, shape=shape)
        assert (whole > 0).sum() > 10
        for rows in (1, 2, 5):
            monkeypatch.setattr(module, "rows_per_block", lambda cols, cells=0, _rows=rows: _rows)
            assert np.array_equal(outlier_marks(codes, window=window, shape=shape, decode=heights.decode), whole)
            assert np.array_equal(outlier_marks(heights.decode(codes), window=window, shape=shape), whole)
        monkeypatch.undo()
