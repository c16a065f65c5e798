"""Multi-pass morphological filter with priority boundary interpolation (dissertation ch. 4)."""

from __future__ import annotations

import numpy as np

from aldpat.filters import ground_filter
from aldpat.filters.cluster_pm import ClusterPmParams, progressive_marks
from aldpat.filters.multipass import MultipassParams, multipass


def test_flat_ground_with_a_building_is_left_alone_by_the_second_pass():
    z = np.zeros((60, 60))
    z[20:30, 20:30] = 8.0
    marks = multipass(z, np.zeros(z.shape, bool), MultipassParams())
    assert (marks[20:30, 20:30] > 0).all()
    assert (marks[20:30, 20:30] <= 8).all()  # removed in the first pass (window <= 8)
    assert marks.sum() == marks[20:30, 20:30].sum()


def test_second_pass_removes_a_remnant_on_the_priority_surface():
    # a roof remnant left standing inside a removed ring; nearest-neighbour values of the
    # ring would widen it past the window, the priority interpolation does not
    z = np.zeros((80, 80))
    ring = np.zeros(z.shape, bool)
    ring[20:60, 20:60] = True
    core = np.zeros(z.shape, bool)
    core[33:47, 33:47] = True  # 14 cells: narrower than the 17-cell window of half window 8
    z[ring] = 9.0
    z[core] = 10.0
    first = np.where(ring & ~core, 4, 0).astype(np.int32)  # pretend pass 1 removed the ring
    surface = np.where(first > 0, np.nan, z)
    from aldpat.core.lowest_grid import fill_nearest
    from aldpat.core.priority_fill import priority_fill

    nearest = fill_nearest(surface, first > 0)
    prio = priority_fill(nearest, first > 0)
    win, thr = (8, 4, 2, 1), (2.0,) * 4
    assert not (progressive_marks(nearest, win, thr, skip=first > 0)[core] > 0).any()
    assert (progressive_marks(prio, win, thr, skip=first > 0)[core] > 0).all()


def test_removes_remnants_a_capped_pm_leaves_on_samp24(samp24):
    """ISPRS sample 24: fewer objects accepted as ground than the same first pass alone."""
    a = np.loadtxt(samp24)
    x, y, z, obj = a[:, 0], a[:, 1], a[:, 2], a[:, 3] == 1
    p = MultipassParams()
    pm = ClusterPmParams(window_series=p.window_series, threshold_series=p.threshold_series,
                         cluster_window_size=None)
    capped = ground_filter(x, y, z, "cluster-pm", pm).is_ground
    multi = ground_filter(x, y, z, "multipass", p).is_ground
    accepted_capped = int((capped & obj).sum())
    accepted_multi = int((multi & obj).sum())
    assert accepted_multi < 0.7 * accepted_capped
