"""Progressive morphological filter with square windows (``pm2d``).

ALDPAT 1.0 user manual (2007), task 8 "2D Morphological Filters (Square or Circle Window)", "Morph 2D
Filter", and the Appendix "Progressive Morphological (PM) Filter" ("the filtering window can
be a one-dimensional line or two-dimensional rectangle"): the same progressive opening,
thresholds and window series as ``pm`` (:mod:`aldpat.filters.pm`) with ``(2k+1) x (2k+1)``
windows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aldpat.core.progressive import progressive_opening
from aldpat.filters.pm import (
    ProgressiveParams,
    progressive_reach,
    threshold_series,
    window_series,
)
from aldpat.filters.registry import register_filter


@dataclass(frozen=True)
class PM2DParams(ProgressiveParams):
    pass


@register_filter("pm2d", params=PM2DParams, takes_codes=True, reach=progressive_reach,
                 summary="progressive morphological filter, square windows (manual task 8, Morph 2D Filter)")
def pm2d(z: np.ndarray, empty: np.ndarray, params: PM2DParams, *, in_place: bool = False, decode=None
         ) -> np.ndarray:
    """Progressive morphology with square windows (manual task 8; appendix PM); ``decode`` as for ``pm``."""
    windows = window_series(params)
    return progressive_opening(z, windows, threshold_series(params, windows), (("square", 1),), decode=decode)
