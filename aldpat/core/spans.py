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

Rows are taken a block at a time and columns a block of them transposed, so that the grid is
never copied whole; each block's lines are scanned once by a compiled loop, the blocks of one
direction on the process's threads at once.
"""

from __future__ import annotations

import numpy as np

from aldpat.core.compiled import compiled
from aldpat.core.height_codes import Decode
from aldpat.core.segments import SPACING_REACH, SPACING_SLOPE, step_limit
from aldpat.core.threads import on_threads, thread_budget

#: A span's heights lie within this range (m): a deck is level across its width.
SPAN_LEVEL = 1.0
#: Lines of the grid taken at a time.
BLOCK_LINES = 64


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
    out = np.zeros((rows, cols), bool) if within is None else within
    if max_cells < 1 or min(rows, cols) < 3:
        out[...] = False
        return out

    def heights(block: np.ndarray) -> np.ndarray:
        return decode(block) if decode is not None else np.asarray(block, dtype=np.float64)

    def row_block(a: int) -> None:
        b = min(rows, a + BLOCK_LINES)
        along_rows = _spans(heights(z[a:b]), None if spacing is None else spacing[a:b], step, max_cells, cell, level)
        if within is None:
            out[a:b] |= along_rows
        else:
            out[a:b] &= along_rows

    def column_block(a: int) -> None:
        b = min(cols, a + BLOCK_LINES)
        lines = np.ascontiguousarray(heights(z[:, a:b]).T)
        spaced = None if spacing is None else np.ascontiguousarray(spacing[:, a:b].T)
        along_columns = _spans(lines, spaced, step, max_cells, cell, level).T
        if enclosed:
            out[:, a:b] &= along_columns
        else:
            out[:, a:b] |= along_columns

    # the blocks of each direction write their own lines of ``out``: on threads at once, the rows
    # before the columns (``enclosed`` keeps what both directions found)
    workers = max(1, min(thread_budget(), rows // BLOCK_LINES, cols // BLOCK_LINES))
    on_threads(row_block, range(0, rows, BLOCK_LINES), workers)
    on_threads(column_block, range(0, cols, BLOCK_LINES), workers)
    return out


def _spans(z: np.ndarray, spacing: np.ndarray | None, step: float, max_cells: int, cell: float,
           level: float) -> np.ndarray:
    """:func:`raised_spans` along the rows of ``z`` only."""
    out = np.empty(z.shape, bool)
    _line_spans(np.ascontiguousarray(z, dtype=np.float64),
                np.zeros((1, 1), np.uint8) if spacing is None else np.ascontiguousarray(spacing), spacing is not None,
                float(step), np.float32(step), np.float32(cell), np.float32(SPACING_SLOPE), np.float32(SPACING_REACH),
                int(max_cells), float(level), out)
    return out


@compiled(nogil=True)
def _line_spans(z: np.ndarray, spacing: np.ndarray, has_spacing: bool, step: float, step32: np.float32,
                cell: np.float32, slope: np.float32, reach: np.float32, max_cells: int, level: float,
                out: np.ndarray) -> None:  # pragma: no cover - compiled
    """Each line's runs between steps (``|rise| > step``, or the float32 limit of
    :func:`aldpat.core.segments.step_limits` where ``spacing`` is given, compared in float64),
    marked where both neighbours outside the run are lower, it is at most ``max_cells`` long and
    its heights lie within ``level``."""
    lines, n = z.shape
    for i in range(lines):
        a = 0
        while a < n:
            b = a
            while b + 1 < n:
                rise = z[i, b + 1] - z[i, b]
                limit = step
                if has_spacing:
                    limit = np.float64(step_limit(np.int64(spacing[i, b + 1]) + np.int64(spacing[i, b]), step32, cell,
                                                  slope, reach))
                if abs(rise) > limit:
                    break
                b += 1
            keep = a > 0 and b < n - 1 and b - a + 1 <= max_cells and z[i, a - 1] < z[i, a] and z[i, b + 1] < z[i, b]
            if keep:
                high = low = z[i, a]
                for k in range(a + 1, b + 1):
                    high = max(high, z[i, k])
                    low = min(low, z[i, k])
                keep = high - low <= level
            for k in range(a, b + 1):
                out[i, k] = keep
            a = b + 1
