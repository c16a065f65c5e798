"""Maximum local slope (``slope``).

ALDPAT 1.0 user manual (2007), task 8 "Maximum Local Slope (MLS)" for the parameters (Width, Height,
Max Z, Min Z, Search Radius, Min Distance, Max Slope) and Appendix "Maximum Local Slope (MLS)
Filter", eq. (4), after Vosselman (2000): a mesh of ``cell`` x ``height`` cells keeps the lowest
point of each cell (the manual's 2-D array); a point ``p0`` is ground when the largest slope
``(z0 - zj) / d0j`` from it down to any array element ``pj`` within ``search_radius`` is below
``max_slope``. Pairs closer than ``min_distance`` are not compared (the manual's Min Distance);
points outside [Min Z, Max Z] are non-ground.

Choices where the manual is silent:

* every point is tested, not only the array elements, and against the array elements (the
  lowest point of each cell, the point itself excluded): the other points of a cell are then
  ground when they lie as the terrain does, not by a separate tolerance;
* a pair exactly ``search_radius`` apart is compared; a pair exactly ``max_slope`` steep makes the
  upper point non-ground (eq. 4 keeps ``s0,max < s`` only).

The search is exact and runs over the cell grid (compiled, :mod:`aldpat.filters.slope_search`):
neighbouring cells are visited in order of their smallest possible distance, and a point leaves
the search as soon as it is found non-ground or no cell left can be steep enough below it -- its
height above the lowest array element within reach, divided by ``max_slope``, bounds the
distance a steep neighbour can have. On terrain most points leave after the first ring of cells.

Marks: 0 ground, 1 non-ground (a steep neighbour or outside [Min Z, Max Z]).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from aldpat._lazy import lazy_import
from aldpat.core.lowest_grid import LowestGrid
from aldpat.core.resources import check_memory
from aldpat.errors import ParamError
from aldpat.filters.marks import MARK_GROUND, MARK_NON_GROUND
from aldpat.filters.options import PointFilterParams
from aldpat.filters.registry import register_filter
from aldpat.options import CellHeightOption, ElevationLimitsOption
from aldpat.params import param

ndimage = lazy_import("scipy.ndimage")
slope_kernels = lazy_import("aldpat.filters.slope_search")

log = logging.getLogger(__name__)



#: The widest search, in cells: 1,000 cells a side compares each point with 3 million cells (the
#: manual's 8 m on 1 m cells: 200).
MOST_REACH = 1_000


@dataclass(frozen=True)
class SlopeParams(CellHeightOption, ElevationLimitsOption, PointFilterParams):
    cell: float = param(1.0, "cell width of the lowest-point mesh", unit="m", gt=0, manual="Width")
    search_radius: float = param(8.0, "neighbours within this distance are compared", unit="m", gt=0,
                                 manual="Search Radius", level="internal")
    min_distance: float = param(0.5, "pairs closer than this are not compared (a slope over a tiny "
                                     "distance says nothing)", unit="m", ge=0, manual="Min Distance", level="internal")
    max_slope: float = param(0.8, "a point is non-ground when the slope from it down to a neighbour "
                                  "reaches this", unit="m/m", gt=0, manual="Max Slope", level="internal")

    def check(self) -> None:
        super().check()
        # each point is compared with the cells of a square of the radius a side (:func:`_offsets`
        # lists them): at --search-radius 1e9 on 1 m cells that list alone was 4e18 cells, and the
        # process ate the machine's memory until the kernel killed it
        reach = self.search_radius / min(self.cell_shape())
        if reach > MOST_REACH:
            raise ParamError(f"search_radius: {self.search_radius:g} m is {reach:.3g} cells of {min(self.cell_shape()):g} m; "
                             f"at most {MOST_REACH:,} cells (each point is compared with every cell within it)")
        if self.min_distance >= self.search_radius:
            raise ParamError(f"min_distance: {self.min_distance:g} must be below search_radius "
                             f"{self.search_radius:g}")


#: bytes a cell offset of the search takes while the offsets are made: its row and column
#: (int64), its gap (float64), their copies kept and the order sorting them
OFFSET_BYTES = 64


def _reach(width: float, height: float, radius: float, shape: tuple[int, int]) -> tuple[int, int]:
    """The rows and columns of cells a search of ``radius`` reaches, no more than the grid of
    ``shape`` holds: a radius of 1,000 km over a strip's 600 x 220 cells needs 220 and 600, not a
    window of 2,000,001 x 2,000,001 offsets (29 TiB)."""
    rows, cols = shape
    return min(math.ceil(radius / height), max(rows - 1, 0)), min(math.ceil(radius / width), max(cols - 1, 0))


def _offsets(width: float, height: float, radius: float, reach: tuple[int, int]
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cell offsets (dr, dc) that can hold a point within ``radius`` of a point of cell (0, 0),
    up to ``reach`` rows and columns away (:func:`_reach`), with the smallest distance two such
    points can have, nearest first. Their memory is checked first: over a large grid a radius
    of many cells is refused by name, not met with numpy's MemoryError."""
    kr, kc = reach
    check_memory((2 * kr + 1) * (2 * kc + 1) * OFFSET_BYTES,
                 f"a search radius of {radius:g} m over {width:g} x {height:g} m cells "
                 f"({2 * kr + 1:,} x {2 * kc + 1:,} cell offsets)", "use a smaller search_radius or a larger cell")
    dr, dc = np.meshgrid(np.arange(-kr, kr + 1), np.arange(-kc, kc + 1), indexing="ij")
    gap = np.hypot(np.maximum(np.abs(dc) - 1, 0) * width, np.maximum(np.abs(dr) - 1, 0) * height)
    keep = gap <= radius
    order = np.argsort(gap[keep], kind="stable")
    return dr[keep][order], dc[keep][order], gap[keep][order]


def steep_points(x: np.ndarray, y: np.ndarray, z: np.ndarray, grid: LowestGrid, params: SlopeParams
                 ) -> np.ndarray:
    """True for every point with a neighbour of the lowest-point array ``grid`` (the filter's
    ``cell`` x ``height`` cells) within ``search_radius`` that lies ``max_slope`` or more below it
    (manual eq. 4)."""
    p = params
    n = len(z)
    width, height = p.cell_shape()
    spec = grid.spec
    rows, cols = spec.shape
    flat_lowest = grid.lowest.ravel()
    ci = grid.cell_index
    # lowest array element within reach of every cell: bounds how far a steep neighbour may be
    kr, kc = reach = _reach(width, height, p.search_radius, spec.shape)
    reach_min = ndimage.minimum_filter(np.where(grid.empty, np.inf, grid.z), size=(2 * kr + 1, 2 * kc + 1),
                                       mode="constant", cval=np.inf).ravel()
    dr, dc, gap = _offsets(width, height, p.search_radius, reach)
    steep = np.zeros(n, bool)
    slope_kernels.steep_search(x, y, z, ci, flat_lowest, reach_min, dr.astype(np.int64), dc.astype(np.int64),
                               gap.astype(np.float64), rows, cols, p.min_distance ** 2, p.search_radius ** 2,
                               p.max_slope, steep)
    log.debug("slope: %d of %d points have a steep neighbour", int(steep.sum()), n)
    return steep


def slope_buffer(params: SlopeParams) -> float:
    """A chunk's buffer: a point's class depends on the lowest points of the cells within its
    search radius, each the lowest of its whole cell: the radius and two cells."""
    return params.search_radius + 2 * max(params.cell_shape())


@register_filter("slope", params=SlopeParams, on_points=True, buffer=slope_buffer,
                 summary="maximum local slope (manual appendix MLS; Vosselman 2000)")
def slope(x: np.ndarray, y: np.ndarray, z: np.ndarray, grid: LowestGrid, params: SlopeParams) -> np.ndarray:
    """Point marks of the maximum local slope filter (manual appendix MLS, eq. 4)."""
    non_ground = steep_points(x, y, z, grid, params)
    if params.min_z is not None:
        non_ground |= z < params.min_z
    if params.max_z is not None:
        non_ground |= z > params.max_z
    return np.where(non_ground, MARK_NON_GROUND, MARK_GROUND).astype(np.int32)
