"""Cluster analysis of rows (dissertation ch. 5 §5.2.1 MakeCluster, §5.2.3 recovery)."""

from __future__ import annotations

import numpy as np
import pytest

from aldpat.core.clusters import make_clusters, next_index, prev_index, recover_runs


def reference_clusters(z, unfiltered, threshold):
    """MakeCluster as printed (one row, Python loop): cluster id of every cell."""
    n = len(z)
    ids = np.zeros(n, int)
    idx = np.flatnonzero(unfiltered)
    if idx.size == 0:
        return ids
    j = 1
    prev = idx[0]
    ids[prev:] = j
    for i in range(prev + 1, n):
        if unfiltered[i]:
            if abs((z[i] - z[prev]) / (i - prev)) > threshold:
                j += 1
                ids[i:] = j
            prev = i
    return ids


def test_prev_next_index():
    m = np.array([[False, True, False, False, True, False]])
    assert prev_index(m).tolist() == [[-1, 1, 1, 1, 4, 4]]
    assert prev_index(m, strict=True).tolist() == [[-1, -1, 1, 1, 1, 4]]
    assert next_index(m).tolist() == [[1, 1, 4, 4, 4, 6]]
    assert next_index(m, strict=True).tolist() == [[1, 4, 4, 4, 6, 6]]


def test_hand_computed_row():
    z = np.array([[0.0, 0.1, 0.2, 5.0, 5.1, 0.3, 0.2]])
    c = make_clusters(z, np.ones_like(z, bool), 1.0)
    assert c.ids.tolist() == [[1, 1, 1, 2, 2, 3, 3]]
    # jumps: into cluster 2 +4.8, into cluster 3 -4.8
    np.testing.assert_allclose(c.pre_diff[0, 3:5], 4.8)
    np.testing.assert_allclose(c.post_diff[0, 3:5], 4.8)  # postDiff = -preDiff of the next
    assert np.isnan(c.pre_diff[0, 0]) and np.isnan(c.post_diff[0, 6])
    np.testing.assert_allclose(c.cluster_diff()[0], [4.8, 4.8, 4.8, 4.8, 4.8, 4.8, 4.8])


def test_gap_uses_slope_and_filtered_cells_join_the_previous_cluster():
    z = np.array([[0.0, 9.0, 9.0, 1.5, 1.6, 0.0]])
    unf = np.array([[True, False, False, True, True, False]])
    c = make_clusters(z, unf, 1.0)
    # 1.5 m over 3 cells = 0.5 per cell: same cluster; filtered cells belong to it too
    assert c.ids.tolist() == [[1, 1, 1, 1, 1, 1]]
    c = make_clusters(z, unf, 0.4)
    assert c.ids.tolist() == [[1, 1, 1, 2, 2, 2]]


def test_cells_before_the_first_unfiltered_cell_have_no_cluster():
    z = np.zeros((2, 4))
    unf = np.array([[False, False, True, True], [False, False, False, False]])
    c = make_clusters(z, unf, 1.0)
    assert c.ids.tolist() == [[0, 0, 1, 1], [0, 0, 0, 0]]
    assert np.isinf(c.cluster_diff()[0, 2])


@pytest.mark.parametrize("threshold", [0.3, 1.0, 2.5])
def test_matches_the_printed_algorithm_on_random_rows(threshold):
    rng = np.random.default_rng(5)
    z = np.cumsum(rng.normal(0, 1.0, (40, 60)), axis=1)
    unf = rng.random((40, 60)) > 0.3
    got = make_clusters(z, unf, threshold).ids
    want = np.array([reference_clusters(z[r], unf[r], threshold) for r in range(40)])
    np.testing.assert_array_equal(got, want)


def test_recovery_keeps_a_cut_hilltop_and_not_a_roof():
    # ids: ground 1 | roof 2 | ground 3 ; and a hill inside cluster 4 of the second row
    ids = np.array([[1, 1, 2, 2, 2, 3, 3], [4, 4, 4, 4, 4, 4, 4]])
    removed = np.array([[0, 0, 1, 1, 1, 0, 0], [0, 0, 1, 1, 1, 0, 0]], bool)
    reset = recover_runs(removed, ids)
    assert reset.tolist() == [[False] * 7, [False, False, True, True, True, False, False]]


def test_recovery_run_straddling_clusters_and_at_row_ends():
    ids = np.array([[1, 1, 1, 2, 2, 2], [1, 1, 1, 1, 2, 2], [1, 1, 1, 1, 1, 1]])
    removed = np.array([[0, 1, 1, 1, 0, 0], [1, 1, 0, 0, 0, 0], [0, 0, 0, 0, 1, 1]], bool)
    reset = recover_runs(removed, ids)
    assert not reset[0].any()                      # straddles clusters 1 and 2
    assert reset[1].tolist() == [True, True, False, False, False, False]  # row start, right side same
    assert reset[2].tolist() == [False, False, False, False, True, True]  # row end, left side same


def test_recovery_of_nothing():
    assert not recover_runs(np.zeros((3, 4), bool), np.ones((3, 4), int)).any()


def test_recovery_can_require_standing_cells_beside_the_run():
    ids = np.array([[1, 1, 1, 1, 1, 1, 1]])
    removed = np.array([[0, 0, 1, 1, 0, 0, 0]], bool)
    standing = np.array([[1, 0, 1, 1, 1, 1, 1]], bool)  # the cell left of the run went earlier
    assert recover_runs(removed, ids)[0, 2:4].all()
    assert not recover_runs(removed, ids, standing).any()
    assert recover_runs(removed, ids, np.ones_like(standing))[0, 2:4].all()


def test_gap_threshold_applies_across_filtered_cells_only():
    z = np.array([[0.0, 9.0, 9.0, 1.5, 2.4]])
    unf = np.array([[True, False, False, True, True]])
    # across the gap 1.5 m / 3 cells = 0.5 per cell; adjacent step 0.9
    assert make_clusters(z, unf, 1.0, gap_threshold=0.4).ids.tolist() == [[1, 1, 1, 2, 2]]
    assert make_clusters(z, unf, 0.8, gap_threshold=1.0).ids.tolist() == [[1, 1, 1, 1, 2]]
