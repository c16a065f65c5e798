"""Cluster-based progressive morphological filter (dissertation ch. 5)."""

from __future__ import annotations

import numpy as np
import pytest
from terrain_scenes import errors, scene

from aldpat.errors import ParamError
from aldpat.filters.cluster_pm import ClusterPmParams, cluster_pm, progressive_marks


def ridge_scene():
    """A smooth ridge (slope below 0.8 m per cell) next to a flat-roofed building."""
    _r, c = np.mgrid[0:60, 0:200].astype(float)
    z = 12.0 * np.exp(-((c - 60.0) / 18.0) ** 2)
    obj = np.zeros(z.shape, bool)
    obj[20:40, 140:160] = True
    z[obj] = 9.0
    return z, obj


def test_plain_progressive_filter_by_hand():
    z = np.zeros((1, 20))
    z[0, 5] = 1.0            # removed by window 1 (threshold 0.5)
    z[0, 10:13] = 0.7        # 3 cells: survive window 1 (opening keeps them), removed by window 2
    m = progressive_marks(z, (1, 2), (0.5, 0.5), axes=(1,))
    assert m[0, 5] == 1 and (m[0, 10:13] == 2).all() and m.sum() == 1 + 6


def test_cluster_recovery_saves_the_ridge_and_still_removes_the_building():
    z, obj = ridge_scene()
    empty = np.zeros(z.shape, bool)
    base = {"window_series": (1, 2, 4, 8, 16, 24), "threshold_series": (0.3, 0.5, 0.8, 1.0, 1.5, 2.0)}
    plain = cluster_pm(z, empty, ClusterPmParams(cluster_window_size=None, **base))
    clustered = cluster_pm(z, empty, ClusterPmParams(cluster_window_size=4, cluster_threshold=1.0, **base))
    t1_plain, t2_plain = errors(plain, obj)
    t1, t2 = errors(clustered, obj)
    assert t1_plain > 5.0          # the large windows cut the ridge top
    assert t1 < 0.5                # the clusters give it back
    assert t2 == 0.0 and t2_plain == 0.0


def test_scene_not_worse_than_plain_pm():
    z, obj = scene(seed=3)
    empty = np.zeros(z.shape, bool)
    plain = cluster_pm(z, empty, ClusterPmParams(cluster_window_size=None))
    clustered = cluster_pm(z, empty, ClusterPmParams())
    assert sum(errors(clustered, obj)) <= sum(errors(plain, obj))


def test_series_lengths_checked():
    with pytest.raises(ParamError, match="threshold_series"):
        cluster_pm(np.zeros((4, 4)), np.zeros((4, 4), bool), ClusterPmParams(threshold_series=(1.0,)))
