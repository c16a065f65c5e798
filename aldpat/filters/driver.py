"""The driver that turns a registered filter into point classes: :func:`ground_filter`.

Every ground filter that works on a grid of lowest points is a function
``fn(z, empty, params) -> marks`` registered with :func:`aldpat.filters.registry.register_filter`:

* ``z`` is the lowest-point grid (dissertation ch. 3) with empty cells already filled by
  nearest-neighbour interpolation (dissertation §4.2.1);
* ``empty`` is the boolean mask of cells that had no point;
* the returned int32 *mark matrix* (dissertation §5.2.2, Table 5-1) holds 0 for ground and,
  for a removed cell, the (half) window size in cells at which it was removed. Cells where
  ``empty`` is true become :data:`~aldpat.filters.marks.MARK_INTERPOLATED` whatever ``fn``
  returns.

:func:`ground_filter` grids the points, fills empties, calls ``fn`` (the grid stage,
:mod:`aldpat.filters.grid_stage`) and classifies every point (:mod:`aldpat.filters.classify`),
at each of the manual's rotations where the filter has them. A point filter gets the points and
the lowest-point grid of its own cells and marks every point itself.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from aldpat.core import units
from aldpat.core.lowest_grid import Extent, LowestGrid, lowest_grid
from aldpat.errors import DataError, ParamError
from aldpat.filters.classify import CellHeights, FilterResult
from aldpat.filters.grid_stage import cell_classes, low_outlier_points, points_spacing
from aldpat.filters.marks import MARK_GROUND, MARK_INTERPOLATED, MARK_LOW_OUTLIER
from aldpat.filters.options import PointFilterParams
from aldpat.filters.registry import FilterSpec, get_filter

log = logging.getLogger(__name__)


def _lowest_without(x: np.ndarray, y: np.ndarray, z: np.ndarray, set_aside: np.ndarray | None, cell: float,
                    origin: tuple[float, float] | None, extent: Extent | None = None) -> LowestGrid:
    """The lowest-point grid with the points ``set_aside`` left out (a cell holding nothing
    else is empty); same cells as with them."""
    if set_aside is None or not set_aside.any():
        return lowest_grid(x, y, z, cell, origin=origin, extent=extent)
    grid = lowest_grid(x, y, np.where(set_aside, np.inf, z), cell, origin=origin, extent=extent)
    only = np.isinf(grid.z)
    if only.any():
        grid.z[only] = np.nan
        grid.lowest[only] = -1
        grid.__dict__.pop("empty", None)  # recomputed from ``lowest``
    return grid


def _rotate(x: np.ndarray, y: np.ndarray, degrees: float) -> tuple[np.ndarray, np.ndarray]:
    """Rotate points counter-clockwise about the origin (0, 0), so tiles rotate alike."""
    t = math.radians(degrees)
    c, s = math.cos(t), math.sin(t)
    return x * c - y * s, x * s + y * c


def ground_filter(x: ArrayLike, y: ArrayLike, z: ArrayLike, algorithm: str, params: Any = None, *,
                  extent: Extent | None = None, spacing: float | None = None,
                  note: Callable[[str], None] | None = None) -> FilterResult:
    """Classify points as ground / non-ground with the registered grid filter ``algorithm``.

    Parameters
    ----------
    x, y, z : array-like (n,)
    algorithm : str
        a name in :data:`FILTERS`.
    params : the filter's params dataclass, optional (defaults when omitted).
    extent : (xmin, ymin, xmax, ymax), optional
        the extent the grid covers (default: the points'); a chunk of a file passes the file's
        extent clipped to the chunk's buffer, so that its grid has the file's cells and edges.
    spacing : float, optional
        the input's mean point spacing, which sets the low-outlier test's blocks (default: the
        points' own, over their extent); a chunk of a file passes the whole file's.
    note : callable, optional
        told which params derived from the points were used (a job's log: ``ctx.note``;
        default: this module's logger).

    With the manual's Rotate Angle / Rotate Times (filters registered with ``rotations``),
    the data are rotated, gridded and filtered at each angle; a point is ground only when every
    orientation keeps it, and its mark is the largest window that removed it.

    The points given are filtered together, at once: the command's options of how a file is
    read and written (``chunk``, ``result``...) are not read here, but ``chunk`` with params that
    need every point at once (gapm's ``auto``) is refused as the command refuses it
    (:meth:`FilterSpec.check_chunks`); without it, such params are derived from the points
    given (:attr:`FilterSpec.with_points`, told to ``note``), as ``aldpat filter`` derives them
    from a file; the result's ``params`` are those the filter ran with.
    """
    spec = get_filter(algorithm)
    if params is None:
        params = spec.params()
    elif not isinstance(params, spec.params):
        raise ParamError(f"filter {algorithm!r} takes {spec.params.__name__}, got {type(params).__name__}")
    # its values and rules were checked when it was made (aldpat.params.Checked)
    spec.check_chunks(params)
    x = np.ascontiguousarray(x, dtype=np.float64)
    y = np.ascontiguousarray(y, dtype=np.float64)
    z = np.ascontiguousarray(z, dtype=np.float64)
    if not (x.shape == y.shape == z.shape) or x.ndim != 1:
        raise ValueError("x, y and z must be 1-D arrays of the same length")
    refuse_not_finite(x, y, z)
    if spec.with_points is not None and spec.needs_every_point(params) is not None:
        params, told = spec.with_points(params, x, y, z)
        (note or log.info)(told)
    if spacing is None:
        spacing = points_spacing(x, y)
    if spec.on_points:
        return _point_filter(spec, x, y, z, params, extent, spacing)
    angles = tuple(float(a) for a in spec.rotations(params)) if spec.rotations else (0.0,)
    if not angles:
        angles = (0.0,)

    units.stage("grid")
    base = lowest_grid(x, y, z, params.cell, origin=params.origin, extent=extent)
    if len(z) == 0:
        return FilterResult(np.zeros(0, np.int32), np.zeros(0, bool), base,
                            np.full(base.z.shape, MARK_INTERPOLATED, np.int32), angles, algorithm, params)
    point_marks: np.ndarray | None = None
    is_ground: np.ndarray | None = None
    low = np.zeros(len(z), bool)  # a low outlier on any orientation's grid
    for angle in angles:
        if angle % 360.0 == 0.0:
            grid, xr, yr = base, x, y
        else:
            xr, yr = _rotate(x, y, angle)
            grid = lowest_grid(xr, yr, z, params.cell)
        units.stage("filter" if len(angles) == 1 else f"filter at {angle:g} degrees")
        classes = cell_classes(spec, CellHeights.of(grid), params, spacing=spacing)
        units.stage("classify", len(z))
        pm, ig = classes.classify(xr, yr, z, grid.cell_index)
        units.advance(len(z))
        low |= pm == MARK_LOW_OUTLIER
        if point_marks is None:
            point_marks, is_ground = pm, ig
        else:
            is_ground &= ig
            np.maximum(point_marks, pm, out=point_marks)
        log.debug("%s at %g deg: %d of %d points ground", algorithm, angle, int(ig.sum()), len(ig))
        del classes, pm, ig

    assert point_marks is not None and is_ground is not None  # one angle at least
    point_marks[low] = MARK_LOW_OUTLIER
    # the mark matrix reported is that of the axis-aligned grid
    return FilterResult(point_marks, is_ground, base, _cell_marks(base, point_marks), angles, algorithm, params)


def _cell_marks(grid: LowestGrid, point_marks: np.ndarray) -> np.ndarray:
    """Mark matrix of a grid: each cell the mark of its lowest point, empty cells interpolated."""
    real = ~grid.empty
    marks = np.full(grid.z.shape, MARK_INTERPOLATED, np.int32)
    marks[real] = point_marks[grid.lowest[real]]
    return marks


def cell_grid(x: np.ndarray, y: np.ndarray, z: np.ndarray, params: PointFilterParams, extent: Extent | None = None,
              leave_out: np.ndarray | None = None) -> LowestGrid:
    """The lowest point of each of a point filter's cells (``params.cell_shape()``), the points
    ``leave_out`` left out (a cell holding nothing else is empty). Rectangular cells are square
    cells of the width over y divided by height / width (the result's ``y_stretch``), so every
    grid tool applies unchanged."""
    width, height = params.cell_shape()
    stretch = height / width
    if extent is not None and stretch != 1.0:
        extent = (extent[0], extent[1] / stretch, extent[2], extent[3] / stretch)
    return _lowest_without(x, y / stretch if stretch != 1.0 else y, z, leave_out, width, None, extent)


def _point_filter(spec: FilterSpec, x: np.ndarray, y: np.ndarray, z: np.ndarray, params: PointFilterParams,
                  extent: Extent | None, spacing: float | None) -> FilterResult:
    """Run a point filter and report its marks on the grid of its own cells (for ``--data-mode
    center`` and the mark matrix): a cell takes the mark of its lowest point."""
    units.stage("grid")
    set_aside = low_outlier_points(x, y, z, params, extent, spacing)
    # the filter's own grid, gridded once for it and the report; low outliers are no cell's lowest
    grid = cell_grid(x, y, z, params, extent, leave_out=set_aside)
    if len(z) == 0:
        point_marks = np.zeros(0, np.int32)
    else:
        units.stage("filter")  # a point filter classifies every point as it filters
        point_marks = np.asarray(spec.fn(x, y, z, grid, params), dtype=np.int32)
        if point_marks.shape != z.shape:
            raise AssertionError(f"filter {spec.name!r} returned {point_marks.shape} marks for {len(z)} points")
        if set_aside is not None:
            point_marks[set_aside] = MARK_LOW_OUTLIER
    width, height = params.cell_shape()
    return FilterResult(point_marks, point_marks == MARK_GROUND, grid, _cell_marks(grid, point_marks), (0.0,),
                        spec.name, params, height / width)



def refuse_not_finite(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> None:
    """Raise :class:`DataError` when a point holds NaN or infinity, saying how many do and the
    first of them with its value: points held in memory have no line to name, so its index (from
    0) stands for one."""
    bad = ~(np.isfinite(x) & np.isfinite(y) & np.isfinite(z))
    if not bad.any():
        return
    first = int(np.argmax(bad))
    name, value = next((n, v[first]) for n, v in (("x", x), ("y", y), ("z", z)) if not np.isfinite(v[first]))
    raise DataError(f"points with non-finite coordinates cannot be filtered: {int(bad.sum()):,} of {len(z):,}, the "
                    f"first point {first:,} (counting from 0) with {name} = {value}")
