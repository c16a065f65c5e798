"""Multi-pass progressive morphological filter with priority boundary interpolation.

The multi-pass filter of the GAPM dissertation (Cui 2013, ch. 4 §4.2.5):

1. ``MorphFilter``: progressive morphological filtering with windows kept small enough not
   to cut the terrain (ascending series, the first pass);
2. ``PQBoundInterp``: the cells removed by pass 1 (and the cells that had no point) are
   re-interpolated from their lowest boundary upward (§4.2.4,
   :func:`aldpat.core.priority_fill.priority_fill`), so remnants of large objects are no
   longer widened by their own heights as nearest-neighbour filling widens them (Fig. 4-9);
3. ``MorphFilter`` again on that surface with a descending series and a larger threshold
   (the text: windows 20, 16, 8, 4, 2, 1 and 2.0 m), removing the remnants. Steps 2-3 may be
   repeated ("until the remaining ... features are completely removed").

Two departures, both measured on the ISPRS samples (bench/bench_gapm.py): cells that never
had a point are not part of the interpolated sets (they take the nearest standing cell), and
the interpolation may rise with the distance from the boundary cell it started from
(``fill_rise``); with neither, the sets of sparse data join into sheets flooded at their lowest
corner and the second pass cuts the terrain beside them. The filter suits flat urban scenes
with large buildings (it lowers the objects accepted as ground on every sample) and costs
terrain on slopes.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from aldpat.core.height_codes import Decode
from aldpat.core.lowest_grid import fill_nearest
from aldpat.core.priority_fill import priority_fill
from aldpat.core.progressive import heights_grid
from aldpat.errors import ParamError
from aldpat.filters.cluster_pm import AXES, OLD_DIRECTIONS, progressive_marks
from aldpat.filters.grid_stage import low_outlier_reach
from aldpat.filters.options import GroundParams, check_series
from aldpat.filters.registry import register_filter
from aldpat.params import param

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class MultipassParams(GroundParams):
    window_series: tuple[int, ...] = param(
        (1, 2, 4, 8, 16, 20), "first pass half windows, ascending (keep the largest small enough "
        "not to cut terrain)", unit="cells", ge=1, level="internal",
    )
    threshold_series: tuple[float, ...] = param(
        (0.4, 0.48, 0.56, 1.0, 1.6, 2.0), "first pass threshold of each window", unit="m", gt=0, level="internal",
    )
    second_window_series: tuple[int, ...] = param(
        (20, 16, 8, 4, 2, 1), "second pass half windows, largest first", unit="cells", ge=1, level="internal",
    )
    second_threshold_series: tuple[float, ...] = param(
        (2.0, 2.0, 2.0, 2.0, 2.0, 2.0), "second pass threshold of each window", unit="m", gt=0, level="internal",
    )
    passes: int = param(1, "how many times interpolation and the second pass are repeated", ge=1, le=100,
                        level="internal")
    min_conn: int = param(
        0, "connected removed or empty sets of at most this many cells keep nearest-neighbour "
        "values instead of priority interpolation [minConn]", unit="cells", ge=0, level="internal",
    )
    connectivity: int = param(8, "neighbours that connect empty cells", choices=(4, 8), level="internal")
    fill_rise: float = param(
        0.8, "height the priority interpolation may rise per cell away from a low boundary "
        "cell; 0 floods every removed set at its lowest boundary, as the queue of §4.2.4 does",
        unit="m", ge=0, level="internal",
    )
    direction: str = param("xy", "filter along x (rows), y (columns) or both", choices=tuple(AXES),
                           renamed_values=OLD_DIRECTIONS, level="internal")

    def check(self) -> None:
        super().check()
        check_series(self.window_series, self.threshold_series, ("window_series", "threshold_series"))
        if len(self.second_window_series) != len(self.second_threshold_series):
            raise ParamError(
                f"second_threshold_series: expected one value per window of second_window_series "
                f"({len(self.second_window_series)}), got {len(self.second_threshold_series)}"
            )


def multipass_reach(p: MultipassParams) -> int:
    """Both passes' openings; the priority interpolation between them may reach farther."""
    first = sum(2 * k for k in p.window_series)
    second = sum(2 * k for k in p.second_window_series) * p.passes
    return first + second + low_outlier_reach(p)


@register_filter("multipass", params=MultipassParams, reach=multipass_reach, takes_codes=True,
                 summary="multi-pass morphological filter with priority boundary interpolation "
                         "(dissertation ch. 4)")
def multipass(z: np.ndarray, empty: np.ndarray, params: MultipassParams, *, in_place: bool = False,
              decode: Decode | None = None) -> np.ndarray:
    """Mark matrix of the multi-pass filter (dissertation §4.2.5); ``decode``: ``z`` holds height
    codes (:mod:`aldpat.core.height_codes`). ``z`` is never changed.

    Memory: a 1 m grid of a large survey holds tens of millions of cells, so one float64 grid
    lives at a time: the interpolation fills it in place and the openings open it in place
    (:func:`aldpat.core.progressive.progressive_opening`).
    """
    p = params
    axes = AXES[p.direction]
    marks = progressive_marks(z, p.window_series, p.threshold_series, axes=axes, decode=decode)
    for n in range(p.passes):
        removed = marks > 0
        standing = ~removed
        standing &= ~empty
        if not standing.any():
            break
        # Cells without a point take the nearest standing cell, as before pass 1; the sets of
        # removed cells are then interpolated from their lowest boundary (small sets keep the
        # nearest-neighbour value). Counting cells without a point into the sets, as the
        # -9999 marks of PQBoundInterp would on dense data, joins the sets of sparse data into
        # one sheet flooded from its lowest corner (ISPRS samples: mean total error 19 %
        # instead of 9 %).
        standing = ~standing
        if decode is None:
            base = fill_nearest(np.where(standing, np.nan, z), standing)
        else:  # the nearest cell's code, then its height: the same value as filling heights
            base = heights_grid(fill_nearest(z, standing), np.float64, decode)
        del standing
        surface = priority_fill(base, removed, min_conn=p.min_conn, connectivity=p.connectivity,
                                rise=p.fill_rise, in_place=True)
        del base
        skip = removed
        skip |= empty
        second = progressive_marks(surface, p.second_window_series, p.second_threshold_series,
                                   axes=axes, skip=skip, in_place=True)
        del surface, skip
        fresh = second > 0
        log.debug("multipass: pass %d removed %d more cells", n + 2, int(fresh.sum()))
        if not fresh.any():
            break
        np.copyto(marks, second, where=fresh)
    return marks.astype(np.int32, copy=False)
