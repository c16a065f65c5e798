"""Every empty cell of a grid filled from its Euclidean-nearest filled cell, a row at a time.

The dissertation's grid-based nearest-neighbour interpolation (§4.2.1) gives an empty cell the
height of the nearest non-empty cell. The exact answer is the feature transform of Maurer, Qi &
Raghavan (2003), "A linear time algorithm for computing exact Euclidean distance transforms of
binary images in arbitrary dimensions", IEEE Trans. PAMI 25(2): first, in each column, the
nearest filled cell of every cell (one dimension); then, along each row, the lower envelope of
the parabolas those column answers make (the partial Voronoi diagram of §3), kept as a stack.

Done for the whole grid at once, the first step needs the column answers of every cell before
the second starts: scipy's ``distance_transform_edt`` holds them, and its answers, as two int32
planes (8 bytes a cell). Here the column answers of one row come from each column's filled
cells just above and below it (kept as the rows go down, a column's next filled cell looked up
only once it is passed), so each row is finished before the next and no grid-sized scratch is
made. Ties are broken as that transform breaks them -- of two cells equally near, the upper one
in a column and the first kept on the row's envelope -- and every comparison is made on the same
float64 values in the same order, so a cell is filled from the very cell the transform names
(``tests/core/test_lowest_grid.py``). Once each column's filled cells just above and below a row
are known, the rows from there on need nothing of the rows before, so blocks of rows are filled
on threads at once (:func:`fill_grid`).
"""

from __future__ import annotations

import math
from itertools import pairwise

import numpy as np

from aldpat.core.compiled import compiled
from aldpat.core.threads import on_threads

#: Rows a thread fills at the least: fewer, and the grid is filled on fewer threads.
MIN_BLOCK_ROWS = 256


def fill_grid(values: np.ndarray, empty: np.ndarray, spacing: np.ndarray, with_spacing: bool,
              workers: int) -> None:
    """:func:`fill_rows` over the whole grid, its rows split into up to ``workers`` blocks filled
    on threads at once. Only empty cells are written and only filled ones read, so the blocks
    share the grid safely, and each cell is filled as by one pass over all rows."""
    rows = values.shape[0]
    blocks = max(1, min(workers, rows // MIN_BLOCK_ROWS))
    bounds = [rows * k // blocks for k in range(blocks + 1)]
    on_threads(lambda piece: fill_rows(values, empty, spacing, with_spacing, *piece), list(pairwise(bounds)),
               blocks)  # the compiled rows release the GIL


@compiled(nogil=True)
def fill_rows(values: np.ndarray, empty: np.ndarray, spacing: np.ndarray, with_spacing: bool,
              first: int, stop: int) -> None:  # pragma: no cover - compiled
    """Fill the ``empty`` cells of rows ``first:stop`` of ``values`` in place from their nearest
    non-empty cells anywhere in the grid (at least one cell must be non-empty); with
    ``with_spacing``, each cell's distance from the cell it was filled from (cells, rounded up,
    at most 255; 0 where it holds a value) into ``spacing``."""
    rows, cols = values.shape
    above = np.full(cols, -1, np.int64)  # a column's last filled row before this one (-1: none)
    below = np.full(cols, -1, np.int64)  # its first filled row from this one on (rows: none)
    nearest = np.empty(cols, np.int64)  # the row of each column's filled cell nearest this row
    kept = np.empty(cols, np.int64)  # the columns on the row's lower envelope
    source = np.empty(cols, np.int64)  # ... the rows of their filled cells
    rise = np.empty(cols)  # ... and those rows' squared distance from this one
    apart = _distances() if with_spacing else np.zeros((1, 1), np.uint8)
    if first > 0:  # the state the rows above would have left: each column's filled cells around ``first``
        for c in range(cols):
            k = first - 1
            while k >= 0 and empty[k, c]:
                k -= 1
            above[c] = k
            k = first
            while k < rows and empty[k, c]:
                k += 1
            below[c] = k
    for r in range(first, stop):
        for c in range(cols):
            if below[c] < r:
                above[c] = below[c]
                k = r
                while k < rows and empty[k, c]:
                    k += 1
                below[c] = k
            a, b = above[c], below[c]
            if b == r:
                nearest[c] = r
            elif a >= 0 and b < rows:
                nearest[c] = a if r - a <= b - r else b  # equally near: the upper
            elif a >= 0:
                nearest[c] = a
            elif b < rows:
                nearest[c] = b
            else:
                nearest[c] = -1
        top = _envelope(nearest, r, kept, source, rise)
        if top < 0:
            continue
        k = 0
        for c in range(cols):
            t1 = float(kept[k] - c)
            near = rise[k] + t1 * t1
            while k < top:
                t1 = float(kept[k + 1] - c)
                after = rise[k + 1] + t1 * t1
                if near <= after:
                    break
                near = after
                k += 1
            if empty[r, c]:
                fr, fc = source[k], kept[k]
                values[r, c] = values[fr, fc]
                if with_spacing:
                    spacing[r, c] = apart[min(abs(fr - r), 255), min(abs(fc - c), 255)]
            elif with_spacing:
                spacing[r, c] = 0


@compiled(nogil=True)
def _distances() -> np.ndarray:  # pragma: no cover - compiled
    """The distance of a cell ``dr`` rows and ``dc`` columns from another, ``ceil(hypot(dr, dc))``
    of their float32 offsets and at most 255, at ``[min(|dr|, 255), min(|dc|, 255)]``: a look-up
    in place of a root and a rounding up per filled cell. hypot is even in each offset and grows
    with either, so an offset beyond 255 is 255 away or more, as its row and column of the table
    say."""
    out = np.empty((256, 256), np.uint8)
    for dr in range(256):
        for dc in range(256):
            out[dr, dc] = min(math.ceil(math.hypot(np.float32(dr), np.float32(dc))), 255)
    return out


@compiled(nogil=True)
def _envelope(nearest: np.ndarray, r: int, kept: np.ndarray, source: np.ndarray,
              rise: np.ndarray) -> int:  # pragma: no cover - compiled
    """The columns whose nearest filled cells lie on the lower envelope along row ``r`` (Maurer
    et al.'s ``RemoveFT`` test, in float64), into ``kept``, with the rows of those filled cells
    (``source``) and their squared distances from row ``r`` (``rise``: each worked out once, as
    its column is kept); the index of the last (-1: none)."""
    top = -1
    for c in range(len(nearest)):
        if nearest[c] < 0:
            continue
        w = float(nearest[c] - r)
        w_r = w * w
        fd = float(c)
        while top >= 1:
            f1 = float(kept[top])
            a = f1 - float(kept[top - 1])
            b = fd - f1
            span = a + b
            if span * rise[top] - b * rise[top - 1] - a * w_r - a * b * span <= 0.0:
                break
            top -= 1
        top += 1
        kept[top] = c
        source[top] = nearest[c]
        rise[top] = w_r
    return top


@compiled(nogil=True)
def flat_cells(x: np.ndarray, y: np.ndarray, ox: float, oy: float, cell: float, c0: int, r0: int, rows: int,
               cols: int) -> np.ndarray:  # pragma: no cover - compiled
    """:func:`aldpat.core.lowest_grid.flat_cell_indices` point by point: ``floor((v - origin) /
    cell)`` of either coordinate, less the grid's first column or row, clipped into the grid,
    ``row * cols + col``. Here, with the grid's fill, so that :mod:`aldpat.core.lowest_grid` loads
    the compiler only once it runs a compiled loop."""
    out = np.empty(len(x), np.int64)
    for k in range(len(x)):
        col = math.floor((x[k] - ox) / cell) - c0
        row = math.floor((y[k] - oy) / cell) - r0
        col = min(max(col, 0), cols - 1)
        row = min(max(row, 0), rows - 1)
        out[k] = row * cols + col
    return out
