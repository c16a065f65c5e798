"""Trend analysis: local minima of rows and the adaptive filtering threshold.

Implements ``MakeTrendArray`` and ``CalThreshArray`` of the GAPM dissertation
(Cui 2013, ch. 6 §6.2.2 trend analysis, §6.2.3 threshold estimation, §6.2.4
``CalThreshArray``).

Like :mod:`aldpat.core.clusters`, everything works along ``axis=1`` on whole 2-D blocks.
The per-point search for "the lowest and highest minima of the full window minima range"
becomes two running min/max filters (``scipy.ndimage.minimum_filter1d``) over keys that pack
the quantized height with the column, so the filters return both the extreme value and where
it is (the slope needs the distance between the two minima).
"""

from __future__ import annotations

import logging

import numpy as np

from aldpat._lazy import lazy_import
from aldpat.core.clusters import Clusters, next_index, prev_index, take_rows
from aldpat.core.compiled import compiled
from aldpat.core.morphology import within

ndimage = lazy_import("scipy.ndimage")

log = logging.getLogger(__name__)

_COL_BITS = 21  # rows up to 2 million cells long
_COL_MASK = (1 << _COL_BITS) - 1
_Z_SCALE = 1000.0  # heights quantized to the millimetre inside the keys
_BIG = 1 << 62  # exactly representable as a float (ndimage passes cval as a double)


def local_minima(z: np.ndarray, unfiltered: np.ndarray) -> np.ndarray:
    """Local minima of the unfiltered cells of every row (``MakeTrendArray``, §6.2.2).

    A cell is compared with its nearest unfiltered neighbours on the left and right. The
    dissertation's loose criterion: lower than one neighbour and not higher than the other
    (so a cell level with both is no minimum). A cell with one unfiltered neighbour only
    (the ends of the row) is a minimum when it is lower than that neighbour.
    """
    left = take_rows(z, prev_index(unfiltered, strict=True), np.nan)
    right = take_rows(z, next_index(unfiltered, strict=True), np.nan)
    hl, hr = ~np.isnan(left), ~np.isnan(right)
    with np.errstate(invalid="ignore"):
        both = ((z < left) & (z <= right)) | ((z <= left) & (z < right))
        only_left = hl & ~hr & (z < left)
        only_right = hr & ~hl & (z < right)
    return unfiltered & ((hl & hr & both) | only_left | only_right)


def _keys(z: np.ndarray, mask: np.ndarray, fill: int) -> np.ndarray:
    n = z.shape[1]
    if n > _COL_MASK:
        raise ValueError(f"row of {n} cells is longer than the trend analysis supports")
    zq = np.rint(np.where(mask, z, 0.0) * _Z_SCALE).astype(np.int64)
    key = (zq << _COL_BITS) | np.arange(n, dtype=np.int64)[None, :]
    return np.where(mask, key, fill)


def _decode(key: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return (key >> _COL_BITS).astype(np.float64) / _Z_SCALE, key & _COL_MASK


def threshold_array(
    z: np.ndarray,
    clusters: Clusters,
    minima: np.ndarray,
    half_window: int,
    cluster_threshold: float,
    *,
    max_divisor: float = 4.0,
    use_cluster_diff: bool = False,
) -> np.ndarray:
    """Per-cell filtering threshold of one window (``CalThreshArray``, §6.2.4 and §6.2.3).

    For cell ``i`` with window bounding cells ``L = max(i - k, 0)`` and ``R = min(i + k, n-1)``
    (``k`` the half window): the full window minima range runs from the last minimum at or
    before ``L`` (or the row start) to the first minimum at or after ``R`` (or the row end);
    ``low``/``high`` are its lowest and highest minima.

    * ``i``, ``L`` and ``R`` in one cluster: threshold = ``high - low`` (line 12);
    * otherwise: ``trendLift`` = slope between ``low`` and ``high`` times ``k`` (line 14), and,
      as the prose of §6.2.3 (steps 1 and 5) adds, no more than ``clusterDiff`` (the smaller
      jump to a neighbouring cluster) when ``use_cluster_diff``;
    * then at least ``cluster_threshold`` (line 16) and at most
      ``cluster_threshold * k / max_divisor`` (line 19; the dissertation's example divisor 4).

    A row without minima gets ``cluster_threshold``.
    """
    _rows, n = z.shape
    k = int(half_window)
    col = np.arange(n, dtype=np.int64)
    left_bound = np.maximum(col - k, 0)
    right_bound = np.minimum(col + k, n - 1)
    ids = clusters.ids
    same = (ids == ids[:, left_bound]) & (ids == ids[:, right_bound])

    lo_key = _keys(z, minima, _BIG)
    hi_key = _keys(z, minima, -_BIG)
    size = 2 * within(k, (n,)) + 1  # wider than the row is the whole row (cval outside)
    low = ndimage.minimum_filter1d(lo_key, size, axis=1, mode="constant", cval=_BIG)
    high = ndimage.maximum_filter1d(hi_key, size, axis=1, mode="constant", cval=-_BIG)
    # The range extends to the minima just outside the window (tight minima ranges of L, R).
    outer_left = prev_index(minima)[:, left_bound]
    outer_right = next_index(minima)[:, right_bound]
    for outer in (outer_left, outer_right):
        low = np.minimum(low, take_rows(lo_key, outer, _BIG))
        high = np.maximum(high, take_rows(hi_key, outer, -_BIG))
    found = low != _BIG
    zlow, clow = _decode(np.where(found, low, 0))
    zhigh, chigh = _decode(np.where(found, high, 0))
    rise = zhigh - zlow
    dist = np.maximum(np.abs(chigh - clow), 1)
    lift = rise / dist * k
    if use_cluster_diff:
        lift = np.minimum(lift, clusters.cluster_diff())
    thresh = np.where(same, rise, lift)
    thresh = np.where(found, thresh, cluster_threshold)
    np.maximum(thresh, cluster_threshold, out=thresh)
    np.minimum(thresh, cluster_threshold * k / max_divisor, out=thresh)
    return thresh


def candidate_thresholds(
    z: np.ndarray,
    unfiltered: np.ndarray,
    positions: np.ndarray,
    half_window: int,
    cluster_threshold: float,
    *,
    max_divisor: float = 4.0,
    use_cluster_diff: bool = False,
    break_slope: float | None = None,
    chunk: int = 1 << 17,
) -> np.ndarray:
    """:func:`threshold_array` for a few cells only (flat ``positions`` into ``z``).

    Same clusters (``MakeCluster``), minima (``MakeTrendArray``) and rules (``CalThreshArray``)
    as the dense version, computed on the sequence of unfiltered cells in row-major order:
    a cell's cluster is that of the last unfiltered cell at or before it in its row, and the
    minima of a window are a contiguous stretch of the sorted minima positions, found by
    binary search. The filter only needs thresholds where the height above the opening lies
    between the smallest and the largest threshold possible, a small share of the cells.
    """
    rows, n = z.shape
    k = int(half_window)
    ct = float(cluster_threshold)
    positions = np.asarray(positions, dtype=np.int64)
    out = np.empty(positions.size)
    if positions.size == 0:
        return out
    # rows are independent: analyse only the rows that hold a cell in question
    cand_rows = np.unique(positions // n)
    if cand_rows.size < 0.8 * rows:
        rank = np.searchsorted(cand_rows, positions // n)
        return candidate_thresholds(
            z[cand_rows], unfiltered[cand_rows], rank * n + positions % n, half_window,
            cluster_threshold, max_divisor=max_divisor, use_cluster_diff=use_cluster_diff,
            break_slope=break_slope, chunk=chunk,
        )
    zf = z.ravel()
    upos = np.flatnonzero(unfiltered.ravel())
    if upos.size == 0:
        out[:] = min(ct, ct * k / max_divisor)
        return out
    m = upos.size
    uz = zf[upos]
    # the first unfiltered cell of every row starts a new sequence (no division per cell)
    row_heads = np.searchsorted(upos, np.arange(rows, dtype=np.int64) * n)
    same_prev = np.ones(m, dtype=bool)
    same_prev[row_heads[row_heads < m]] = False
    same_prev[0] = False
    dz = np.empty(m)
    dz[0] = 0.0
    np.subtract(uz[1:], uz[:-1], out=dz[1:])
    gap = np.empty(m)
    gap[0] = 1.0
    np.subtract(upos[1:], upos[:-1], out=gap[1:], casting="unsafe")
    gap *= ct if break_slope is None else float(break_slope)
    breaks = same_prev & (np.abs(dz) > gap)
    del gap
    start = ~same_prev
    start |= breaks
    cluster = np.cumsum(start)
    cluster -= 1
    del start
    jump = np.full(int(cluster[-1]) + 2, np.nan)  # one spare: "next cluster" of the last
    jump[cluster[breaks]] = dz[breaks]
    del breaks
    # loose local minima of the unfiltered sequence (MakeTrendArray): dz[i] = z_i - z_{i-1}
    same_next = np.empty(m, dtype=bool)
    same_next[:-1] = same_prev[1:]
    same_next[-1] = False
    down = np.zeros(m, dtype=bool)   # lower than the left neighbour
    down_eq = np.zeros(m, dtype=bool)
    np.less(dz, 0.0, out=down)
    np.less_equal(dz, 0.0, out=down_eq)
    down &= same_prev
    down_eq &= same_prev
    up = np.zeros(m, dtype=bool)     # lower than the right neighbour: z_{i+1} - z_i > 0
    up_eq = np.zeros(m, dtype=bool)
    np.greater(dz[1:], 0.0, out=up[:-1])
    np.greater_equal(dz[1:], 0.0, out=up_eq[:-1])
    up &= same_next
    up_eq &= same_next
    is_min = (down & up_eq) | (down_eq & up) | (down & ~same_next) | (up & ~same_prev)
    if n > _COL_MASK:
        raise ValueError(f"row of {n} cells is longer than the trend analysis supports")
    mpos = upos[is_min]
    mkey = (np.rint(uz[is_min] * _Z_SCALE).astype(np.int64) << _COL_BITS) | (mpos % n)

    def cluster_at(q: np.ndarray, row: np.ndarray) -> np.ndarray:
        e = np.searchsorted(upos, q, side="right") - 1
        e0 = np.maximum(e, 0)
        ok = (e >= 0) & (upos[e0] >= row * n)
        return np.where(ok, cluster[e0], -1)

    for s in range(0, positions.size, chunk):
        p = positions[s:s + chunk]
        row, col = p // n, p % n
        base = row * n
        lq = base + np.maximum(col - k, 0)
        rq = base + np.minimum(col + k, n - 1)
        ci = cluster_at(p, row)
        same = (ci == cluster_at(lq, row)) & (ci == cluster_at(rq, row))
        thresh = np.full(p.size, ct)
        if mpos.size:
            row_first = np.searchsorted(mpos, base, side="left")
            row_last = np.searchsorted(mpos, base + n, side="left") - 1
            a = np.maximum(np.searchsorted(mpos, lq, side="right") - 1, row_first)
            b = np.minimum(np.searchsorted(mpos, rq, side="left"), row_last)
            found = a <= b
            width = int((b - a + 1)[found].max()) if found.any() else 0
            if width:
                idx = a[:, None] + np.arange(width)[None, :]
                valid = idx <= b[:, None]
                keys = mkey[np.minimum(idx, mpos.size - 1)]
                low = np.where(valid, keys, _BIG).min(axis=1)
                high = np.where(valid, keys, -_BIG).max(axis=1)
                zlow, clow = _decode(np.where(found, low, 0))
                zhigh, chigh = _decode(np.where(found, high, 0))
                rise = zhigh - zlow
                lift = rise / np.maximum(np.abs(chigh - clow), 1) * k
                if use_cluster_diff:
                    has = ci >= 0
                    cc = np.maximum(ci, 0)
                    pre = np.where(has, np.abs(jump[cc]), np.nan)
                    post = np.where(has, np.abs(jump[cc + 1]), np.nan)
                    cdiff = np.fmin(pre, post)
                    lift = np.minimum(lift, np.where(np.isnan(cdiff), np.inf, cdiff))
                thresh = np.where(found, np.where(same, rise, lift), ct)
        np.maximum(thresh, ct, out=thresh)
        np.minimum(thresh, ct * k / max_divisor, out=thresh)
        out[s:s + chunk] = thresh
    return out


def line_thresholds(z: np.ndarray, unfiltered: np.ndarray, positions: np.ndarray, half_window: int,
                    cluster_threshold: float, *, max_divisor: float = 4.0) -> np.ndarray:
    """:func:`candidate_thresholds` (without ``use_cluster_diff`` and ``break_slope``), compiled:
    the same values to the bit, from one scan of each row holding a cell in question.

    ``positions``: flat indices into ``z``, ascending. A row's clusters and minima are found in
    one pass over its cells; a cell's window minima range is a stretch of the row's minima found
    by binary search, as the vectorised version finds it; the arithmetic is the same, operation
    for operation. Runs without Python's lock (threads may share the work).
    """
    z = np.ascontiguousarray(z, dtype=np.float64)
    n = z.shape[1]
    if n > _COL_MASK:
        raise ValueError(f"row of {n} cells is longer than the trend analysis supports")
    positions = np.ascontiguousarray(positions, dtype=np.int64)
    if positions.size > 1 and (np.diff(positions) < 0).any():
        raise ValueError("positions must be ascending")
    out = np.empty(positions.size)
    _line_thresholds(z, np.ascontiguousarray(unfiltered, dtype=bool), positions, int(half_window),
                     float(cluster_threshold), float(max_divisor), out)
    return out


@compiled(nogil=True)
def _line_thresholds(z: np.ndarray, unfiltered: np.ndarray, positions: np.ndarray, k: int, ct: float,
                     max_divisor: float, out: np.ndarray) -> None:  # pragma: no cover - compiled
    n = z.shape[1]
    work = np.empty((3, n), np.int64)
    cols = positions % n
    s = 0
    while s < positions.size:
        row = positions[s] // n
        e = s
        while e < positions.size and positions[e] // n == row:
            e += 1
        row_thresholds(z[row], unfiltered[row], cols[s:e], k, ct, max_divisor, out[s:e], work)
        s = e


@compiled(nogil=True)
def row_thresholds(zr: np.ndarray, ur: np.ndarray, cols: np.ndarray, k: int, ct: float, max_divisor: float,
                   out: np.ndarray, work: np.ndarray) -> None:  # pragma: no cover - compiled
    """The adaptive thresholds of the cells ``cols`` of one row (heights ``zr``, unfiltered ``ur``)
    into ``out``, as :func:`candidate_thresholds` computes them; ``work``: ``(3, n)`` int64. For
    compiled callers (:mod:`aldpat.core.line_pass`)."""
    n = zr.shape[0]
    cluster_at, mpos, mkey = work[0], work[1], work[2]
    cap = ct * k / max_divisor
    # one scan: clusters (MakeCluster: a new one where the height changes by more than ct per
    # cell; a cell belongs to the cluster of the last unfiltered cell at or before it, -1: none)
    # and the loose local minima of the unfiltered sequence (MakeTrendArray), each unfiltered
    # cell judged once the next one is seen
    m = 0
    cluster = -1
    count = 0
    last = -1  # the last unfiltered cell, its height, and whether it lies below / not above the one before
    z_last = 0.0
    down = down_eq = False
    for c in range(n):
        if ur[c]:
            zc = zr[c]
            if m == 0:
                cluster += 1
            else:
                gap = float(c - last)
                gap *= ct
                dz = zc - z_last
                if abs(dz) > gap:
                    cluster += 1
                up = dz > 0.0  # the last cell is lower than this one
                up_eq = dz >= 0.0
                if (down and up_eq) or (down_eq and up) or (up and m == 1):
                    mpos[count] = last
                    mkey[count] = (np.int64(np.rint(z_last * _Z_SCALE)) << _COL_BITS) | last
                    count += 1
                down = dz < 0.0  # this cell is lower than the last
                down_eq = dz <= 0.0
            last = c
            z_last = zc
            m += 1
        cluster_at[c] = cluster
    if m > 1 and down:  # the last unfiltered cell, lower than the one before it
        mpos[count] = last
        mkey[count] = (np.int64(np.rint(z_last * _Z_SCALE)) << _COL_BITS) | last
        count += 1
    minima = mpos[:count]
    for q in range(cols.size):
        col = cols[q]
        lq = max(col - k, 0)
        rq = min(col + k, n - 1)
        ci = cluster_at[col]
        same = ci == cluster_at[lq] and ci == cluster_at[rq]
        thresh = ct
        # the window's minima range: from the last minimum at or before L to the first at or after R
        a = max(np.searchsorted(minima, lq, side="right") - 1, 0)
        b = min(np.searchsorted(minima, rq, side="left"), count - 1)
        if a <= b:
            low = mkey[a]
            high = mkey[a]
            for i in range(a + 1, b + 1):
                low = min(low, mkey[i])
                high = max(high, mkey[i])
            rise = np.float64(high >> _COL_BITS) / _Z_SCALE - np.float64(low >> _COL_BITS) / _Z_SCALE
            if same:
                thresh = rise
            else:
                thresh = rise / max(abs((high & _COL_MASK) - (low & _COL_MASK)), 1) * k
        out[q] = min(max(thresh, ct), cap)
