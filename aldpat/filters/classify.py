"""Classes of points from a filtered grid: the grid stage's decision (:class:`CellClasses`, on the
lowest heights of the cells, :class:`CellHeights`) and the classes it gives any point of the
gridded area, and what a filter run returns (:class:`FilterResult`).

The lowest point of a cell is classified by the cell's mark, every other point by its height above
the final ground surface (ground within ``ground_tolerance``), so that results compare point for
point with other tools. The surface at a point is interpolated bilinearly between the centres of
the ground cells among the four around it; a point with no ground cell around it lies amid removed
cells and is not ground.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aldpat.core.compiled import PREFETCH_BLOCK, compiled, prefetch_cells
from aldpat.core.height_codes import FloatHeights, Heights
from aldpat.core.low_points import NO_LOW_POINTS, LowPoints
from aldpat.core.lowest_grid import CellGridSpec, LowestGrid, fill_nearest, flat_cell_indices
from aldpat.core.rise import compiled_decoding
from aldpat.core.surface_check import SurfaceTest
from aldpat.filters.marks import MARK_GROUND, MARK_INTERPOLATED, MARK_LOW_OUTLIER, MARK_NON_GROUND

#: Points classified per block when comparing with the ground surface (bounds temporaries).
_CHUNK = 1 << 21


@dataclass
class CenterPoints:
    """One point per non-empty cell at the cell centre (``--data-mode center``, manual task 8)."""

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    index: np.ndarray  # the lowest point of the cell (to copy its other attributes)
    is_ground: np.ndarray
    marks: np.ndarray


@dataclass
class FilterResult:
    """Classes of every point plus the grid they came from.

    Attributes
    ----------
    point_marks : int32 (n,)
        0 for ground; for non-ground the window at which the point (or its cell) was removed.
    is_ground : bool (n,)
    grid : LowestGrid
        the axis-aligned lowest-point grid (``grid.cell_index`` is every point's cell).
    marks : int32 (rows, cols)
        mark matrix on that grid: the lowest point's mark, ``MARK_INTERPOLATED`` where empty.
    angles : rotation angles (degrees) the data were filtered at.
    """

    point_marks: np.ndarray
    is_ground: np.ndarray
    grid: LowestGrid
    marks: np.ndarray
    angles: tuple[float, ...] = (0.0,)
    algorithm: str = ""
    params: object = None
    #: cell height / width: a point filter with rectangular cells grids y / stretch on square cells
    y_stretch: float = 1.0

    @property
    def cell_index(self) -> np.ndarray:
        return self.grid.cell_index

    @property
    def count(self) -> int:
        return len(self.is_ground)

    @property
    def surface(self) -> np.ndarray:
        """Final ground surface: ground cells' lowest elevations, every other cell filled from
        the nearest ground cell (all NaN when nothing is ground). Computed on demand."""
        return ground_surface(self.grid.z, (self.marks == MARK_GROUND) & ~self.grid.empty)

    def center(self) -> CenterPoints:
        """ALDPAT's ``center`` data mode: the lowest point of each cell moved to the centre."""
        g = self.grid
        real = ~g.empty
        rr, cc = np.nonzero(real)
        xc, yc = g.spec.centers()
        index = g.lowest[real]
        return CenterPoints(
            x=xc[cc], y=yc[rr] * self.y_stretch, z=g.z[real], index=index,
            is_ground=self.is_ground[index], marks=self.point_marks[index],
        )


@compiled(nogil=True)
def _surface_decides(marks: np.ndarray, ground: np.ndarray, cell: np.ndarray, z: np.ndarray, low_cells: np.ndarray,
                     low_limits: np.ndarray) -> None:  # pragma: no cover - compiled
    """The marks of points the final surface test decided (``ground``): ground where it says so,
    ``MARK_NON_GROUND`` for a point it does not take whose mark said ground; then a point below
    its cell's limit (``low_cells``, ascending, and ``low_limits``: :class:`LowPoints`) a low
    outlier, not ground -- :meth:`LowPoints.below`'s leftmost binary search, point by point."""
    n = len(low_cells)
    for k in range(len(marks)):
        if ground[k]:
            marks[k] = MARK_GROUND
        elif marks[k] == MARK_GROUND:
            marks[k] = MARK_NON_GROUND
        if n:
            a, b = 0, n  # the first of low_cells not below the point's cell (np.searchsorted, left)
            while a < b:
                m = (a + b) >> 1
                if low_cells[m] < cell[k]:
                    a = m + 1
                else:
                    b = m
            if a == n:
                a = 0
            if low_cells[a] == cell[k] and z[k] < low_limits[a]:
                marks[k] = MARK_LOW_OUTLIER
                ground[k] = False


def ground_surface(z: np.ndarray, ground: np.ndarray) -> np.ndarray:
    """Ground cells' elevations, every other cell filled from its nearest ground cell."""
    if not ground.any():
        return np.full(z.shape, np.nan)
    return fill_nearest(np.where(ground, z, np.nan), ~ground)


@dataclass
class CellHeights:
    """The lowest height of every cell of a grid, kept as codes (:mod:`aldpat.core.height_codes`).

    ``owned``: the codes belong to the filter run, which may fill the empty cells in place
    (the mark matrix then says which they were); otherwise they are copied first.
    """

    spec: CellGridSpec
    codes: np.ndarray
    heights: Heights
    owned: bool = False
    spacing: float | None = None  # the points' mean spacing, where known

    @classmethod
    def of(cls, grid: LowestGrid) -> CellHeights:
        """The float64 heights of a lowest-point grid (NaN where empty), not owned."""
        return cls(grid.spec, grid.z, FloatHeights())


@dataclass
class CellClasses:
    """What the grid stage decided, and the classes it gives any point of the gridded area.

    :meth:`classify` takes the points in any number of pieces (a whole array, or a file read
    chunk by chunk: the same points get the same classes either way).
    """

    cells: CellHeights
    marks: np.ndarray  # (rows, cols) int16 or int32, MARK_INTERPOLATED where empty
    tolerance: float
    origin: tuple[float, float] | None = None
    surface: SurfaceTest | None = None
    low: LowPoints = NO_LOW_POINTS  # the low outliers' cells, left out of the grid stage

    def classify(self, x: np.ndarray, y: np.ndarray, z: np.ndarray, cell_index: np.ndarray | None = None, *,
                 marks: bool = True
                 ) -> tuple[np.ndarray, np.ndarray]:
        """(point marks int32, is ground) of points x, y, z (``cell_index``: their flat cells when
        already known). ``marks=False``: the marks are not wanted, only the classes (with the
        final surface test the points above their cell's lowest are then not compared with the
        ground cells, which only their marks would use).

        The lowest point of a cell takes the cell's mark. Points exactly as low share it: which of
        them the grid kept is an accident of input order, and classes must not depend on it. Any
        other point is ground when it lies no more than ``tolerance`` above the final ground
        surface, interpolated bilinearly between ground cell centres so that a sloping cell does
        not push its upper points out of the ground. With the final surface test
        (``surface``), that test decides every point's class instead. A point below the limit
        of a low outlier's cell (``low``) is a low outlier whatever the rest says.
        """
        spec = self.cells.spec
        n = len(z)
        point_marks = np.empty(n, np.int32)
        is_ground = np.empty(n, bool)
        flat_marks = self.marks.ravel()
        for a in range(0, n, _CHUNK):
            b = min(n, a + _CHUNK)
            xs, ys, zs = x[a:b], y[a:b], z[a:b]
            ci = flat_cell_indices(xs, ys, spec, origin=self.origin) if cell_index is None else cell_index[a:b]
            pm = flat_marks[ci].astype(np.int32)
            if marks or self.surface is None:  # else the surface test alone decides
                self._lowest_or_above(ci, xs, ys, zs, pm)
            if self.surface is not None:
                # the test's answer and the low outliers, in one pass over the chunk's points
                ig = self.surface.test(xs, ys, zs)
                _surface_decides(pm, ig, ci, np.ascontiguousarray(zs, dtype=np.float64), self.low.cells,
                                 self.low.limits)
            else:
                ig = pm == MARK_GROUND
                if len(self.low):
                    low = self.low.below(ci, zs)
                    pm[low] = MARK_LOW_OUTLIER
                    ig[low] = False
            del ci
            point_marks[a:b] = pm
            is_ground[a:b] = ig
        return point_marks, is_ground

    def _lowest_or_above(self, ci: np.ndarray, x: np.ndarray, y: np.ndarray, z: np.ndarray,
                         pm: np.ndarray) -> None:
        """``pm`` (the points' cell marks) of the points that are not their cell's lowest: ground
        within ``tolerance`` of the ground surface, else at least ``MARK_NON_GROUND``
        (:func:`_lowest_or_above_points`)."""
        spec = self.cells.spec
        scaled, scale, offset = compiled_decoding(self.cells.heights.decode)
        x, y, z = (np.ascontiguousarray(v, dtype=np.float64) for v in (x, y, z))
        _lowest_or_above_points(np.ascontiguousarray(ci), x, y, z, self.marks.ravel(), self.cells.codes.ravel(),
                                scaled, scale, offset, float(spec.x0), float(spec.y0), float(spec.cell), spec.rows,
                                spec.cols, float(self.tolerance), pm)


@compiled(nogil=True)
def _lowest_or_above_points(ci: np.ndarray, x: np.ndarray, y: np.ndarray, z: np.ndarray, marks: np.ndarray,
                            codes: np.ndarray, scaled: bool, scale: float, offset: float, x0: float, y0: float,
                            cell: float, rows: int, cols: int, tolerance: float,
                            pm: np.ndarray) -> None:  # pragma: no cover - compiled
    """:meth:`CellClasses.classify`'s points above their cell's lowest, point by point. A point
    is its cell's lowest when its height is the cell's (``code * scale + offset`` unfused, or the
    code itself when not ``scaled``) and the cell was not empty; any other point is compared with
    the ground surface: bilinear between the centres of the four cells around it, over those that
    are ground (``marks`` 0), the weights renormalised; where none is ground (or none weighs) the
    surface is not there and the point is not ground -- it sits amid removed or empty cells. Local
    by design: a nearest-ground search over the whole grid would cost a distance transform a run.

    The operations are numpy's, in numpy's order, so that the classes are the same to the bit
    whichever form computes them (``tests/filters/test_classify.py`` holds the numpy form). The
    cells of each block of points are asked for while the block before is classified
    (:func:`aldpat.core.compiled.prefetch_cells`)."""
    last_c, last_r = max(cols - 2, 0), max(rows - 2, 0)
    dc = 1 if cols > 1 else 0
    dr = cols if rows > 1 else 0
    n = len(z)
    grids = (marks.reshape(rows, cols), codes.reshape(rows, cols))
    prefetch_cells(grids, x, y, 0, min(n, PREFETCH_BLOCK), x0, y0, cell)
    for first in range(0, n, PREFETCH_BLOCK):
        stop = min(n, first + PREFETCH_BLOCK)
        prefetch_cells(grids, x, y, stop, min(n, stop + PREFETCH_BLOCK), x0, y0, cell)
        for k in range(first, stop):
            own = codes[ci[k]] * scale if scaled else np.float64(codes[ci[k]])
            own = own + offset if scaled else own
            if z[k] == own and marks[ci[k]] != MARK_INTERPOLATED:
                continue  # the cell's lowest point: its mark is the cell's
            fc = min(max((x[k] - x0) / cell - 0.5, 0.0), cols - 1.0)
            fr = min(max((y[k] - y0) / cell - 0.5, 0.0), rows - 1.0)
            c0 = min(int(fc), last_c)  # fc >= 0: truncation is the floor
            r0 = min(int(fr), last_r)
            tc, tr = fc - c0, fr - r0
            one_c, one_r = 1.0 - tc, 1.0 - tr
            i00 = r0 * cols + c0
            num = 0.0
            den = 0.0
            for corner in range(4):
                idx = i00 + (dc if corner & 1 else 0) + (dr if corner & 2 else 0)
                ground = marks[idx] == MARK_GROUND  # empty cells carry MARK_INTERPOLATED
                w = (tr if corner & 2 else one_r) * (tc if corner & 1 else one_c)
                w = w * (1.0 if ground else 0.0)
                den += w
                height = codes[idx] * scale if scaled else np.float64(codes[idx])
                height = height + offset if scaled else height
                w = w * (height if ground else 0.0)  # another cell's height may be anything
                num += w
            if den != 0.0 and z[k] - num / den <= tolerance:
                pm[k] = MARK_GROUND
            else:
                pm[k] = max(pm[k], MARK_NON_GROUND)
