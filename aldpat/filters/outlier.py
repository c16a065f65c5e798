"""Morphological outlier removal (``outlier``).

GAPM dissertation (Cui 2013, ch. 4 §4.1.1): isolated extremely high points (power
lines, birds) stand out of an *opening* with a small window (1 to 3 cells); isolated extremely
low points (multipath, a window reaching a floor) sink below a *closing*. A cell is an outlier
when it lies more than ``high_threshold`` above its opening or more than ``low_threshold``
below its closing; its mark is the half window used.

Classified output (:func:`outlier_noise`) calls the points of a removed cell low noise when they
lie more than ``low_threshold`` below the ground surface around them, high noise when more than
``high_threshold`` above it (ASPRS classes 7 and 18).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from aldpat.core import morphology
from aldpat.core.height_codes import Decode
from aldpat.core.lowest_grid import rows_per_block
from aldpat.filters.classify import FilterResult
from aldpat.filters.grid_stage import low_outlier_reach
from aldpat.filters.options import GroundParams
from aldpat.filters.registry import register_filter
from aldpat.params import param

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class OutlierParams(GroundParams):
    window: int = param(1, "half window of the opening and closing (1 to 3 cells suit outliers)",
                        unit="cells", ge=1, level="internal")
    high_threshold: float | None = param(
        2.0, "a cell this far above its opening is a high outlier; none: keep high points", unit="m", gt=0,
        level="internal",
    )
    low_threshold: float | None = param(
        2.0, "a cell this far below its closing is a low outlier; none: keep low points", unit="m", gt=0,
        level="internal",
    )
    shape: str = param("square", "window shape", choices=("square", "disk"), level="internal")


def outlier_marks(z: np.ndarray, *, window: int = 1, high_threshold: float | None = 2.0,
                  low_threshold: float | None = 2.0, shape: str = "square", decode: Decode | None = None) -> np.ndarray:
    """Mark matrix of the morphological outlier test (§4.1.1): ``window`` where an outlier.

    ``decode``: ``z`` holds height codes (:mod:`aldpat.core.height_codes`); openings and closings
    move values only, so they run on the codes and only the comparisons read heights. The test
    is local -- a closing, then an opening of the lifted surface: ``4 window`` cells -- so it runs
    on slabs of rows with that many rows of margin, each row the value the whole grid gives it,
    and memory holds the grid and its marks, not a grid-sized temporary per step.
    """
    z = np.asarray(z) if decode is not None else np.asarray(z, dtype=np.float64)
    rows, cols = z.shape
    marks = np.zeros(z.shape, np.int32)
    margin = 4 * int(window)
    step = max(rows_per_block(cols, 1 << 20), margin)
    for a in range(0, rows, step):
        b = min(rows, a + step)
        lo, hi = max(0, a - margin), min(rows, b + margin)
        marks[a:b] = _slab_marks(z[lo:hi], window, high_threshold, low_threshold, shape, decode)[a - lo:b - lo]
    return marks


def _slab_marks(z: np.ndarray, window: int, high_threshold: float | None, low_threshold: float | None, shape: str,
                decode: Decode | None) -> np.ndarray:
    heights = decode if decode is not None else (lambda v: v)
    out = np.zeros(z.shape, dtype=bool)
    if low_threshold is not None:
        closed = morphology.closing(z, window, window=shape)
        out = heights(closed) - heights(z) > low_threshold
        # a pit pulls the opening of its neighbours down with it: test the high side on the
        # surface with the low outliers lifted to their closing
        z = np.where(out, closed, z)
    if high_threshold is not None:
        out |= heights(z) - heights(morphology.opening(z, window, window=shape)) > high_threshold
    return np.where(out, np.int32(window), np.int32(0))


def outlier_noise(result: FilterResult, z: np.ndarray, params: OutlierParams) -> np.ndarray:
    """Per point: -1 low noise, +1 high noise, 0 neither.

    Noise is a point of a removed cell (mark > 0) that is not ground; it is low or high by its
    height against the final ground surface at its cell (the removed cell filled from its
    nearest ground cell), measured with the filter's own thresholds. Points of kept cells are
    never noise, even canopy over ground: the test is about isolated points, not objects.
    """
    cell_marks = result.marks.ravel()[result.cell_index]
    removed = (cell_marks > 0) & ~result.is_ground
    kind = np.zeros(len(z), np.int8)
    if not removed.any():
        return kind
    height = z[removed] - result.surface.ravel()[result.cell_index[removed]]
    sub = np.zeros(len(height), np.int8)
    if params.low_threshold is not None:
        sub[height < -params.low_threshold] = -1
    if params.high_threshold is not None:
        sub[height > params.high_threshold] = 1
    kind[removed] = sub
    return kind


def outlier_reach(p: OutlierParams) -> int:
    """A closing, then an opening of the lifted surface: four half windows."""
    return 4 * p.window + low_outlier_reach(p)


@register_filter("outlier", params=OutlierParams, noise=outlier_noise, reach=outlier_reach, takes_codes=True,
                 summary="morphological removal of isolated high and low points (dissertation §4.1)")
def outlier(z: np.ndarray, empty: np.ndarray, params: OutlierParams, *, in_place: bool = False,
            decode: Decode | None = None) -> np.ndarray:
    """Mark matrix of the outlier filter (dissertation §4.1.1); ``decode``: ``z`` holds height
    codes. ``z`` is never changed."""
    p = params
    marks = outlier_marks(z, window=p.window, high_threshold=p.high_threshold,
                          low_threshold=p.low_threshold, shape=p.shape, decode=decode)
    log.debug("outlier: %d cells removed", int((marks > 0).sum()))
    return marks
