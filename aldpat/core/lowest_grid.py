"""Points to a grid of lowest points, and nearest-neighbour filling of empty cells.

Cui (2013) ch. 3 "Resampling Data": each grid cell keeps one representative point,
the lowest one, and the filters treat the cell as that point. §4.2.1 "Grid-Based Nearest
Neighbor Interpolation": an empty cell takes the elevation of the nearest non-empty cell.

Grid convention (shared by every grid filter): ``z[row, col]``, ``col`` increases with x (east)
and ``row`` with y (north); cell ``(r, c)`` covers ``[x0 + c*cell, x0 + (c+1)*cell) x
[y0 + r*cell, y0 + (r+1)*cell)``. ``x0`` and ``y0`` are whole multiples of ``cell`` from the
origin (the grid alignment every grid task shares), so tiles gridded apart share their cell boundaries.
"""

from __future__ import annotations

import functools
import logging
import math
from dataclasses import dataclass

import numpy as np

from aldpat.core.grid_extent import steps_between, steps_from_origin
from aldpat.core.resources import check_memory, count_text
from aldpat.errors import DataError

log = logging.getLogger(__name__)

#: Refuse grids larger than this many cells: a stray far-away point or a tiny cell would
#: otherwise exhaust memory before anything useful happens.
MAX_CELLS = 400_000_000
#: what a cell of the filters' grids takes while they run (the lowest point's height and index,
#: the opened and filled surfaces, marks), checked against the memory there is before they are made
BYTES_PER_CELL = 48


@dataclass(frozen=True)
class CellGridSpec:
    """Where a grid of cells lies: lower-left corner, square cell size and shape (cells, each
    holding its lowest point; :class:`aldpat.core.grid_extent.GridSpec` is the grid of *nodes*
    that ``aldpat grid`` writes)."""

    x0: float
    y0: float
    cell: float
    rows: int
    cols: int

    @property
    def shape(self) -> tuple[int, int]:
        return (self.rows, self.cols)

    @property
    def size(self) -> int:
        return self.rows * self.cols

    def centers(self) -> tuple[np.ndarray, np.ndarray]:
        """x of each column centre, y of each row centre."""
        xc = self.x0 + (np.arange(self.cols) + 0.5) * self.cell
        yc = self.y0 + (np.arange(self.rows) + 0.5) * self.cell
        return xc, yc


@dataclass
class LowestGrid:
    """The lowest point of every cell.

    Attributes
    ----------
    spec : CellGridSpec
    z : float64 array (rows, cols)
        elevation of the lowest point; NaN where the cell is empty.
    lowest : int32 array (rows, cols) (int64 beyond 2**31 points)
        index (into the input arrays) of the lowest point; -1 where empty.
        Ties go to the smallest index, so the result does not depend on chance.
    cell_index : int64 array (n,)
        flat cell index ``row * cols + col`` of every input point.
    """

    spec: CellGridSpec
    z: np.ndarray
    lowest: np.ndarray
    cell_index: np.ndarray

    @functools.cached_property
    def empty(self) -> np.ndarray:
        """Cells without a point (computed once)."""
        return self.lowest < 0


#: An extent ``(xmin, ymin, xmax, ymax)`` a grid is to cover, as the points' own would be.
Extent = tuple[float, float, float, float]


def grid_spec(x: np.ndarray, y: np.ndarray, cell: float, *, origin: tuple[float, float] | None = None,
              extent: Extent | None = None) -> CellGridSpec:
    """The smallest aligned grid covering the points, or the cells of ``extent`` (which must hold
    them): a chunk of a file gets the whole file's cells there, its edges where the file's are."""
    if not cell > 0:
        raise ValueError(f"cell must be > 0, got {cell!r}")
    ox, oy = origin if origin is not None else (0.0, 0.0)
    if len(x) == 0 and extent is None:
        return CellGridSpec(ox, oy, float(cell), 0, 0)
    xmin, ymin, xmax, ymax = extent if extent is not None else (
        float(np.min(x)), float(np.min(y)), float(np.max(x)), float(np.max(y)))
    steps_between(xmin, xmax, cell, "x")  # the refusal names the data's extent, not the origin's distance
    steps_between(ymin, ymax, cell, "y")
    c0 = math.floor(steps_from_origin(ox, xmin, cell, "x"))
    c1 = math.floor(steps_from_origin(ox, xmax, cell, "x"))
    r0 = math.floor(steps_from_origin(oy, ymin, cell, "y"))
    r1 = math.floor(steps_from_origin(oy, ymax, cell, "y"))
    rows, cols = r1 - r0 + 1, c1 - c0 + 1
    if rows * cols > MAX_CELLS:
        raise DataError(
            f"a {rows} x {cols} grid of {cell:g} m cells is too large; use a larger cell or tile the data"
        )
    check_memory(rows * cols * BYTES_PER_CELL, f"a {rows} x {cols} grid ({count_text(rows * cols)} cells) of "
                 f"{cell:g} m", "use a larger cell, --chunk, or tile the data (aldpat tile)")
    return CellGridSpec(ox + c0 * cell, oy + r0 * cell, float(cell), rows, cols)


def floor_index(v: np.ndarray, origin: float, cell: float) -> np.ndarray:
    """floor((v - origin) / cell) as int64, in one scratch array (fresh pages are slow here)."""
    t = np.subtract(np.asarray(v, dtype=np.float64), origin)
    t /= cell
    np.floor(t, out=t)
    return t.astype(np.int64)


def cell_indices(x: np.ndarray, y: np.ndarray, spec: CellGridSpec, *, origin: tuple[float, float] | None = None
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Row and column of every point.

    Indices are computed from the origin, not from ``x0``, so a point falls in the same
    absolute cell whatever part of the data is gridded with it.
    """
    ox, oy = origin if origin is not None else (0.0, 0.0)
    c0 = round((spec.x0 - ox) / spec.cell)
    r0 = round((spec.y0 - oy) / spec.cell)
    col = floor_index(x, ox, spec.cell) - c0
    row = floor_index(y, oy, spec.cell) - r0
    # floor((x - ox) / cell) can land one cell outside at the extreme after rounding
    np.clip(col, 0, spec.cols - 1, out=col)
    np.clip(row, 0, spec.rows - 1, out=row)
    return row, col


def flat_cell_indices(x: np.ndarray, y: np.ndarray, spec: CellGridSpec, *,
                      origin: tuple[float, float] | None = None) -> np.ndarray:
    """Flat cell index ``row * cols + col`` (int64) of every point (:func:`cell_indices`), in one
    compiled pass over the points (the same operations: the second pass of a streamed filter
    finds every point's cell, and numpy's eight passes over a chunk cost more than the rest of
    its classifying but the surface test)."""
    from aldpat.core.nearest_fill import flat_cells

    ox, oy = origin if origin is not None else (0.0, 0.0)
    x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    if x.shape != y.shape or x.ndim != 1:
        flat, col = cell_indices(x, y, spec, origin=origin)
        flat *= spec.cols
        flat += col
        return flat
    return flat_cells(x, y, float(ox), float(oy), float(spec.cell), round((spec.x0 - ox) / spec.cell),
                      round((spec.y0 - oy) / spec.cell), spec.rows, spec.cols)


def rows_per_block(cols: int, cells: int = 1 << 20) -> int:
    """Rows of a grid ``cols`` wide to take at a time for about ``cells`` cells (at least one):
    a block's scratch stays small whatever the grid."""
    return max(1, cells // max(1, cols))


def lowest_grid(x: np.ndarray, y: np.ndarray, z: np.ndarray, cell: float, *,
                origin: tuple[float, float] | None = None, extent: Extent | None = None) -> LowestGrid:
    """Keep the lowest point of every cell (dissertation ch. 3, §3.1 "Resampling Data").

    Vectorized: a running minimum per cell with ``np.minimum.at``, then the index of the point
    that reached it (no sort, no Python loop over points).
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    z = np.asarray(z, dtype=np.float64)
    if not (len(x) == len(y) == len(z)):
        raise ValueError("x, y and z must have the same length")
    spec = grid_spec(x, y, cell, origin=origin, extent=extent)
    if len(x) == 0:
        shape = spec.shape
        return LowestGrid(spec, np.full(shape, np.nan), np.full(shape, -1, np.int32), np.zeros(0, np.int64))
    flat = flat_cell_indices(x, y, spec, origin=origin)
    zmin = np.full(spec.size, np.inf)
    np.minimum.at(zmin, flat, z)
    hit = np.flatnonzero(z == zmin[flat])
    # int32 halves the largest per-cell array; MAX_CELLS keeps cell counts far below 2**31
    lowest: np.ndarray = np.full(spec.size, -1, np.int32 if len(x) < 2**31 else np.int64)
    # several points may share the minimum: assigning in reverse order leaves the smallest index
    lowest[flat[hit[::-1]]] = hit[::-1]
    zmin[lowest < 0] = np.nan
    log.debug("gridded %d points into %d x %d cells of %g", len(x), spec.rows, spec.cols, cell)
    return LowestGrid(spec, zmin.reshape(spec.shape), lowest.reshape(spec.shape), flat)


def fill_nearest(z: np.ndarray, empty: np.ndarray | None = None, *, out: np.ndarray | None = None,
                 spacing: np.ndarray | None = None) -> np.ndarray:
    """Fill empty cells with the value of the nearest non-empty cell.

    Dissertation §4.2.1 "Grid-Based Nearest Neighbor Interpolation" (the layer-by-layer
    search of Fig. 4-1 finds the Euclidean-nearest cell; the exact Euclidean feature transform
    of :mod:`aldpat.core.nearest_fill` gives the same answer a row at a time, without scratch
    the size of the grid).

    Parameters
    ----------
    z : 2-D array (float64 heights, or any dtype of values such as height codes)
    empty : bool array of the same shape, optional
        cells to fill; default: the NaN cells of ``z``.
    out : array, optional
        where the result goes; ``out=z`` fills in place (no second grid).
    spacing : uint8 array of the grid's shape, optional
        receives every cell's distance (cells, rounded up, at most 255) from the cell it was
        filled from: 0 where the cell holds a value. How far apart the points behind two
        neighbouring cells are (:mod:`aldpat.core.segments`).

    Returns
    -------
    The filled grid (a new array unless ``out`` is given). If no cell holds a value, the values
    are returned unchanged.
    """
    z = np.asarray(z)
    if not (np.issubdtype(z.dtype, np.floating) or np.issubdtype(z.dtype, np.integer)):
        z = z.astype(np.float64)
    if empty is None:
        empty = np.isnan(z)
    else:
        empty = np.asarray(empty, dtype=bool)
        if empty.shape != z.shape:
            raise ValueError(f"empty mask shape {empty.shape} differs from grid shape {z.shape}")
    if out is None:
        out = z.copy()
    elif out is not z:
        np.copyto(out, z)
    if not empty.any() or empty.all():
        if spacing is not None:
            spacing[...] = 0
        return out
    from aldpat.core.nearest_fill import fill_grid
    from aldpat.core.threads import thread_budget

    # a row at a time, in place: a cell's nearest non-empty cell is itself when it holds a value,
    # so the values read are never ones written
    fill_grid(out, np.ascontiguousarray(empty), spacing if spacing is not None else np.zeros((1, 1), np.uint8),
              spacing is not None, thread_budget())
    return out
