"""Iterative polynomial fitting (``ipf``) and the polynomial two-surface filter (``poly2``).

ALDPAT 1.0 user manual (2007), task 8 "Iterative Polynomial Fitting (IPF)" and "Polynomial Two-Surface
Filter" for the parameters, Appendix "Iterative Polynomial Fitting (IPF) Filter" (Figs. 14, 15)
for the method:

1. nodes every ``cell``; the lowest point within a window of ``init_window_length``
   centred on each node is a seed: the seeds are the first ground set;
2. the window shrinks through ``window_series`` (default: halving, ``window_series_length`` =
   floor(log2(init window) - log2(1)) + 1, the manual's formula with a smallest window of 1 m);
   at each step the lowest point in the window around each node is a candidate, and joins the
   ground set when it lies within ``z_difference`` of the surface interpolated from the ground
   set so far (Fig. 14);
3. every point within ``outlier_tolerance`` of the final surface is ground.

The surface is a local polynomial (:mod:`aldpat.core.local_poly`) fitted at every node to the
ground points in the window of the step just done (at least one cell each side), widened where
it holds too few ground points.

``poly2`` adds the recovery of Fig. 15: a candidate the previous surface rejects is recovered
when the *current* surface -- fitted to the ground set plus this step's candidates -- puts it
within ``z_difference`` and that current surface fits the ground points inside
``interpolation_window`` better than the previous surface by ``sigma_difference`` (root mean
square residuals). ``neighbor_range`` is the fewest ground points a local fit may use (a node's
window grows until it holds them) and ``power`` the polynomial's degree.

Choices where the manual is silent: windows are whole odd numbers of cells (the nearest to the
length asked for, the smallest the node's own cell); a candidate is compared with the surface at
its own cell rather than at the node whose window found it, so that on a slope the distance
between the two does not count as height; ``ipf`` fits planes to at least 3 points; the final
test is two-sided (a point far below the surface is not ground either).

Marks: 0 ground, 1 non-ground.
"""

from __future__ import annotations

import itertools
import logging
import math
from dataclasses import dataclass

import numpy as np

from aldpat._lazy import lazy_import
from aldpat.core.local_poly import PointSums, fit_surface
from aldpat.core.lowest_grid import LowestGrid
from aldpat.core.morphology import within
from aldpat.core.surface_check import within_surface
from aldpat.errors import ParamError
from aldpat.filters.marks import MARK_GROUND, MARK_NON_GROUND
from aldpat.filters.options import PointFilterParams
from aldpat.filters.registry import register_filter
from aldpat.params import default_of, param

ndimage = lazy_import("scipy.ndimage")

log = logging.getLogger(__name__)



@dataclass(frozen=True)
class IpfParams(PointFilterParams):
    cell: float = param(1.0, "node spacing of the interpolated surface", unit="m", gt=0,
                             manual="Cell Size")
    z_difference: float = param(1.0, "a candidate within this height of the surface joins the ground set",
                                unit="m", gt=0, manual="Z Difference", level="internal")
    outlier_tolerance: float = param(0.6, "at the end, every point within this height of the final "
                                          "surface is ground", unit="m", gt=0, manual="Outlier Tolerance",
                                          level="internal")
    init_window_length: float = param(30.0, "first moving window: larger than the largest object",
                                      unit="m", gt=0, manual="Init Window Length", level="internal")
    window_series_length: int | None = param(
        None, "number of windows (none: floor(log2(init_window_length)) + 1, down to 1 m)", ge=1, le=64,
        manual="Window Series Length", level="internal",
    )
    window_series: tuple[float, ...] | None = param(
        None, "window lengths, largest first (none: init_window_length halved window_series_length - 1 "
              "times)", unit="m", gt=0, manual="Window Series", level="internal",
    )

    def check(self) -> None:
        super().check()
        series = self.windows()
        if not series:
            raise ParamError("window_series: expected at least one window length (or none given, for the halving "
                             "series)")
        if any(b > a for a, b in itertools.pairwise(series)):
            raise ParamError(f"window_series: must not grow, got {list(series)}")

    def cell_shape(self) -> tuple[float, float]:
        return self.cell, self.cell

    def windows(self) -> tuple[float, ...]:
        """The window lengths, first (seed) window included."""
        if self.window_series is not None:
            return tuple(self.window_series)
        n = self.window_series_length
        if n is None:
            n = max(1, math.floor(math.log2(self.init_window_length)) + 1) if self.init_window_length >= 1 else 1
        return tuple(self.init_window_length / 2 ** i for i in range(n))

    # ipf's fixed choices; poly2 declares them as parameters
    @property
    def degree(self) -> int:
        return 1

    @property
    def min_points(self) -> int:
        return 3


@dataclass(frozen=True)
class Poly2Params(IpfParams):
    sigma_difference: float = param(
        0.2, "a rejected candidate is recovered only when the current surface fits the ground points "
              "better than the previous one by this much (RMS residual)", unit="m", ge=0,
        manual="Sigma Difference", level="internal",
    )
    z_difference: float = default_of(IpfParams, "z_difference", 0.5)
    init_window_length: float = default_of(IpfParams, "init_window_length", 40.0)
    outlier_tolerance: float = default_of(IpfParams, "outlier_tolerance", 0.8)
    neighbor_range: int = param(6, "fewest ground points a local fit uses (its window grows until it "
                                    "holds them)", ge=1, le=10_000, manual="Neighbor Range", level="internal")
    interpolation_window: float = param(10.0, "window in which the two surfaces' fit to the ground "
                                              "points is compared", unit="m", gt=0,
                                        manual="Interpolation Wnd", level="internal")
    power: int = param(1, "degree of the local polynomial (1 plane, 2 quadratic)", choices=(1, 2),
                       manual="Power", level="internal")

    @property
    def degree(self) -> int:  # type: ignore[override]
        return self.power

    @property
    def min_points(self) -> int:  # type: ignore[override]
        return max(self.neighbor_range, 3 if self.power == 1 else 6)


def half_window(length: float, cell: float) -> int:
    """Half size in cells of the odd window nearest to ``length`` (0: the cell alone)."""
    return max(0, round((length / cell - 1.0) / 2.0))


def _candidates(zinf: np.ndarray, k: int) -> np.ndarray:
    """Cells holding the lowest point of the window around at least one node."""
    if k == 0:
        return np.isfinite(zinf)
    size = 2 * within(k, zinf.shape) + 1
    low = ndimage.minimum_filter(zinf, size=size, mode="constant", cval=np.inf)
    # the lowest of a window lies in it; a cell is some node's lowest when the highest of the
    # window minima around it equals its own height (every one of them is at most its height)
    seen = ndimage.maximum_filter(np.where(np.isfinite(low), low, -np.inf), size=size, mode="constant",
                                  cval=-np.inf)
    return np.isfinite(zinf) & (seen == zinf)


class _Ground:
    """The ground set as cells of the node grid (a cell's lowest point), with its surface."""

    def __init__(self, grid: LowestGrid, x: np.ndarray, y: np.ndarray, params: IpfParams):
        self.grid = grid
        self.params = params
        self.cell_x = np.zeros(grid.z.shape)
        self.cell_y = np.zeros(grid.z.shape)
        real = ~grid.empty
        self.cell_x[real] = x[grid.lowest[real]]
        self.cell_y[real] = y[grid.lowest[real]]

    def surface(self, cells: np.ndarray, k: int) -> np.ndarray:
        p = self.params
        sums = PointSums.one_per_cell(self.grid.spec, self.cell_x, self.cell_y, self.grid.z, cells, p.degree)
        return fit_surface(sums, max(k, 1), min_points=p.min_points)


def _rms_residual(ground: np.ndarray, z: np.ndarray, surface: np.ndarray, k: int) -> np.ndarray:
    """RMS of ground cells' heights about ``surface`` over the window of ``k`` cells at each node."""
    size = 2 * within(k, z.shape) + 1
    r2 = np.where(ground, (z - surface) ** 2, 0.0)
    # the count as a whole number, the sum not below zero: the box filter's roundoff would
    # otherwise make a window without ground points (NaN: never better) a tiny ratio of tiny
    # numbers in one grid and not in another
    n = np.rint(ndimage.uniform_filter(ground.astype(np.float64), size=size, mode="constant") * size * size)
    s = np.maximum(ndimage.uniform_filter(r2, size=size, mode="constant") * size * size, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, np.sqrt(s / n), np.nan)


def polynomial_marks(x: np.ndarray, y: np.ndarray, z: np.ndarray, grid: LowestGrid, params: IpfParams
                     ) -> np.ndarray:
    """Point marks of ``ipf``, or of ``poly2`` (the recovery of Fig. 15) for :class:`Poly2Params`;
    ``grid`` holds the lowest point of each node's cell."""
    p = params
    zinf = np.where(grid.empty, np.inf, grid.z)
    ground_set = _Ground(grid, x, y, p)
    ks = [half_window(w, p.cell) for w in p.windows()]
    kw = half_window(p.interpolation_window, p.cell) if isinstance(p, Poly2Params) else 0
    ground = _candidates(zinf, ks[0])
    log.debug("%d seed cells (window %d cells)", int(ground.sum()), 2 * ks[0] + 1)
    surface = ground_set.surface(ground, ks[0])
    for prev_k, k in itertools.pairwise(ks):
        cand = _candidates(zinf, k) & ~ground
        near = cand & (np.abs(grid.z - surface) <= p.z_difference)
        if isinstance(p, Poly2Params):
            rejected = cand & ~near
            if rejected.any():
                current = ground_set.surface(ground | cand, prev_k)
                with np.errstate(invalid="ignore"):  # nodes without ground on either side: NaN, not better
                    better = (_rms_residual(ground, grid.z, surface, kw)
                              - _rms_residual(ground, grid.z, current, kw)) >= p.sigma_difference
                recovered = rejected & (np.abs(grid.z - current) <= p.z_difference) & better
                near |= recovered
                log.debug("poly2: window %d cells, %d candidates recovered", 2 * k + 1, int(recovered.sum()))
        ground |= near
        surface = ground_set.surface(ground, k)
        log.debug("window %d cells: %d candidates, %d joined", 2 * k + 1, int(cand.sum()), int(near.sum()))
    on_surface = within_surface(x, y, z, surface, grid.spec, threshold=p.outlier_tolerance, slope_scalar=0.0)
    return np.where(on_surface, MARK_GROUND, MARK_NON_GROUND).astype(np.int32)


def polynomial_buffer(params: IpfParams) -> float:
    """A chunk's buffer: three first windows. A seed is the lowest of the first window around
    a node, the first surface is fitted over that window (wider where it holds too few ground
    points), and each later window builds on the last, so the classes depend on points farther
    than any one window; with three first windows (90 m for ipf, 120 m for poly2 as shipped)
    chunks gave the whole file's classes on 99.9 % of the points or more
    (``bench/bench_chunks.py agree``)."""
    return 3 * params.windows()[0]


@register_filter("ipf", params=IpfParams, on_points=True, buffer=polynomial_buffer,
                 summary="iterative local polynomial fitting (manual appendix IPF)")
def ipf(x: np.ndarray, y: np.ndarray, z: np.ndarray, grid: LowestGrid, params: IpfParams) -> np.ndarray:
    """Point marks of the iterative polynomial fitting filter (manual appendix IPF, Fig. 14)."""
    return polynomial_marks(x, y, z, grid, params)


@register_filter("poly2", params=Poly2Params, on_points=True, buffer=polynomial_buffer,
                 summary="polynomial two-surface filter (manual appendix IPF, Fig. 15)")
def poly2(x: np.ndarray, y: np.ndarray, z: np.ndarray, grid: LowestGrid, params: Poly2Params) -> np.ndarray:
    """Point marks of the polynomial two-surface filter (manual appendix IPF, Fig. 15)."""
    return polynomial_marks(x, y, z, grid, params)
