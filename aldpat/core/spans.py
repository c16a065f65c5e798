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
never copied whole; each block is a few vectorised passes over its cells.
"""

from __future__ import annotations

import numpy as np

from aldpat.core.height_codes import Decode
from aldpat.core.segments import step_limits

#: A span's heights lie within this range (m): a deck is level across its width.
SPAN_LEVEL = 1.0
#: Lines of the grid taken at a time.
BLOCK_LINES = 64


def raised_spans(z: np.ndarray, step: float, max_cells: int, *,
                 decode: Decode | None = None,
                 spacing: np.ndarray | None = None, cell: float = 1.0, enclosed: bool = False,
                 level: float = SPAN_LEVEL) -> np.ndarray:
    """Cells of level runs along rows or columns (with ``enclosed``: along rows and columns alike),
    bounded at both ends by steps down from them and at most ``max_cells`` long (bool, the shape
    of ``z``).

    ``z`` holds the filled lowest-point grid as heights, or codes that ``decode`` turns into
    heights; ``spacing`` and ``cell`` as for :func:`aldpat.core.segments.raised_segments`. A run's
    heights lie within ``level`` (m; ``SPAN_LEVEL`` for a deck).
    """
    rows, cols = z.shape
    out = np.zeros((rows, cols), bool)
    if max_cells < 1 or min(rows, cols) < 3:
        return out

    def heights(block: np.ndarray) -> np.ndarray:
        return decode(block) if decode is not None else np.asarray(block, dtype=np.float64)

    for a in range(0, rows, BLOCK_LINES):
        b = min(rows, a + BLOCK_LINES)
        out[a:b] |= _spans(heights(z[a:b]), None if spacing is None else spacing[a:b], step, max_cells, cell, level)
    for a in range(0, cols, BLOCK_LINES):
        b = min(cols, a + BLOCK_LINES)
        lines = np.ascontiguousarray(heights(z[:, a:b]).T)
        spaced = None if spacing is None else np.ascontiguousarray(spacing[:, a:b].T)
        along_columns = _spans(lines, spaced, step, max_cells, cell, level).T
        if enclosed:
            out[:, a:b] &= along_columns
        else:
            out[:, a:b] |= along_columns
    return out


def _spans(z: np.ndarray, spacing: np.ndarray | None, step: float, max_cells: int, cell: float,
           level: float) -> np.ndarray:
    """:func:`raised_spans` along the rows of ``z`` only."""
    lines, n = z.shape
    rise = np.diff(z, axis=1)  # from each cell to the next
    apart = None if spacing is None else spacing[:, 1:].astype(np.uint16) + spacing[:, :-1]
    cut = np.abs(rise) > step_limits(apart, step, cell)
    # runs: the cells between two cuts; every line starts a run
    starts = np.zeros((lines, n), bool)
    starts[:, 0] = True
    starts[:, 1:] = cut
    first = np.flatnonzero(starts.ravel())
    last = np.append(first[1:], lines * n) - 1
    flat = z.ravel()
    length = last - first + 1
    col_first, col_last = first % n, last % n
    # a step down from the run on either side: the neighbour before / after it is lower
    before = col_first > 0
    after = col_last < n - 1
    down_before = before & (flat[np.maximum(first - 1, 0)] < flat[first])
    down_after = after & (flat[np.minimum(last + 1, flat.size - 1)] < flat[last])
    keep = down_before & down_after & (length <= max_cells)
    if keep.any():
        relief = np.maximum.reduceat(flat, first) - np.minimum.reduceat(flat, first)
        keep &= relief <= level
    return np.repeat(keep, length).reshape(lines, n)
