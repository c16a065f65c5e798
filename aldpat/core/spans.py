"""Raised spans: bridge decks and other flat objects spanning lower ground.

A bridge deck joins the ramps at both of its ends without a step, so the raised-segment test
(:mod:`aldpat.core.segments`) finds it one segment with the terrain; a morphological window
removes it only when wider than the deck. Across its width, though, a deck is a *run* of cells
joined without a step and bounded at both ends by steps down to the road or river under it. A
ramp is not: its sides slope down without a step, and a terrace steps up on one side.

:func:`raised_spans` marks the cells of every run along a row or a column of the lowest-point
grid that is bounded at both ends by steps *down* from it, at most ``max_cells`` long and level
(its heights within ``SPAN_LEVEL``): a deck is level across its width, while the crest of a
ridge or an embankment between two steep flanks rises and falls (the steps are counted as the
raised-segment test counts them, with the points' spacing of sparse data). Buildings and trees
are spans too where they are level; they are objects either way.

With ``enclosed``, a cell counts only where it lies in such a run along its row *and* along its
column: a flat enclosed by steps down on all four sides. :func:`aldpat.filters.grid_stage.remnants`
asks this of the ground a filter left, where a deck has gone with the objects around it and what
stands so is a piece of roof whose taller parts were taken away; there a run is level when its
heights lie within a step of each other (one level of a building, as the raised-segment test
joins cells), since a low roof falls to its gutters or steps by less than a storey.

Each line is scanned once by a compiled loop reading the cells where they lie (a column too, a
block of them at a time: no transposed copy) and their heights from the codes; the blocks of one
direction run on the process's threads at once.
"""

from __future__ import annotations

import numpy as np

from aldpat.core.compiled import compiled, prefetch_run
from aldpat.core.height_codes import Decode
from aldpat.core.rise import scale_and_offset
from aldpat.core.segments import SPACING_REACH, SPACING_SLOPE, _height, step_limit
from aldpat.core.threads import on_threads, thread_budget

#: A span's heights lie within this range (m): a deck is level across its width.
SPAN_LEVEL = 1.0
#: Lines of the grid taken at a time.
BLOCK_LINES = 64
#: Grid rows ahead whose cells of a block of columns are asked for (:func:`aldpat.core.compiled.prefetch_run`).
_AHEAD = 8


def raised_spans(z: np.ndarray, step: float, max_cells: int, *,
                 decode: Decode | None = None,
                 spacing: np.ndarray | None = None, cell: float = 1.0, enclosed: bool = False,
                 level: float = SPAN_LEVEL, within: np.ndarray | None = None) -> np.ndarray:
    """Cells of level runs along rows or columns (with ``enclosed``: along rows and columns alike),
    bounded at both ends by steps down from them and at most ``max_cells`` long (bool, the shape
    of ``z``).

    ``z`` holds the filled lowest-point grid as heights, or codes that ``decode`` turns into
    heights; ``spacing`` and ``cell`` as for :func:`aldpat.core.segments.raised_segments`. A run's
    heights lie within ``level`` (m; ``SPAN_LEVEL`` for a deck). With ``enclosed``, ``within`` (a
    bool grid the caller gives up) keeps only its own cells: the result is made in it, in place of
    a grid of its own.
    """
    rows, cols = z.shape
    if within is not None and not enclosed:
        raise ValueError("within= is for enclosed spans")
    out = np.empty((rows, cols), bool) if within is None else within  # the rows set every cell
    if max_cells < 1 or min(rows, cols) < 3:
        out[...] = False
        return out

    linear = scale_and_offset(decode)
    if decode is not None and linear is None:
        z = decode(z)  # another decoding than ``code * scale + offset``: its float64 heights, whole
    scale, offset = linear if linear is not None else (1.0, 0.0)
    sp = np.zeros((1, 1), np.uint8) if spacing is None else np.ascontiguousarray(spacing)
    z = np.ascontiguousarray(z)
    # rows: the first direction sets the cells (``within``: keeps its own); columns keep what the
    # rows found (``enclosed``) or add to it
    row_mode, column_mode = (_SET if within is None else _AND), (_AND if enclosed else _OR)

    limits = _limits(np.float32(step), np.float32(cell), np.float32(SPACING_SLOPE), np.float32(SPACING_REACH))

    def lines(piece: tuple[bool, int]) -> None:
        columns, a = piece
        b = min(cols if columns else rows, a + BLOCK_LINES)
        scan = _column_spans if columns else _line_spans
        scan(z, sp, spacing is not None, linear is not None, scale, offset, a, b, float(step), limits,
             int(max_cells), float(level), column_mode if columns else row_mode, out)

    # the blocks of each direction write their own lines of ``out``: on threads at once, the rows
    # before the columns (``enclosed`` keeps what both directions found)
    workers = max(1, min(thread_budget(), rows // BLOCK_LINES, cols // BLOCK_LINES))
    on_threads(lines, [(False, a) for a in range(0, rows, BLOCK_LINES)], workers)
    on_threads(lines, [(True, a) for a in range(0, cols, BLOCK_LINES)], workers)
    return out


@compiled(nogil=True)
def _limits(step: np.float32, cell: np.float32, slope: np.float32,
            reach: np.float32) -> np.ndarray:  # pragma: no cover - compiled
    """The step limit of two neighbouring cells (:func:`aldpat.core.segments.step_limit`, in
    float32, widened) at each sum of their distances from the cells they were filled from (two
    bytes: 0 to 510), looked up by the scans in place of working it out per cell."""
    out = np.empty(511)
    for apart in range(511):
        out[apart] = np.float64(step_limit(apart, step, cell, slope, reach))
    return out


#: How :func:`_line_spans` writes a line's cells into its output: set them, or keep those both
#: the output and the line's spans hold, or those either holds.
_SET, _AND, _OR = 0, 1, 2


@compiled(nogil=True)
def _line_spans(z: np.ndarray, spacing: np.ndarray, has_spacing: bool, scaled: bool, scale: float, offset: float,
                first: int, stop: int, step: float, limits: np.ndarray, max_cells: int, level: float, mode: int,
                out: np.ndarray) -> None:  # pragma: no cover - compiled
    """The runs between steps of rows ``first:stop`` of ``z`` -- ``|rise| > step``, or the float32
    limit of :func:`aldpat.core.segments.step_limits` where ``spacing`` is given (``limits``),
    compared in float64 -- marked where both neighbours outside the run are lower, it is at most
    ``max_cells`` long and its heights lie within ``level``; written into the same rows of
    ``out`` by ``mode``. The heights are those of :func:`aldpat.core.segments._height` (``code *
    scale + offset`` unfused, as the codes' decoding gives them, with ``scaled``)."""
    n = z.shape[1]
    for i in range(first, stop):
        a = 0
        while a < n:
            b = a
            here = _height(z[i, b], scaled, scale, offset)
            while b + 1 < n:
                there = _height(z[i, b + 1], scaled, scale, offset)
                limit = step
                if has_spacing:
                    limit = limits[np.int64(spacing[i, b + 1]) + np.int64(spacing[i, b])]
                if abs(there - here) > limit:
                    break
                b += 1
                here = there
            keep = (a > 0 and b < n - 1 and b - a + 1 <= max_cells
                    and _height(z[i, a - 1], scaled, scale, offset) < _height(z[i, a], scaled, scale, offset)
                    and _height(z[i, b + 1], scaled, scale, offset) < here)
            if keep:
                high = low = _height(z[i, a], scaled, scale, offset)
                for k in range(a + 1, b + 1):
                    h = _height(z[i, k], scaled, scale, offset)
                    high = max(high, h)
                    low = min(low, h)
                keep = high - low <= level
            for k in range(a, b + 1):
                out[i, k] = _written(out[i, k], keep, mode)
            a = b + 1


@compiled(nogil=True)
def _written(held: bool, keep: bool, mode: int) -> bool:  # pragma: no cover - compiled
    """A cell of the output once its line's answer ``keep`` is written into it by ``mode``."""
    if mode == _SET:
        return keep
    if mode == _AND:
        return held and keep
    return held or keep


@compiled(nogil=True)
def _column_spans(z: np.ndarray, spacing: np.ndarray, has_spacing: bool, scaled: bool, scale: float,
                  offset: float, first: int, stop: int, step: float, limits: np.ndarray, max_cells: int,
                  level: float, mode: int, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """:func:`_line_spans` of columns ``first:stop``, taken side by side a row at a time (each
    row's cells of the block read where they lie, in one run of memory: walking each column down
    alone reads a cache line a cell). Each column keeps its run so far: where it starts, its last
    height, its highest and lowest, and whether it may still be kept (it rose from the cell before
    it, is at most ``max_cells`` long and within ``level``: the range of its heights only grows).
    A run that may not is written as it goes; one that may is written once it ends, at most
    ``max_cells`` cells back. The same runs and the same comparisons on the same heights as
    :func:`_line_spans`, so the same cells."""
    rows = z.shape[0]
    width = stop - first
    start = np.zeros(width, np.int64)
    here = np.empty(width)
    high = np.empty(width)
    low = np.empty(width)
    alive = np.zeros(width, np.bool_)
    for j in range(width):
        h = _height(z[0, first + j], scaled, scale, offset)
        here[j] = high[j] = low[j] = h
        _lost(out, 0, 0, first + j, mode)  # a run from the grid's edge is never kept
    for i in range(1, rows):
        if i + _AHEAD < rows:
            prefetch_run(z, i + _AHEAD, first, stop)
            prefetch_run(out, i + _AHEAD, first, stop)
            if has_spacing:
                prefetch_run(spacing, i + _AHEAD, first, stop)
        for j in range(width):
            c = first + j
            there = _height(z[i, c], scaled, scale, offset)
            limit = step
            if has_spacing:
                limit = limits[np.int64(spacing[i, c]) + np.int64(spacing[i - 1, c])]
            if abs(there - here[j]) > limit:  # the run ends at row i - 1: a step to this row
                if alive[j]:
                    keep = there < here[j]
                    for k in range(start[j], i):
                        out[k, c] = _written(out[k, c], keep, mode)
                alive[j] = here[j] < there and 1 <= max_cells and 0.0 <= level
                start[j], high[j], low[j] = i, there, there
                if not alive[j]:
                    _lost(out, i, i, c, mode)
            else:
                high[j] = max(high[j], there)
                low[j] = min(low[j], there)
                if alive[j]:
                    if i - start[j] + 1 > max_cells or high[j] - low[j] > level:
                        alive[j] = False
                        _lost(out, start[j], i, c, mode)
                else:
                    _lost(out, i, i, c, mode)
            here[j] = there
    for j in range(width):
        if alive[j]:  # a run to the grid's edge is never kept
            _lost(out, start[j], rows - 1, first + j, mode)


@compiled(nogil=True)
def _lost(out: np.ndarray, a: int, b: int, c: int, mode: int) -> None:  # pragma: no cover - compiled
    """Rows ``a..b`` of column ``c`` written as cells of a run not kept."""
    if mode != _OR:
        for k in range(a, b + 1):
            out[k, c] = False
