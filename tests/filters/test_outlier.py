"""Morphological outlier removal (dissertation §4.1.1)."""

from __future__ import annotations

import numpy as np

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
