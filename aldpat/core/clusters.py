"""Row/column cluster analysis of unfiltered grid cells.

Implements ``MakeCluster`` and the cluster recovery (``UpdateMark``) of the GAPM dissertation
(Cui 2013, ch. 5 §5.2.1 and §5.2.3; reused in ch. 6 §6.2.1).

Every function works along ``axis=1`` (each row is one "row or column" of the dissertation) on
whole 2-D blocks at once: the scans of the printed algorithm become running maxima/minima of
indices (``np.maximum.accumulate``), so no Python loop touches a cell. To analyse columns pass
the transposed grid.

Cluster ids are 1, 2, 3 ... in scan order within each row; cells before the first unfiltered
cell of a row belong to no cluster (id 0). As in ``MakeCluster`` (line 9, ``last = i - 1``),
a cluster covers every cell from its first unfiltered cell up to the cell before the first
unfiltered cell of the next cluster, so filtered cells inside that range belong to it.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

log = logging.getLogger(__name__)


def prev_index(mask: np.ndarray, *, strict: bool = False) -> np.ndarray:
    """Column of the last true cell at or before each cell of its row (``-1`` if none).

    With ``strict`` the cell itself is excluded (last true cell strictly before it).
    """
    n = mask.shape[1]
    idx = np.where(mask, np.arange(n, dtype=np.int64), -1)
    np.maximum.accumulate(idx, axis=1, out=idx)
    if strict:
        idx[:, 1:] = idx[:, :-1].copy()
        idx[:, 0] = -1
    return idx


def next_index(mask: np.ndarray, *, strict: bool = False) -> np.ndarray:
    """Column of the first true cell at or after each cell of its row (``n`` if none)."""
    n = mask.shape[1]
    idx = np.where(mask, np.arange(n, dtype=np.int64), n)
    rev = idx[:, ::-1]
    np.minimum.accumulate(rev, axis=1, out=rev)
    if strict:
        idx[:, :-1] = idx[:, 1:].copy()
        idx[:, -1] = n
    return idx


def take_rows(values: np.ndarray, cols: np.ndarray, fill: float) -> np.ndarray:
    """``values[r, cols[r, c]]`` for every cell, ``fill`` where ``cols`` is out of the row."""
    n = values.shape[1]
    ok = (cols >= 0) & (cols < n)
    out = np.take_along_axis(values, np.clip(cols, 0, n - 1), axis=1)
    if not ok.all():
        out = np.where(ok, out, fill)
    return out


@dataclass(frozen=True)
class Clusters:
    """The clusters of every row of a block (``MakeCluster`` output, vectorized).

    ids:
        int64 cluster id of every cell (0 = before the first unfiltered cell of its row).
    start:
        bool, the cells that open a cluster.
    jump:
        at the cells opening a cluster after another, the elevation jump into it (``preDiff``
        of line 7); NaN elsewhere.
    """

    ids: np.ndarray
    start: np.ndarray
    jump: np.ndarray

    @property
    def pre_diff(self) -> np.ndarray:
        """Per cell, the jump into its cluster from the previous one (NaN for the first)."""
        return take_rows(self.jump, prev_index(self.start), np.nan)

    @property
    def post_diff(self) -> np.ndarray:
        """Per cell, ``postDiff`` of its cluster (line 10: minus the next cluster's preDiff)."""
        return -take_rows(self.jump, next_index(self.start, strict=True), np.nan)

    def cluster_diff(self) -> np.ndarray:
        """``clusterDiff``: the smaller absolute jump to a neighbouring cluster (§6.2.3 step 1).

        The first and last clusters have one neighbour only; that one is used. A row made of
        one cluster has none: +inf.
        """
        a = np.abs(self.pre_diff)
        b = np.abs(self.post_diff)
        out = np.fmin(a, b)
        return np.where(np.isnan(out), np.inf, out)


def make_clusters(z: np.ndarray, unfiltered: np.ndarray, threshold: float,
                  gap_threshold: float | None = None) -> Clusters:
    """Split the unfiltered cells of every row into clusters (``MakeCluster``, §5.2.1).

    Consecutive unfiltered cells stay in one cluster while the slope between them,
    ``|z_i - z_prev| / (i - prev)`` in height per cell, is at most ``threshold``; the same
    rule covers adjacent cells (gap 1: a height difference) and cells separated by filtered
    ones, as line 8 of the algorithm prescribes.

    The dissertation notes that "different thresholds could be given for the two scenarios if
    needed": ``gap_threshold`` is the slope allowed across filtered cells (default
    ``threshold``).

    Parameters
    ----------
    z : (rows, n) float array, current surface.
    unfiltered : (rows, n) bool array, cells still marked ground (0 or -7777 in Table 5-1).
    threshold : cluster threshold, height per cell.
    gap_threshold : slope threshold between unfiltered cells separated by filtered ones.
    """
    _rows, n = z.shape
    prev = prev_index(unfiltered, strict=True)
    zprev = take_rows(z, prev, np.nan)
    gap = np.arange(n, dtype=np.int64)[None, :] - prev
    jump = z - zprev  # preDiff of line 7
    with np.errstate(invalid="ignore"):
        limit = threshold * gap
        if gap_threshold is not None and gap_threshold != threshold:
            limit = np.where(gap > 1, gap_threshold * gap, limit)
        breaks = unfiltered & (prev >= 0) & (np.abs(jump) > limit)
    first = unfiltered & (prev < 0)
    start = breaks | first
    ids = np.cumsum(start, axis=1, dtype=np.int64)
    return Clusters(ids=ids, start=start, jump=np.where(breaks, jump, np.nan))


def recover_runs(removed: np.ndarray, ids: np.ndarray, candidates: np.ndarray | None = None) -> np.ndarray:
    """Cells of removed runs that fall completely inside one cluster (``UpdateMark``, §5.2.3).

    ``removed`` marks the cells removed at the current window. Each run of consecutive removed
    cells of a row is reset to ground when the whole run and the cells just before and after
    it (those that exist) belong to the same cluster: the run is then continuous with the
    candidate ground surface on both sides (a hilltop cut off by a large window, Fig. 5-6),
    not a separate surface such as a roof, whose cells form a cluster of their own.

    With ``candidates`` (the cells that were unfiltered before the current window) the cells
    just before and after the run must also be candidates themselves: a run whose side is a
    gap of cells removed earlier (trees along a wall) joins its cluster only through the
    slope across that gap, which a roof next to a row of trees passes as easily as terrain.

    Returns the bool mask of cells to reset to ground.
    """
    _rows, n = removed.shape
    flat = removed.ravel()
    pos = np.flatnonzero(flat)
    out = np.zeros(removed.shape, dtype=bool)
    if pos.size == 0:
        return out
    col = pos % n
    new_run = np.ones(pos.size, dtype=bool)
    new_run[1:] = (np.diff(pos) != 1) | (col[1:] == 0)
    starts = np.flatnonzero(new_run)
    ends = np.append(starts[1:], pos.size) - 1
    idflat = ids.ravel()
    run_ids = idflat[pos]
    lo = np.minimum.reduceat(run_ids, starts)
    hi = np.maximum.reduceat(run_ids, starts)
    ok = (lo == hi) & (lo > 0)
    first_pos, last_pos = pos[starts], pos[ends]
    has_left = col[starts] > 0
    has_right = col[ends] < n - 1
    left_id = np.where(has_left, idflat[np.maximum(first_pos - 1, 0)], lo)
    right_id = np.where(has_right, idflat[np.minimum(last_pos + 1, idflat.size - 1)], lo)
    ok &= (left_id == lo) & (right_id == lo)
    if candidates is not None:
        cand = candidates.ravel()
        ok &= ~has_left | cand[np.maximum(first_pos - 1, 0)]
        ok &= ~has_right | cand[np.minimum(last_pos + 1, idflat.size - 1)]
    keep = np.repeat(ok, ends - starts + 1)
    out.ravel()[pos[keep]] = True
    return out
