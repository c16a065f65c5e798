"""Cluster-based progressive morphological filter (``cluster-pm``).

``MorphClusterFilter`` of the GAPM dissertation (Cui 2013, ch. 5 §5.2.2): the
progressive morphological filter of Zhang et al. (§5.1) with 1-D line windows, rows then
columns at every window (lines 3-18), where from ``cluster_window_size`` on the unfiltered
cells of each row/column are grouped into clusters before the opening (``MakeCluster``,
§5.2.1) and the runs of cells removed at that window that fall completely inside one
cluster are set back to ground afterwards (``UpdateMark``, cluster recovery of §5.2.3).

:func:`progressive_marks` is also the plain progressive filter (``cluster_window_size=None``)
used by the multi-pass filter (ch. 4 §4.2.5) and as the reference the cluster recovery is
compared with.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from aldpat.core.clusters import make_clusters, recover_runs
from aldpat.core.height_codes import Decode
from aldpat.core.progressive import Recovery, progressive_opening
from aldpat.filters.grid_stage import low_outlier_reach
from aldpat.filters.options import GroundParams, check_series
from aldpat.filters.registry import register_filter
from aldpat.params import param

log = logging.getLogger(__name__)

#: Rows (or columns) analysed together by the cluster recovery.
_BLOCK = 256

#: ``direction`` -> axes filtered at every window, in order (1: along x / rows, 0: along y).
AXES = {"x": (1,), "y": (0,), "xy": (1, 0)}
#: the spellings of ``direction`` before it took the x / y / xy of ``pm`` and ``tile``
OLD_DIRECTIONS = {"row": "x", "column": "y", "both": "xy"}


@dataclass(frozen=True)
class ClusterPmParams(GroundParams):
    window_series: tuple[int, ...] = param(
        (1, 2, 4, 8, 16, 24), "half window sizes, ascending (full window 2k+1)", unit="cells", ge=1, level="internal",
    )
    threshold_series: tuple[float, ...] = param(
        (0.3, 0.5, 0.8, 1.2, 2.0, 2.5), "elevation difference threshold of each window", unit="m", gt=0,
        level="internal",
    )
    cluster_window_size: int | None = param(
        8, "smallest half window with cluster analysis and recovery; none: plain PM", unit="cells", ge=1,
        level="internal",
    )
    cluster_threshold: float = param(
        2.0, "cluster threshold: largest height change per cell inside one cluster", unit="m", gt=0, level="internal",
    )
    gap_threshold: float | None = param(
        None, "slope per cell allowed across cells removed earlier; none: cluster_threshold "
        "(the dissertation uses one threshold for both and allows two)", unit="m", gt=0, level="internal",
    )
    recover_across_gaps: bool = param(
        False, "let a removed run whose side is a cell removed earlier be recovered too (the "
        "printed UpdateMark); by default its sides must be cells still standing", level="internal",
    )
    direction: str = param("xy", "filter along x (rows), y (columns) or both", choices=tuple(AXES),
                           renamed_values=OLD_DIRECTIONS, level="internal")

    def check(self) -> None:
        super().check()
        check_series(self.window_series, self.threshold_series, ("window_series", "threshold_series"))


def _along(axis: int, a: np.ndarray) -> np.ndarray:
    """``a`` with the filtering axis last (rows as the cluster functions expect)."""
    return a if axis == 1 else np.ascontiguousarray(a.T)


def progressive_marks(
    z: np.ndarray,
    windows: tuple[int, ...],
    thresholds: tuple[float, ...],
    *,
    axes: tuple[int, ...] = (1, 0),
    cluster_window_size: int | None = None,
    cluster_threshold: float = 1.0,
    gap_threshold: float | None = None,
    recover_across_gaps: bool = True,
    skip: np.ndarray | None = None,
    decode: Decode | None = None,
    in_place: bool = False,
) -> np.ndarray:
    """Mark matrix of the (cluster-based) progressive morphological filter (§5.2.2).

    Parameters
    ----------
    z : 2-D grid, empty cells already interpolated.
    windows, thresholds : half windows (cells) and their elevation thresholds, in the order
        they are applied.
    axes : 1 filters along rows (x), 0 along columns (y), in the given order at every window.
    cluster_window_size : first half window with cluster analysis; ``None`` for plain PM.
    cluster_threshold : slope threshold of ``MakeCluster`` (height per cell).
    gap_threshold : its slope threshold across filtered cells (default: the same).
    recover_across_gaps : whether a run may be recovered when a cell beside it was removed at
        an earlier window (see :func:`aldpat.core.clusters.recover_runs`).
    skip : cells that are never marked (they only support the openings).
    decode : ``z`` holds height codes (:mod:`aldpat.core.height_codes`) that it turns into heights.
    in_place : ``z`` (float64 heights) is the run's to open in place, instead of a copy.

    A cell keeps the first window that removed it. The surface handed to the next window is
    the opened one (line 17). Runs on :func:`aldpat.core.progressive.progressive_opening` in
    float64.
    """
    recovery = None
    if cluster_window_size is not None:
        recovery = _cluster_recovery(cluster_threshold, gap_threshold, recover_across_gaps)
    return progressive_opening(z, windows, thresholds, [("line", axis) for axis in axes], dtype=np.float64,
                               skip=skip, recover=lambda k: recovery if k >= (cluster_window_size or 0) else None,
                               decode=decode, in_place=in_place)


def _cluster_recovery(cluster_threshold: float, gap_threshold: float | None, recover_across_gaps: bool) -> Recovery:
    """The cluster recovery of §5.2.3 after one opening: clusters of the surface before it
    (line 7) among the cells still standing, and the removed runs that lie inside one cluster
    (``UpdateMark``). Rows (or columns) are independent, so blocks bound the temporaries."""
    def recover(before: np.ndarray, candidates: np.ndarray, removed: np.ndarray, axis: int) -> np.ndarray:
        reset = np.zeros(removed.shape, bool)
        n_lines = before.shape[0] if axis == 1 else before.shape[1]
        for a in range(0, n_lines, _BLOCK):
            part = slice(a, min(a + _BLOCK, n_lines))
            take = (part, slice(None)) if axis == 1 else (slice(None), part)
            zb, ub, rb = (_along(axis, arr[take]) for arr in (before, candidates, removed))
            ids = make_clusters(zb, ub, cluster_threshold, gap_threshold).ids
            back = recover_runs(rb, ids, None if recover_across_gaps else ub)
            reset[take] = back if axis == 1 else back.T
        return reset

    return recover


def cluster_pm_reach(p: ClusterPmParams) -> int:
    """The progressive openings; the cluster recovery along a row may reach farther."""
    return sum(2 * k for k in p.window_series) + low_outlier_reach(p)


@register_filter("cluster-pm", params=ClusterPmParams, reach=cluster_pm_reach, takes_codes=True,
                 summary="cluster-based progressive morphological filter (dissertation ch. 5)")
def cluster_pm(z: np.ndarray, empty: np.ndarray, params: ClusterPmParams, *, in_place: bool = False,
               decode: Decode | None = None) -> np.ndarray:
    """Mark matrix of ``MorphClusterFilter`` (dissertation ch. 5 §5.2.2); ``decode``: ``z`` holds
    height codes. ``z`` is never changed."""
    p = params
    return progressive_marks(
        z, p.window_series, p.threshold_series, axes=AXES[p.direction],
        cluster_window_size=p.cluster_window_size, cluster_threshold=p.cluster_threshold,
        gap_threshold=p.gap_threshold, recover_across_gaps=p.recover_across_gaps, decode=decode,
    )
