"""Progressive morphological filter with circular windows (``pmcircle``).

ALDPAT 1.0 user manual (2007), task 8 "2D Morphological Filters (Square or Circle Window)", "Morph
Circle Filter", and the Appendix "Progressive Morphological (PM) Filter": the progressive
opening of ``pm`` (:mod:`aldpat.filters.pm`) with disk windows of radius ``k`` cells (the cells
whose centres lie within ``k`` cells; diameter ``2k+1`` is the ``w`` of the threshold rule).
A disk has no preferred direction, so objects are removed alike whatever their orientation.
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
class PMCircleParams(ProgressiveParams):
    pass


@register_filter("pmcircle", params=PMCircleParams, takes_codes=True, reach=progressive_reach,
                 summary="progressive morphological filter, circular windows (manual task 8, Morph Circle Filter)")
def pmcircle(z: np.ndarray, empty: np.ndarray, params: PMCircleParams, *, in_place: bool = False, decode=None
             ) -> np.ndarray:
    """Progressive morphology with disk windows (manual task 8; appendix PM); ``decode`` as for ``pm``."""
    windows = window_series(params)
    return progressive_opening(z, windows, threshold_series(params, windows), (("disk", 1),), decode=decode)
