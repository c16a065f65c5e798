"""Elevation threshold with expanding window (``etew``).

ALDPAT 1.0 user manual (2007), Appendix "Elevation Threshold with Expand Window (ETEW) Filter"
(Zhang and Whitman 2005) and task 8 for the parameters (Slope, Loop Times, Max Z, Min Z).

The manual keeps the lowest point of each cell (our lowest-point grid is that first
iteration), then doubles the cell size each iteration, ``c_i = 2 c_{i-1}``, and removes a point
when it lies more than ``h_i = s * c_i`` above the minimum of its cell (eqs. 1-3), until an
iteration removes nothing or Loop Times is reached.

Choice where the manual is silent: the "cells" of iteration ``i`` are moving square windows
of half size ``k_i = 2^(i-1)`` lowest-point cells centred on each cell, not fixed blocks, so
``c_i = 2 k_i c`` doubles as in eq. (3) (2c, 4c, 8c ...) and a point is compared with the
lowest point around it rather than with the lowest of an arbitrary block; the result then
does not depend on where tiles start. A removed cell is marked with ``k_i``; cells outside
[Min Z, Max Z] are marked 1 (``MARK_NON_GROUND``).

The manual stops as soon as an iteration removes nothing. Every iteration here compares a
cell with the lowest cell of the original grid around it, so that early stop only saves time
-- but it is decided over the whole data set, which would make a tile's classes depend on
points outside its buffer. All ``loop_times`` iterations are therefore run.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from aldpat.core import morphology
from aldpat.core.height_codes import Decode
from aldpat.core.lowest_grid import rows_per_block
from aldpat.core.progressive import mark_dtype
from aldpat.filters.grid_stage import low_outlier_reach
from aldpat.filters.marks import MARK_GROUND, MARK_NON_GROUND
from aldpat.filters.options import GroundParams
from aldpat.filters.registry import register_filter
from aldpat.options import ElevationLimitsOption
from aldpat.params import param

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ETEWParams(ElevationLimitsOption, GroundParams):
    slope: float = param(0.4, "terrain slope: a point more than slope x window width above the window's "
                              "lowest point is removed", unit="m/m", gt=0, manual="Slope", level="internal")
    loop_times: int = param(5, "number of iterations; the window doubles each time", ge=1, le=30,
                            manual="Loop Times", level="internal")


def etew_reach(p: ETEWParams) -> int:
    """Every iteration erodes the original surface: the largest window is the reach."""
    return 2 ** (p.loop_times - 1) + low_outlier_reach(p)


@register_filter("etew", params=ETEWParams, reach=etew_reach, takes_codes=True,
                 summary="elevation threshold with expanding window (manual appendix; Zhang and Whitman 2005)")
def etew(z: np.ndarray, empty: np.ndarray, params: ETEWParams, *, in_place: bool = False, decode: Decode | None = None
         ) -> np.ndarray:
    """Expanding-window elevation threshold (manual appendix ETEW, eqs. 1-3).

    ``decode``: ``z`` holds height codes (:mod:`aldpat.core.height_codes`); the window minimum is
    taken on the codes (the same cells) and heights are compared a block of rows at a time.
    ``z`` is never changed.
    """
    heights = decode if decode is not None else (lambda a: a)
    marks = np.zeros(z.shape, mark_dtype(2 ** (params.loop_times - 1)))
    step = rows_per_block(z.shape[1])  # rows compared at once: bounds the float64 scratch
    for a in range(0, z.shape[0], step):
        block = heights(z[a:a + step])
        if params.min_z is not None:
            marks[a:a + step][block < params.min_z] = MARK_NON_GROUND
        if params.max_z is not None:
            marks[a:a + step][block > params.max_z] = MARK_NON_GROUND
    for i in range(1, params.loop_times + 1):
        k = 2 ** (i - 1)
        h = params.slope * 2 * k * params.cell
        # a window wider than the grid sees the whole grid: no need to make it wider still
        lowest = morphology.erosion(z, min(k, max(z.shape)), window="square")
        removed_count = 0
        for a in range(0, z.shape[0], step):
            m = marks[a:a + step]
            removed = (heights(z[a:a + step]) - heights(lowest[a:a + step]) > h) & (m == MARK_GROUND)
            m[removed] = k
            removed_count += int(removed.sum())
        del lowest
        log.debug("etew iteration %d: window %d, threshold %.3g, %d cells removed", i, k, h, removed_count)
    return marks
