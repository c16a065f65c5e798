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

from aldpat.core.compiled import compiled
from aldpat.core.height_codes import FloatHeights, Heights
from aldpat.core.low_points import NO_LOW_POINTS, LowPoints
from aldpat.core.lowest_grid import CellGridSpec, LowestGrid, fill_nearest, flat_cell_indices
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
        codes = self.cells.codes.ravel()
        decode = self.cells.heights.decode
        for a in range(0, n, _CHUNK):
            b = min(n, a + _CHUNK)
            xs, ys, zs = x[a:b], y[a:b], z[a:b]
            ci = flat_cell_indices(xs, ys, spec, origin=self.origin) if cell_index is None else cell_index[a:b]
            cm = flat_marks[ci]
            pm = cm.astype(np.int32)
            if marks or self.surface is None:  # else the surface test alone decides
                # a cell left out of the grid (empty, or a low outlier's) has no lowest point
                other = np.flatnonzero((zs != decode(codes[ci])) | (cm == MARK_INTERPOLATED))
                if len(other):
                    h = zs[other] - self._ground_height(xs[other], ys[other])
                    ok = h <= self.tolerance  # NaN (no ground around) compares False
                    pm[other] = np.where(ok, MARK_GROUND, np.maximum(pm[other], MARK_NON_GROUND))
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

    def _ground_height(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Ground surface at points x, y: bilinear between the centres of the four cells around
        each point, over those that are ground, weights renormalised.

        NaN where none of the four is ground: such a point sits in a cell whose lowest point was
        removed, amid removed or empty cells, so it cannot be ground either. Local by design -- a
        nearest-ground search over the whole grid would cost a distance transform per run.
        """
        spec = self.cells.spec
        flat_marks = self.marks.ravel()
        codes = self.cells.codes.ravel()
        # in place wherever possible: on large inputs fresh scratch arrays cost more than arithmetic
        fc = np.subtract(x, spec.x0)
        fc /= spec.cell
        fc -= 0.5
        fr = np.subtract(y, spec.y0)
        fr /= spec.cell
        fr -= 0.5
        np.clip(fc, 0.0, max(spec.cols - 1.0, 0.0), out=fc)
        np.clip(fr, 0.0, max(spec.rows - 1.0, 0.0), out=fr)
        c0 = fc.astype(np.int64)
        np.minimum(c0, max(spec.cols - 2, 0), out=c0)
        r0 = fr.astype(np.int64)
        np.minimum(r0, max(spec.rows - 2, 0), out=r0)
        fc -= c0  # now the fraction across the cell pair (tc)
        fr -= r0  # (tr)
        dc = 1 if spec.cols > 1 else 0
        dr = spec.cols if spec.rows > 1 else 0
        i00 = r0
        i00 *= spec.cols
        i00 += c0
        del c0
        num = np.zeros(len(x))
        den = np.zeros(len(x))
        one_c = 1.0 - fc
        one_r = 1.0 - fr
        for offset, wr, wc in ((0, one_r, one_c), (dc, one_r, fc), (dr, fr, one_c), (dr + dc, fr, fc)):
            idx = i00 + offset if offset else i00
            ground = flat_marks[idx] == MARK_GROUND  # empty cells carry MARK_INTERPOLATED
            w = wr * wc
            w *= ground  # 0 unless the corner cell is ground
            den += w
            height = self.cells.heights.decode(codes[idx])
            height[~ground] = 0.0  # another cell's height may be anything (NaN where empty)
            w *= height
            num += w
        with np.errstate(invalid="ignore", divide="ignore"):
            return num / den
