"""Progressive morphological filter (``pm``) and its window shapes (``pm2d``, ``pmcircle``).

ALDPAT 1.0 user manual (2007), Appendix "Progressive Morphological (PM) Filter" (Zhang et al. 2003)
and task 8 "Progressive Morphology (PM)" and "2D Morphological Filters (Square or Circle Window)"
for the parameters; Cui (2013) §5.1 for the review and §5.2.2 for the mark matrix it fills
(Table 5-1).

For each window of an increasing series the current surface is opened; a cell whose
elevation drops by more than the window's threshold is marked with the (half) window size at
which that happened, and the opened surface becomes the input of the next window. The appendix:
"the filtering window can be a one-dimensional line or two-dimensional rectangle"; the three
filters are that one method with three window shapes, each filter's params class fixing its
shape (:attr:`ProgressiveParams.window_shape`):

* ``pm``: line windows, the opening along x, along y, or along x then y at every step (the
  manual: "the opening operation was applied to both x and y directions at each step"); the
  data can be rotated first (Rotate Angle / Rotate Times) to line the windows up with linear
  features;
* ``pm2d`` ("Morph 2D Filter"): ``(2k+1) x (2k+1)`` square windows;
* ``pmcircle`` ("Morph Circle Filter"): disk windows of radius ``k`` cells (the cells whose
  centres lie within ``k`` cells; diameter ``2k+1`` is the ``w`` of the threshold rule). A disk
  has no preferred direction, so objects are removed alike whatever their orientation.

Threshold of the manual's eq. (5), with full window sizes ``w = 2k + 1`` in cells::

    dh_k = dh0                                   if w_k <= 3
         = s * (w_k - w_{k-1}) * c + dh0         otherwise, capped at dh_max

For the first window ``w_{k-1}`` is 1 (the unfiltered grid is a one-cell window).
"""

from __future__ import annotations

import itertools
import logging
import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from aldpat.core.height_codes import Decode
from aldpat.core.progressive import progressive_opening
from aldpat.errors import ParamError, shown
from aldpat.filters.grid_stage import low_outlier_reach
from aldpat.filters.options import GroundParams
from aldpat.filters.registry import register_filter
from aldpat.params import param

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ProgressiveParams(GroundParams):
    """The manual's PM parameters (task 8), shared by ``pm``, ``pm2d`` and ``pmcircle``.

    Defaults were chosen on the seven ISPRS samples of bench/ (one set for all samples and all
    three window shapes, see bench/README.md): half windows 1, 2, 3, 4, 6, 8, 11, 16 cells
    (base 2, increment 0.5) keep each threshold step small, which matters more than the slope.
    """

    slope: float = param(0.3, "terrain slope that raises the threshold as the window grows", unit="m/m",
                         ge=0, manual="Slope", level="internal")
    init_threshold: float = param(0.5, "threshold of the smallest windows: the error of the measurements",
                                  unit="m", ge=0, manual="Init Threshold", level="internal")
    max_threshold: float = param(3.0, "cap of the threshold (the lowest building height; 9999: none)",
                                 unit="m", ge=0, manual="Max Threshold", level="internal")
    window_base: float = param(2.0, "base of the power series of half windows, k_i = base^(i*increment)",
                               gt=1, manual="Window Base", level="internal")
    power_increment: float = param(0.5, "exponent step of the power series", gt=0, manual="Power Increment",
                                   level="internal")
    window_series_length: int = param(9, "number of windows of the power series", ge=1, le=1000,
                                      manual="Window Series Length", level="internal")
    window_series: tuple[int, ...] | None = param(
        None, "half windows in cells, ascending, replacing the power series (full window 2k+1)",
        unit="cells", ge=1, manual="Wind Series", level="internal",
    )
    threshold_series: tuple[float, ...] | None = param(
        None, "one threshold per window, replacing the slope rule", unit="m", ge=0, manual="Threshold Series",
        level="internal",
    )
    min_window: int = param(1, "smallest half window used", unit="cells", ge=1, manual="Min WndSize", level="internal")

    #: The window of the openings, fixed by each filter's params class (no parameter a user sets):
    #: ``"line"`` (``pm``), ``"square"`` (``pm2d``) or ``"disk"`` (``pmcircle``).
    window_shape: ClassVar[str]

    def check(self) -> None:
        super().check()
        threshold_series(self, window_series(self))

    def openings(self) -> tuple[tuple[str, int], ...]:
        """The openings at every window, in turn, as ``(window shape, axis)``
        (:func:`aldpat.core.progressive.progressive_opening`'s ``passes``)."""
        return ((self.window_shape, 1),)


@dataclass(frozen=True)
class PMParams(ProgressiveParams):
    window_shape: ClassVar[str] = "line"
    direction: str = param("xy", "open along x (rows), y (columns) or x then y at every window",
                           choices=("x", "y", "xy"), manual="Direction", level="internal")
    rotate_angle: float = param(0.0, "angle the data are rotated by (counter-clockwise) before filtering",
                                unit="deg", ge=-360, le=360, manual="Rotate Angle", level="internal")
    rotate_times: int = param(
        0, "number of rotations: filter at 1, 2 ... times the angle; a point is ground only if every "
        "rotation keeps it (0: unrotated)", ge=0, le=36, manual="Rotate Times", level="internal",
    )

    def openings(self) -> tuple[tuple[str, int], ...]:
        """Along x (axis 1, the rows), y (axis 0, the columns) or x then y."""
        return tuple(("line", axis) for axis in _LINE_AXES[self.direction])


#: The axes a line window opens along, by ``direction``.
_LINE_AXES = {"x": (1,), "y": (0,), "xy": (1, 0)}


@dataclass(frozen=True)
class PM2DParams(ProgressiveParams):
    window_shape: ClassVar[str] = "square"


@dataclass(frozen=True)
class PMCircleParams(ProgressiveParams):
    window_shape: ClassVar[str] = "disk"


#: The largest half window of a series (cells): 100 km at 1 m cells, wider than any tile; a
#: series growing past it asks for windows no grid has.
MOST_HALF_WINDOW = 100_000


def window_series(p: ProgressiveParams) -> tuple[int, ...]:
    """Half windows in cells: the given series, or ``round(base ** (i * increment))``,
    ``i = 0 .. length-1`` (manual task 8 "Wind Series"), without repeats and below
    ``min_window`` dropped."""
    if p.window_series is not None:
        ks = tuple(int(k) for k in p.window_series)
        if any(b <= a for a, b in itertools.pairwise(ks)):
            raise ParamError(f"window_series: half windows must be strictly ascending, got {shown(ks, quoted=False)}")
    else:
        # the exponent of the last window, in logarithms: 2 ** (3000 * 0.5) is no float
        largest = (p.window_series_length - 1) * p.power_increment * math.log(p.window_base)
        if largest > math.log(MOST_HALF_WINDOW):
            fit = math.floor(math.log(MOST_HALF_WINDOW) / (p.power_increment * math.log(p.window_base))) + 1
            raise ParamError(f"window_series_length: {p.window_series_length} windows of base {p.window_base:g} and "
                             f"increment {p.power_increment:g} grow past {MOST_HALF_WINDOW:,} cells a half window; "
                             f"at most {fit} fit")
        raw = [round(p.window_base ** (i * p.power_increment)) for i in range(p.window_series_length)]
        ks = tuple(sorted(set(raw)))
    ks = tuple(k for k in ks if k >= p.min_window)
    if not ks:
        raise ParamError(f"min_window: {p.min_window} leaves no window of the series")
    return ks


def threshold_series(p: ProgressiveParams, windows: tuple[int, ...]) -> tuple[float, ...]:
    """The given thresholds, or the manual's eq. (5) for each window."""
    if p.threshold_series is not None:
        if len(p.threshold_series) != len(windows):
            raise ParamError(f"threshold_series: expected one value per window ({len(windows)}: "
                             f"{','.join(map(str, windows))}), got {len(p.threshold_series)}")
        return tuple(float(t) for t in p.threshold_series)
    out = []
    w_prev = 1
    for k in windows:
        w = 2 * k + 1
        dh = p.init_threshold if w <= 3 else p.slope * (w - w_prev) * p.cell + p.init_threshold
        out.append(min(dh, p.max_threshold))
        w_prev = w
    return tuple(out)


def rotation_angles(p: PMParams) -> tuple[float, ...]:
    """Angles the data are filtered at: ``i * rotate_angle`` for ``i = 1 .. rotate_times``."""
    if p.rotate_times == 0 or p.rotate_angle % 360.0 == 0.0:
        return (0.0,)
    return tuple(i * p.rotate_angle for i in range(1, p.rotate_times + 1))


def progressive_reach(p: ProgressiveParams) -> int:
    """Cells a progressive filter's marks depend on: each opening works on the last one's
    surface and reaches twice its half window (Zhang et al. 2003, eq. 2)."""
    return sum(2 * k for k in window_series(p)) + low_outlier_reach(p)


def pm(z: np.ndarray, empty: np.ndarray, params: ProgressiveParams, *, in_place: bool = False,
       decode: Decode | None = None) -> np.ndarray:
    """Progressive morphology with the windows of ``params`` (manual appendix PM, task 8): lines
    along ``direction`` (:class:`PMParams`), squares (:class:`PM2DParams`) or disks
    (:class:`PMCircleParams`).

    ``decode``: ``z`` holds height codes (:mod:`aldpat.core.height_codes`); ``z`` is never changed.
    """
    windows = window_series(params)
    return progressive_opening(z, windows, threshold_series(params, windows), params.openings(), decode=decode)


register_filter("pm", params=PMParams, takes_codes=True, rotations=rotation_angles, reach=progressive_reach,
                summary="progressive morphological filter, line windows along x, y or both "
                        "(manual appendix and task 8; Zhang and others 2003)")(pm)
register_filter("pm2d", params=PM2DParams, takes_codes=True, reach=progressive_reach,
                summary="progressive morphological filter, square windows (manual task 8, Morph 2D Filter)")(pm)
register_filter("pmcircle", params=PMCircleParams, takes_codes=True, reach=progressive_reach,
                summary="progressive morphological filter, circular windows (manual task 8, Morph Circle Filter)")(pm)
