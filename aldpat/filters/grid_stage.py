"""The grid stage of a grid filter and the tests around every filter: fill the empty cells
(dissertation §4.2.1), set the low outliers aside, run the filter on the mark matrix, then the
raised-segment test (and, with raised spans, the remnants it leaves: :func:`remnants`) and, with
``surface_threshold``, the provisional surface of SMRF's final test (:func:`cell_classes`). The driver (:mod:`aldpat.filters.driver`) and the streamed file path
(:mod:`aldpat.filters.streamed`) both run it.
"""

from __future__ import annotations

import math

import numpy as np

from aldpat.core.compiled import compiled
from aldpat.core.height_codes import Decode
from aldpat.core.low_points import NO_LOW_POINTS, LowPoints, find_low_points, point_spacing
from aldpat.core.lowest_grid import Extent, fill_nearest, lowest_grid, rows_per_block
from aldpat.core.memory import one_arena, release_free_memory
from aldpat.core.surface_check import SurfaceTest
from aldpat.core.threads import on_threads
from aldpat.filters.classify import CellClasses, CellHeights
from aldpat.filters.marks import MARK_GROUND, MARK_INTERPOLATED, MARK_RAISED_SEGMENT
from aldpat.filters.options import GroundParams, LowOutlierOption, PointFilterParams, RaisedSegmentOption
from aldpat.filters.registry import FilterSpec


def _run_grid(spec: FilterSpec, cells: CellHeights, params: GroundParams, spacing: float | None) -> tuple[np.ndarray, LowPoints]:
    """Fill, find the low outliers, filter and return the cell mark matrix (int16 or int32) of
    one grid and the low outliers' cells (left out of the grid: marked as empty ones).

    Peak memory is what makes 1 m cells over a large survey possible, so the steps hold as
    little at once as they can: the empty cells are filled in the codes themselves when the
    run owns them (``empty`` remembers which they were), the filter gets the one float64 grid
    and may overwrite it, and it never sees a second copy; a mask waiting for a later step is
    held as bits, and the marks take over ``empty`` as soon as they exist.
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
        # the empty cells as bits while the segments hold their labels (4 bytes a cell), and the
        # raised ones while the filter holds its scratch: two of the stage's fullest moments
        packed = _Bits(empty)
        del empty
        raised = _Bits(raised_cells(filled, params, cells.spec.cell, filled_from, decode=cells.heights.decode))
        del filled_from
        release_free_memory()
        empty = packed.unpacked()
        del packed
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
    # the marks say which cells were empty from here on, and which ground cells are raised: in
    # one pass, the raised cells read from their bits
    _mark_cells(marks, empty, raised)
    del read_only, empty
    release_free_memory()  # the filter's scratch, before the surface and the points' pass
    if raised is not None:
        del raised
        if getattr(params, "object_span", 0.0) > 0:
            marks[remnants(cells, marks, params, cells.spec.cell)] = MARK_RAISED_SEGMENT
    return marks, low


class _Bits:
    """A bool grid held as one bit a cell (an eighth of its bytes) while it waits for a later step."""

    def __init__(self, mask: np.ndarray) -> None:
        self.bits, self.shape = np.packbits(mask, axis=None), mask.shape

    def unpacked(self) -> np.ndarray:
        return np.unpackbits(self.bits, count=math.prod(self.shape)).view(bool).reshape(self.shape)


def _mark_cells(marks: np.ndarray, empty: np.ndarray, raised: _Bits | None) -> None:
    """``marks`` of the ``empty`` cells ``MARK_INTERPOLATED`` and, of the ``raised`` cells (if
    any) marked ground, ``MARK_RAISED_SEGMENT``; strips of rows on the process's threads."""
    rows, cols = marks.shape
    bits = raised.bits if raised is not None else np.zeros(0, np.uint8)
    step = max(1, rows_per_block(cols, 1 << 20))
    on_threads(lambda a: _mark_rows(marks, empty, bits, raised is not None, a, min(rows, a + step)),
               range(0, rows, step))


@compiled(nogil=True)
def _mark_rows(marks: np.ndarray, empty: np.ndarray, bits: np.ndarray, with_raised: bool, a: int,
               b: int) -> None:  # pragma: no cover - compiled
    """:func:`_mark_cells` of rows ``a:b``; ``bits``: ``np.packbits`` of the raised cells, the
    first cell of each byte its highest bit."""
    cols = marks.shape[1]
    for i in range(a, b):
        for j in range(cols):
            if empty[i, j]:
                marks[i, j] = MARK_INTERPOLATED
            elif with_raised and marks[i, j] == MARK_GROUND:
                k = i * cols + j
                if (bits[k >> 3] >> (7 - (k & 7))) & 1:
                    marks[i, j] = MARK_RAISED_SEGMENT


def raised_cells(filled: np.ndarray, params: RaisedSegmentOption, cell: float, filled_from: np.ndarray | None = None,
                 *, decode: Decode | None = None, levels: bool = True) -> np.ndarray:
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


def remnants(cells: CellHeights, marks: np.ndarray, params: RaisedSegmentOption, cell: float) -> np.ndarray:
    """The ground cells (``marks`` 0; empty cells marked ``MARK_INTERPOLATED``) that stand as
    flats on the ground the filter left: level runs at most ``object_span`` long bounded by steps
    down at both ends along their row *and* their column (:func:`aldpat.core.spans.raised_spans`
    with ``enclosed``), on the grid of the ground cells' lowest points with every other cell
    filled from the nearest of them.

    What a filter leaves so is the lower part of a building whose taller parts it removed: a
    one-storey part inside a block, a podium below a tower. Among the tall parts the low roof
    steps up on some sides and down on others, and where points are sparse (0.1 per m2) its
    filled cells may join it to the street through a tree or a ramp without a step, so neither
    the windows (it is wider than they are) nor the raised-segment test take it; once the tall
    parts are gone, it is a flat standing above the ground on every side. A bridge deck or an
    embankment's crest steps down across its run only, and terrain on a slope rises along one
    direction at least, so neither is enclosed on all sides. The runs are those of raised spans,
    with their step (``object_step``) and length; level here means heights within that step of
    each other, what the raised-segment test takes for one level of a building: a low roof that
    falls to its gutters, or steps by less than a storey between its parts, is one flat, as a
    deck's 1 m levelness would not have it. No constant of its own.
    """
    from aldpat.core.spans import raised_spans

    ground, others, held, grounds = _ground_and_held(marks)
    if not grounds:
        return ground
    in_place = cells.owned and cells.codes.flags.c_contiguous
    if in_place:
        # the run's own codes take the surface, and those of the non-empty cells that are not
        # ground -- which the points' pass compares its points with -- are put back after: a
        # copy of those cells, not of the grid. No later step reads the code of a cell marked
        # empty (the surface test reads the ground cells', the classes compare a point with its
        # cell's lowest height only where the cell is not marked empty).
        surface = cells.codes
        saved = surface.reshape(-1)[held]
    else:
        surface = cells.codes.copy()
    filled_from = np.empty(surface.shape, np.uint8)
    fill_nearest(surface, others, out=surface, spacing=filled_from)
    del others
    # the flats are made in ``ground`` itself, not in a grid of their own
    flats = raised_spans(surface, params.object_step, int(params.object_span / cell), decode=cells.heights.decode,
                         spacing=filled_from, cell=cell, enclosed=True, level=params.object_step, within=ground)
    if in_place:
        surface.reshape(-1)[held] = saved
    return flats


@compiled(nogil=True)
def _ground_and_held(marks: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:  # pragma: no cover
    """From one pass over the marks: the ground cells, every other cell, the cells holding a
    point that are not ground (flat indices, ascending: those whose codes :func:`remnants` puts
    back) and how many cells are ground."""
    rows, cols = marks.shape
    ground = np.empty((rows, cols), np.bool_)
    others = np.empty((rows, cols), np.bool_)
    grounds = held_count = 0
    for i in range(rows):
        for j in range(cols):
            on = marks[i, j] == MARK_GROUND
            ground[i, j] = on
            others[i, j] = not on
            grounds += on
            held_count += not on and marks[i, j] != MARK_INTERPOLATED
    held = np.empty(held_count, np.int64)
    at = 0
    for i in range(rows):
        for j in range(cols):
            if marks[i, j] != MARK_GROUND and marks[i, j] != MARK_INTERPOLATED:
                held[at] = i * cols + j
                at += 1
    return ground, others, held, grounds


def find_low_outliers(cells: CellHeights, real: np.ndarray, params: LowOutlierOption,
                      spacing: float | None) -> LowPoints:
    """The low outliers of a grid (:mod:`aldpat.core.low_points`) with the test's parameters;
    none when ``low_outliers`` is off. ``spacing``: the input's point spacing."""
    threshold = getattr(params, "low_outliers", None)
    if threshold is None:
        return NO_LOW_POINTS
    return find_low_points(cells.codes, cells.heights.decode, real, cells.spec,
                           origin=getattr(params, "origin", None), spacing=spacing, threshold=threshold,
                           window=params.low_outlier_window, reach=params.low_outlier_reach)


def cell_classes(spec: FilterSpec, cells: CellHeights, params: GroundParams, *, origin: tuple[float, float] | None = None,
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


def low_outlier_reach(params: LowOutlierOption) -> int:
    """Cells the low-outlier test looks across: the terrain around a pit, in cells."""
    if getattr(params, "low_outliers", None) is None:
        return 0
    cell = float(getattr(params, "cell", None) or 1.0)
    return max(4 * params.low_outlier_window, math.ceil(params.low_outlier_reach / cell - 1e-9))


def low_outlier_points(x: np.ndarray, y: np.ndarray, z: np.ndarray, params: GroundParams | PointFilterParams,
                       extent: Extent | None = None, spacing: float | None = None) -> np.ndarray | None:
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
