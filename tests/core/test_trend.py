"""Trend analysis and adaptive thresholds (dissertation ch. 6 §6.2.2-6.2.4)."""

from __future__ import annotations

import numpy as np
import pytest

from aldpat.core.clusters import make_clusters
from aldpat.core.trend import local_minima, threshold_array


def test_loose_minima_criterion():
    z = np.array([[3.0, 1.0, 1.0, 2.0, 2.0, 2.0, 0.5, 4.0]])
    m = local_minima(z, np.ones_like(z, bool))
    # cell 1 and 2: equal to one neighbour, lower than the other -> both minima;
    # cell 4 level with both neighbours -> not; cell 6 strict minimum; the ends compare
    # with their single neighbour
    assert m.tolist() == [[False, True, True, False, False, False, True, False]]


def test_minima_skip_filtered_cells():
    z = np.array([[1.0, 0.0, 2.0, 9.0, 3.0]])
    unf = np.array([[True, False, True, False, True]])
    m = local_minima(z, unf)
    assert m.tolist() == [[True, False, False, False, False]]


def reference_thresholds(z, unf, k, ct, divisor, use_cluster_diff):
    """CalThreshArray for one row, per point, as printed plus §6.2.3 steps 1 and 5."""
    n = len(z)
    c = make_clusters(z[None], unf[None], ct)
    ids = c.ids[0]
    cdiff = c.cluster_diff()[0]
    minima = np.flatnonzero(local_minima(z[None], unf[None])[0])
    out = np.empty(n)
    for i in range(n):
        left, right = max(i - k, 0), min(i + k, n - 1)
        before = minima[minima <= left]
        after = minima[minima >= right]
        lo_r = before[-1] if before.size else 0
        hi_r = after[0] if after.size else n - 1
        inside = minima[(minima >= lo_r) & (minima <= hi_r)]
        if inside.size == 0:
            t = ct
        else:
            vals = np.round(z[inside] * 1000) / 1000
            ilow = inside[np.argmin(vals)]
            ihigh = inside[len(vals) - 1 - np.argmax(vals[::-1])]
            rise = vals.max() - vals.min()
            if ids[i] == ids[left] == ids[right]:
                t = rise
            else:
                t = rise / max(abs(ihigh - ilow), 1) * k
                if use_cluster_diff:
                    t = min(t, cdiff[i])
        t = max(t, ct)
        t = min(t, ct * k / divisor)
        out[i] = t
    return out


@pytest.mark.parametrize("k", [4, 8, 16])
@pytest.mark.parametrize("use_cluster_diff", [False, True])
def test_thresholds_match_a_per_point_reference(k, use_cluster_diff):
    rng = np.random.default_rng(k)
    rows, n = 12, 70
    x = np.arange(n)
    z = 0.15 * x[None, :] + rng.normal(0, 0.4, (rows, n))
    z[:, 30:40] += 6.0  # a roof: its own cluster
    unf = rng.random((rows, n)) > 0.2
    c = make_clusters(z, unf, 1.0)
    minima = local_minima(z, unf)
    got = threshold_array(z, c, minima, k, 1.0, max_divisor=4.0, use_cluster_diff=use_cluster_diff)
    want = np.array([reference_thresholds(z[r], unf[r], k, 1.0, 4.0, use_cluster_diff) for r in range(rows)])
    np.testing.assert_allclose(got, want, atol=1e-9)


def test_floor_and_cap():
    i = np.arange(41.0)
    z = (i + 1.5 * (i % 2 == 0))[None, :]  # steep saw-tooth ramp, minima at odd cells
    unf = np.ones_like(z, bool)
    c = make_clusters(z, unf, 2.0)  # 2.5 m steps split it into many clusters
    t = threshold_array(z, c, local_minima(z, unf), 8, 2.0, max_divisor=4.0, use_cluster_diff=False)
    np.testing.assert_allclose(t, 2.0 * 8 / 4)  # trend lift 1 m/cell x 8 = 8 m, capped at 4
    flat = np.zeros((1, 30))
    c = make_clusters(flat, np.ones_like(flat, bool), 0.5)
    t = threshold_array(flat, c, local_minima(flat, np.ones_like(flat, bool)), 8, 0.5)
    np.testing.assert_allclose(t, 0.5)  # no minima on a flat row: the cluster threshold


@pytest.mark.parametrize("seed", range(6))
def test_candidate_thresholds_equal_the_dense_ones(seed):
    from aldpat.core.trend import candidate_thresholds

    rng = np.random.default_rng(seed)
    rows, n = int(rng.integers(1, 25)), int(rng.integers(2, 80))
    z = np.cumsum(rng.normal(0, 0.8, (rows, n)), axis=1)
    z[:, n // 3: n // 2] += 5.0
    unf = rng.random((rows, n)) > rng.uniform(0.0, 0.9)
    for k in (1, 4, 8, 20):
        for ct in (0.5, 2.0):
            for ucd in (False, True):
                dense = threshold_array(z, make_clusters(z, unf, ct), local_minima(z, unf), k, ct,
                                        use_cluster_diff=ucd)
                pos = rng.permutation(z.size)[: max(1, z.size // 2)]
                sparse = candidate_thresholds(z, unf, pos, k, ct, use_cluster_diff=ucd)
                np.testing.assert_allclose(sparse, dense.ravel()[pos])


def test_candidate_thresholds_on_a_few_rows_only():
    from aldpat.core.trend import candidate_thresholds

    rng = np.random.default_rng(11)
    z = np.cumsum(rng.normal(0, 0.8, (40, 50)), axis=1)
    unf = rng.random(z.shape) > 0.3
    dense = threshold_array(z, make_clusters(z, unf, 1.0), local_minima(z, unf), 8, 1.0)
    pos = np.array([3 * 50 + 7, 3 * 50 + 40, 31 * 50 + 0, 39 * 50 + 49])  # rows 3, 31, 39
    np.testing.assert_allclose(candidate_thresholds(z, unf, pos, 8, 1.0), dense.ravel()[pos])


@pytest.mark.parametrize("seed", range(4))
def test_compiled_line_thresholds_are_the_vectorised_ones_to_the_bit(seed):
    from aldpat.core.trend import candidate_thresholds, line_thresholds

    rng = np.random.default_rng(seed)
    for _ in range(40):
        rows, n = int(rng.integers(1, 6)), int(rng.integers(1, 60))
        # heights to the centimetre or metre: ties and level runs, as LAS heights give them
        z = np.round(rng.normal(0, 1.5, (rows, n)).cumsum(axis=1), int(rng.integers(0, 3)))
        unf = rng.random((rows, n)) > rng.uniform(0, 0.6)
        k, ct = int(rng.integers(1, 25)), float(rng.choice([0.3, 0.5, 1.0, 2.0]))
        pos = np.flatnonzero(unf & (rng.random((rows, n)) < 0.5))
        want = candidate_thresholds(z, unf, pos, k, ct, max_divisor=3.0)
        got = line_thresholds(z, unf, pos, k, ct, max_divisor=3.0)
        assert np.array_equal(got.view(np.int64), want.view(np.int64))
