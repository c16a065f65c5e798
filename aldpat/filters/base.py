"""The grid-filter registry and the driver that turns a grid filter into point classes.

Every ground filter that works on a grid of lowest points is a function
``fn(z, empty, params) -> marks`` registered with :func:`register_filter`:

* ``z`` is the lowest-point grid (dissertation ch. 3) with empty cells already filled by
  nearest-neighbour interpolation (dissertation §4.2.1);
* ``empty`` is the boolean mask of cells that had no point;
* the returned int32 *mark matrix* (dissertation §5.2.2, Table 5-1) holds 0 for ground and,
  for a removed cell, the (half) window size in cells at which it was removed. Cells where
  ``empty`` is true become :data:`MARK_INTERPOLATED` whatever ``fn`` returns.

:func:`ground_filter` grids the points, fills empties, calls ``fn`` and classifies every point:
the lowest point of a cell by the cell's mark, every other point by its height above the final
ground surface (ground within ``ground_tolerance``), so that results compare point for point
with other tools. The surface at a point is interpolated bilinearly between the
centres of the ground cells among the four around it; a point with no ground cell around it
lies amid removed cells and is not ground.
"""

from __future__ import annotations

import difflib
import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from aldpat.core import units
from aldpat.core.height_codes import FloatHeights, Heights
from aldpat.core.low_points import NO_LOW_POINTS, LowPoints, find_low_points, point_spacing
from aldpat.core.lowest_grid import CellGridSpec, Extent, LowestGrid, fill_nearest, flat_cell_indices, lowest_grid
from aldpat.core.memory import one_arena, release_free_memory
from aldpat.core.surface_test import SurfaceTest
from aldpat.errors import DataError, ParamError
from aldpat.filters.survey import ExistingClassesOption
from aldpat.options import ChunkOption, CrsOption, OriginOption
from aldpat.params import Checked, SharedOption, param, validate_instance

log = logging.getLogger(__name__)

#: Mark of a real cell kept as ground (dissertation Table 5-1).
MARK_GROUND = 0
#: Mark of an interpolated (empty) cell (dissertation Table 5-1); never written out as a point.
MARK_INTERPOLATED = -7777
#: Mark given to a point that is not the lowest of its cell, lies above the ground surface by
#: more than ``ground_tolerance`` and sits in a cell whose lowest point is ground: no window
#: removed it, so it gets the smallest window a filter can use.
MARK_ABOVE_SURFACE = 1

#: Mark of a cell removed by the raised-segment test (an object larger than any window).
MARK_RAISED_SEGMENT = 9000
#: Mark of a point set aside as a low outlier before filtering.
MARK_LOW_OUTLIER = -9000
#: Points classified per block when comparing with the ground surface (bounds temporaries).
_CHUNK = 1 << 21


@dataclass(frozen=True)
class FilterOutputOption(SharedOption):
    """What ``aldpat filter`` writes (the filter functions ignore these)."""

    result: str | None = param(
        None, "what to write: terrain points, non-terrain points, both files, or every point classified "
        "(in input order with every attribute: ground LAS class 2, a former 2 or 0 that is not ground 1, low "
        "outliers 7, other classes kept; text: a column class); default: classified for a LAS/LAZ output, "
        "terrain for text", choices=("terrain", "nonterrain", "both", "classified"), manual="Result Mode")
    marks: bool = param(False, "add each point's mark: 0 for ground, else the half window (cells) "
                        "at which it was removed (column / LAS extra byte 'mark')", level="advanced")


@dataclass(frozen=True)
class LowOutlierOption(SharedOption):
    """The low-outlier test (:mod:`aldpat.core.low_points`), taken by every ground filter."""

    low_outliers: float | None = param(
        2.0,
        "low outliers (multipath, a pulse through a window) take no part in finding ground and are "
        "not ground (class 7 in classified output): points this far below every point around them "
        "and below the floor of the terrain within low_outlier_reach (further where the heights "
        "there spread more; after dissertation §4.1.1); none: off",
        unit="m", gt=0,
    )
    low_outlier_window: int = param(
        2, "a clump of low points at most twice this many cells (or point spacings, where the "
        "points are sparser than the cells) across is a low outlier; a wider hollow is terrain",
        unit="cells", ge=1, level="advanced",
    )
    low_outlier_reach: float = param(
        20.0, "the terrain a low outlier must lie below: a plane through the points within this "
        "distance, raised to the height a tenth of them reach",
        unit="m", gt=0, level="advanced",
    )


@dataclass(frozen=True)
class RaisedSegmentOption(SharedOption):
    """The raised-segment test (:mod:`aldpat.core.segments`), taken by the grid filters and
    ``atin``: objects larger than any window or seed square, found by the steps around them."""

    object_step: float = param(
        0.0,
        "raised-segment test: cells whose heights differ by more than this split the grid into "
        "segments, and a segment standing above its surroundings is an object whatever its size "
        "(buildings larger than the filter's largest window or seed square); 0: off",
        unit="m", ge=0, level="advanced",
    )
    object_share: float = param(
        0.6, "share of a segment's perimeter steps that must go down from it for it to be an object",
        ge=0, le=1, level="advanced",
    )
    object_span: float = param(
        0.0,
        "with the raised-segment test: a level run of cells along a row or column, bounded at both "
        "ends by steps down from it and at most this long, is an object (a bridge deck across its "
        "width, joined to the ramps at its ends); 0: off",
        unit="m", ge=0, level="advanced",
    )


@dataclass(frozen=True)
class GroundParams(RaisedSegmentOption, LowOutlierOption, ExistingClassesOption, FilterOutputOption, ChunkOption,
                   OriginOption, CrsOption, Checked):
    """Parameters every grid filter shares; each filter's params class subclasses it."""

    cell: float = param(1.0, "grid cell size", unit="m", gt=0, manual="Cell size")
    data_mode: str = param(
        "real",
        "output points at their own x, y (real) or one point per cell at the cell centre (center)",
        choices=("real", "center"),
        manual="Data Mode", level="advanced",
    )
    ground_tolerance: float = param(
        0.3,
        "a non-lowest point of a cell is ground within this height of the final ground surface",
        unit="m",
        ge=0, level="advanced",
    )
    surface_threshold: float | None = param(
        None,
        "final test (SMRF): every point within this height of the interpolated ground surface, plus "
        "surface_slope x its local slope, is ground and every other point is not; none: off (the "
        "lowest point of a cell takes the cell's class, the others ground_tolerance)",
        unit="m", ge=0, level="advanced",
    )
    surface_slope: float = param(
        1.0, "slope scalar of the final test: metres of tolerance per unit of terrain slope", ge=0, level="advanced",
    )


@dataclass(frozen=True)
class PointFilterParams(LowOutlierOption, ExistingClassesOption, FilterOutputOption, ChunkOption, CrsOption, Checked):
    """Parameters every point filter shares (``slope``, ``ipf``, ``poly2``, ``atin``): filters that
    test points against their neighbours or a fitted surface rather than a mark matrix.

    Subclasses say which cells ``--data-mode center`` and the reported mark matrix use
    (:meth:`cell_shape`): the filter's own cells.
    """

    data_mode: str = param(
        "real",
        "output points at their own x, y (real) or one point per cell at the cell centre (center)",
        choices=("real", "center"),
        manual="Data Mode", level="advanced",
    )

    def cell_shape(self) -> tuple[float, float]:
        """Width and height of the filter's cells."""
        raise NotImplementedError


FilterFn = Callable[[np.ndarray, np.ndarray, object], np.ndarray]
#: A point filter: ``fn(x, y, z, grid, params) -> point marks`` (int32, 0 for ground); ``grid`` is
#: the lowest-point grid of the filter's own cells (:func:`cell_grid`).
PointFilterFn = Callable[[np.ndarray, np.ndarray, np.ndarray, LowestGrid, object], np.ndarray]


@dataclass(frozen=True)
class FilterSpec:
    """A registered filter: a grid filter (``fn`` on a mark matrix) or, when ``on_points``, a
    point filter (``fn(x, y, z, grid, params)`` returning every point's mark)."""

    name: str
    summary: str
    params: type
    fn: Callable[..., np.ndarray]  # a FilterFn, or a PointFilterFn when on_points
    #: params -> rotation angles in degrees (the manual's Rotate Angle / Rotate Times);
    #: ``None``: the data are filtered once, unrotated.
    rotations: Callable[[Any], Sequence[float]] | None = None
    on_points: bool = False
    #: ``noise(result, z, params)``: per point -1 low noise, +1 high noise, 0 neither, for a
    #: filter that finds noise rather than ground (``outlier``); ``None``: it finds none.
    noise: Callable[..., np.ndarray] | None = None
    #: ``reach(params) -> cells``: how far from a cell the cells its mark depends on may lie
    #: (the windows of the morphological steps, each opening reaching twice its half window);
    #: ``--chunk-buffer auto`` is this many cells. ``None``: the filter does not know.
    reach: Callable[[Any], int] | None = None
    #: ``buffer(params) -> metres``: for a filter without a bounded reach (a point filter whose
    #: steps spread without a limit), the chunk buffer ``--chunk-buffer auto`` gives it: measured,
    #: not proven (``bench/bench_chunks.py agree``).
    buffer: Callable[[Any], float] | None = None
    #: ``fn(codes, empty, params, in_place=..., decode=...)`` takes the filled grid as height
    #: codes (:mod:`aldpat.core.height_codes`; ``decode`` gives their heights), and may overwrite
    #: them when ``in_place``: the filter's working surface at the codes' size, no float64 copy.
    takes_codes: bool = False


#: Every registered grid filter by name (filled by importing :mod:`aldpat.filters`).
FILTERS: dict[str, FilterSpec] = {}


def register_filter(name: str, *, params: type, summary: str,
                    rotations: Callable[[Any], Sequence[float]] | None = None, on_points: bool = False,
                    noise: Callable[..., np.ndarray] | None = None, reach: Callable[[Any], int] | None = None,
                    buffer: Callable[[Any], float] | None = None, takes_codes: bool = False):
    """Decorator registering ``fn(z, empty, params) -> marks`` as the grid filter ``name``, or
    with ``on_points`` ``fn(x, y, z, grid, params) -> point marks`` as the point filter ``name``."""
    base = PointFilterParams if on_points else GroundParams
    if not (isinstance(params, type) and issubclass(params, base)):
        raise TypeError(f"filter {name!r}: params must subclass {base.__name__}")

    def deco(fn: Callable) -> Callable:
        if name in FILTERS and FILTERS[name].fn is not fn:
            raise ValueError(f"filter {name!r} is registered twice")
        FILTERS[name] = FilterSpec(name=name, summary=summary, params=params, fn=fn, rotations=rotations,
                                   on_points=on_points, noise=noise, reach=reach,
                                   buffer=buffer, takes_codes=takes_codes)
        return fn

    return deco


def get_filter(name: str) -> FilterSpec:
    """The registered filter ``name``; a :class:`ParamError` with a suggestion otherwise."""
    spec = FILTERS.get(name)
    if spec is None:
        hint = difflib.get_close_matches(name, list(FILTERS), n=1)
        did = f"; did you mean {hint[0]!r}?" if hint else ""
        raise ParamError(f"unknown filter {name!r} (known: {', '.join(sorted(FILTERS))}){did}")
    return spec


# ---------------------------------------------------------------------------- results


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


# ---------------------------------------------------------------------------- the driver


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

    def classify(self, x, y, z, cell_index: np.ndarray | None = None, *, marks: bool = True
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
            # a cell left out of the grid (empty, or a low outlier's) has no lowest point
            other = np.flatnonzero((zs != decode(codes[ci])) | (cm == MARK_INTERPOLATED))
            if len(other) and (marks or self.surface is None):
                h = zs[other] - self._ground_height(xs[other], ys[other])
                ok = h <= self.tolerance  # NaN (no ground around) compares False
                pm[other] = np.where(ok, MARK_GROUND, np.maximum(pm[other], MARK_ABOVE_SURFACE))
            if self.surface is not None:
                ig = self.surface.test(xs, ys, zs)
                pm[ig] = MARK_GROUND
                pm[~ig & (pm == MARK_GROUND)] = MARK_ABOVE_SURFACE
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


def _run_grid(spec: FilterSpec, cells: CellHeights, params, spacing: float | None) -> tuple[np.ndarray, LowPoints]:
    """Fill, find the low outliers, filter and return the cell mark matrix (int16 or int32) of
    one grid and the low outliers' cells (left out of the grid: marked as empty ones).

    Peak memory is what makes 1 m cells over a large survey possible, so the steps hold as
    little at once as they can: the empty cells are filled in the codes themselves when the
    run owns them (``empty`` remembers which they were), the filter gets the one float64 grid
    and may overwrite it, and it never sees a second copy.
    """
    one_arena()  # before the filter's threads start: their scratch is then returned with the rest
    empty = cells.heights.is_empty(cells.codes)
    filled = cells.codes if cells.owned else cells.codes.copy()
    low = find_low_outliers(cells, ~empty, params, spacing)  # on the cells as gridded
    empty.ravel()[low.cells] = True  # filled from their neighbours, as an empty cell is
    filled_from = np.empty(filled.shape, np.uint8) if params.object_step > 0 else None
    fill_nearest(filled, empty, out=filled, spacing=filled_from)
    raised = None
    if filled_from is not None:
        raised = raised_cells(filled, params, cells.spec.cell, filled_from, decode=cells.heights.decode)
        del filled_from
        release_free_memory()
    read_only = empty.view()
    read_only.flags.writeable = False
    if spec.takes_codes:
        # the cells' own codes are lent, not given: a filter that opens them in place copies them
        given = filled
        marks = np.asarray(spec.fn(given, read_only, params, in_place=given is not cells.codes,
                                   decode=cells.heights.decode))
    else:
        given = cells.heights.decode(filled)
        if given is cells.codes:  # float heights owned by the run: the filter gets a copy
            given = given.copy()
        marks = np.asarray(spec.fn(given, read_only, params))
    del filled
    if marks.shape != empty.shape:
        raise AssertionError(f"filter {spec.name!r} returned marks of shape {marks.shape}, grid is {empty.shape}")
    if marks.dtype not in (np.int16, np.int32) or not marks.flags.writeable or marks is given:
        marks = marks.astype(np.int32)
    del given
    release_free_memory()  # the filter's scratch, before the surface and the points' pass
    if raised is not None:
        marks[raised & (marks == MARK_GROUND)] = MARK_RAISED_SEGMENT
    marks[empty] = MARK_INTERPOLATED  # the marks say which cells were empty from here on
    return marks, low


def raised_cells(filled: np.ndarray, params, cell: float, filled_from: np.ndarray | None = None, *,
                 decode: Callable[[np.ndarray], np.ndarray] | None = None, levels: bool = True) -> np.ndarray:
    """The cells of objects found by the steps around them (``object_step``): raised segments
    (:mod:`aldpat.core.segments`, with a building's levels unless ``levels`` is false) and, with
    ``object_span``, raised spans (:mod:`aldpat.core.spans`). ``filled``: the lowest-point grid
    with its empty cells filled (heights, or codes ``decode`` turns into heights); ``filled_from``:
    each cell's distance from the cell it was filled from (``fill_nearest(..., spacing=)``)."""
    from aldpat.core.segments import raised_segments

    raised = raised_segments(filled, params.object_step, params.object_share, decode=decode, spacing=filled_from,
                             cell=cell, levels=levels)
    span = getattr(params, "object_span", 0.0)
    if span > 0:
        from aldpat.core.spans import raised_spans

        raised |= raised_spans(filled, params.object_step, int(span / cell), decode=decode, spacing=filled_from,
                               cell=cell)
    return raised


def find_low_outliers(cells: CellHeights, real: np.ndarray, params, spacing: float | None) -> LowPoints:
    """The low outliers of a grid (:mod:`aldpat.core.low_points`) with the test's parameters;
    none when ``low_outliers`` is off. ``spacing``: the input's point spacing."""
    if getattr(params, "low_outliers", None) is None:
        return NO_LOW_POINTS
    return find_low_points(cells.codes, cells.heights.decode, real, cells.spec,
                           origin=getattr(params, "origin", None), spacing=spacing, threshold=params.low_outliers,
                           window=params.low_outlier_window, reach=params.low_outlier_reach)


def cell_classes(spec: FilterSpec, cells: CellHeights, params, *, origin: tuple[float, float] | None = None,
                 spacing: float | None = None) -> CellClasses:
    """The grid stage of a grid filter: fill, the low-outlier test, filter, the raised-segment
    test and, with ``surface_threshold``, the provisional surface of SMRF's final test.
    ``spacing``: the input's point spacing (:func:`aldpat.core.low_points.point_spacing`), which
    sets the low-outlier test's blocks."""
    marks, low = _run_grid(spec, cells, params, spacing)
    surface = None
    if params.surface_threshold is not None:
        surface = SurfaceTest.build(cells, marks, threshold=params.surface_threshold,
                                    slope_scalar=params.surface_slope)
        release_free_memory()
    return CellClasses(cells, marks, params.ground_tolerance, origin, surface, low)


def _lowest_without(x, y, z, set_aside: np.ndarray | None, cell: float, origin, extent: Extent | None = None
                    ) -> LowestGrid:
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


def low_outlier_reach(params) -> int:
    """Cells the low-outlier test looks across: the terrain around a pit, in cells."""
    if getattr(params, "low_outliers", None) is None:
        return 0
    cell = float(getattr(params, "cell", None) or 1.0)
    return max(4 * params.low_outlier_window, math.ceil(params.low_outlier_reach / cell - 1e-9))


def low_outlier_points(x, y, z, params, extent: Extent | None = None, spacing: float | None = None
                       ) -> np.ndarray | None:
    """Which points the low-outlier test finds on the lowest-point grid of ``params.cell`` (a
    point filter's, which sets them aside before it runs); ``None`` when the test is off."""
    if getattr(params, "low_outliers", None) is None or len(z) == 0:
        return None
    grid = lowest_grid(x, y, z, params.cell, origin=getattr(params, "origin", None), extent=extent)
    spacing = spacing if spacing is not None else points_spacing(x, y)
    return find_low_outliers(CellHeights.of(grid), ~grid.empty, params, spacing).below(grid.cell_index, z)


def points_spacing(x: np.ndarray, y: np.ndarray) -> float | None:
    """The mean spacing of points over their own extent (:func:`point_spacing`)."""
    if len(x) == 0:
        return None
    return point_spacing(len(x), (float(x.min()), float(y.min()), float(x.max()), float(y.max())))


def _rotate(x: np.ndarray, y: np.ndarray, degrees: float) -> tuple[np.ndarray, np.ndarray]:
    """Rotate points counter-clockwise about the origin (0, 0), so tiles rotate alike."""
    t = math.radians(degrees)
    c, s = math.cos(t), math.sin(t)
    return x * c - y * s, x * s + y * c


def ground_filter(x, y, z, algorithm: str, params=None, *, extent: Extent | None = None,
                  spacing: float | None = None) -> FilterResult:
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

    With the manual's Rotate Angle / Rotate Times (filters registered with ``rotations``),
    the data are rotated, gridded and filtered at each angle; a point is ground only when every
    orientation keeps it, and its mark is the largest window that removed it.
    """
    spec = get_filter(algorithm)
    if params is None:
        params = spec.params()
    elif not isinstance(params, spec.params):
        raise ParamError(f"filter {algorithm!r} takes {spec.params.__name__}, got {type(params).__name__}")
    validate_instance(params)
    x = np.ascontiguousarray(x, dtype=np.float64)
    y = np.ascontiguousarray(y, dtype=np.float64)
    z = np.ascontiguousarray(z, dtype=np.float64)
    if not (x.shape == y.shape == z.shape) or x.ndim != 1:
        raise ValueError("x, y and z must be 1-D arrays of the same length")
    if len(z) and not (np.isfinite(x).all() and np.isfinite(y).all() and np.isfinite(z).all()):
        raise DataError("points with non-finite coordinates cannot be filtered")
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


def cell_grid(x: np.ndarray, y: np.ndarray, z: np.ndarray, params, extent: Extent | None = None,
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


def _point_filter(spec: FilterSpec, x, y, z, params, extent: Extent | None, spacing: float | None
                  ) -> FilterResult:
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
