"""Raised segments: objects found by the steps around them, whatever their size.

A morphological filter removes only objects smaller than its largest window; widening the
window to a railway shed or a department store cuts hilltops and embankments instead. A
connected-operator view (after Mongus & Žalik 2014, and the segment-based filters compared by
Sithole & Vosselman 2004) asks another question: split the lowest-point grid into segments of
cells joined wherever neighbouring cells differ by no more than ``step``; a building roof is then
one segment bounded by steps *down* to the ground on nearly all of its perimeter, while a
hilltop or the upper side of an embankment joins the surrounding terrain through cells of
gentle slope and is bounded by steps on little or none of it. Cells on the border of the grid
count as open perimeter, so a terrace above a cliff that runs out of the data is not taken for
a roof (a building cut by the border of a tile is left to the buffer of the next one).

:func:`raised_segments` marks the cells of every segment whose perimeter steps are mostly
down-steps (the segment stands above what surrounds it), except the largest segment, which is
the connected terrain itself. Work is one connected-component labelling of the grid's 4-neighbour
graph (as an image, :func:`_label`) and a few ``bincount`` calls: linear in the number of cells,
no loop over cells.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from aldpat._lazy import lazy_import

ndimage = lazy_import("scipy.ndimage")


#: Grid rows labelled at a time: bounds the labelling image and the height differences to a strip.
STRIP_ROWS = 256


def raised_segments(z: np.ndarray, step: float, down_share: float, *,
                    decode: Callable[[np.ndarray], np.ndarray] | None = None,
                    strip_rows: int = STRIP_ROWS) -> np.ndarray:
    """Cells of segments that stand above their surroundings (bool, the shape of ``z``).

    Parameters
    ----------
    z : (rows, cols)
        lowest-point grid with empty cells filled: float heights, or height codes that
        ``decode`` turns into float64 heights (:mod:`aldpat.core.height_codes`).
    step : float
        neighbouring cells whose heights differ by more than this are in different segments (m).
    down_share : float
        a segment is raised when at least this share of the steps on its perimeter go down from it.

    The grid is labelled a strip of rows at a time, each strip's segments joined to those of the
    strip above it where their cells are joined across the strip's edge (a union of labels,
    :func:`_merge`); the steps of each segment are counted as the strips go. Memory: the labels
    (4 bytes a cell) and one strip's scratch.
    """
    rows, cols = z.shape
    if rows * cols < 2:
        return np.zeros(z.shape, bool)

    def heights(a: int, b: int) -> np.ndarray:
        return decode(z[a:b]) if decode is not None else np.asarray(z[a:b], dtype=np.float64)

    label = np.empty((rows, cols), np.int32)
    count = 0
    parts: list[tuple[int, np.ndarray]] = []  # first label, its counts: down-steps, steps, open edge, size
    pairs: list[np.ndarray] = []  # segments joined across a strip's upper edge
    above_z = above_label = None
    for a in range(0, rows, strip_rows):
        b = min(rows, a + strip_rows)
        zs = heights(a, b)
        # height change to the east and north neighbour of every cell (float32 is ample for a step)
        east = (zs[:, 1:] - zs[:, :-1]).astype(np.float32)
        north = (zs[1:, :] - zs[:-1, :]).astype(np.float32)
        strip, n = _label(np.abs(east) <= step, np.abs(north) <= step, b - a, cols)
        strip += count
        label[a:b] = strip
        # the labels this strip counts for: its own and those of the row above it
        base = count if above_label is None else min(count, int(above_label.min()))
        span = count + n - base
        down = np.zeros(span, np.int64)
        steps = np.zeros(span, np.int64)
        edges = [(east, strip[:, :-1], strip[:, 1:]), (north, strip[:-1, :], strip[1:, :])]
        if above_z is not None and above_label is not None:
            rise = (zs[0] - above_z).astype(np.float32)
            joined = np.abs(rise) <= step
            pairs.append(np.stack([above_label[joined], strip[0][joined]]))
            edges.append((rise[None, :], above_label[None, :], strip[:1]))
        for rise, lo, hi in edges:
            cut = np.abs(rise) > step
            la, lb, r = lo[cut] - base, hi[cut] - base, rise[cut]
            down += np.bincount(la[r < 0], minlength=span) + np.bincount(lb[r > 0], minlength=span)
            steps += np.bincount(la, minlength=span) + np.bincount(lb, minlength=span)
        # the grid's own edge is open perimeter: a terrace running out of the data is not enclosed
        # by down-steps the way a roof is
        edge = np.zeros((b - a, cols), bool)
        edge[:, 0] = edge[:, -1] = True
        if a == 0:
            edge[0] = True
        if b == rows:
            edge[-1] = True
        open_edge = np.bincount(strip[edge] - base, minlength=span)
        size = np.bincount(strip.ravel() - base, minlength=span)
        parts.append((base, np.stack([down, steps, open_edge, size])))
        above_z, above_label = zs[-1].copy(), strip[-1].copy()
        count += n
        del zs, east, north, strip
    segment, first = _merge(pairs, count)
    per_label = np.zeros((4, count), np.int64)
    for base, counts in parts:
        per_label[:, base:base + counts.shape[1]] += counts
    del parts
    down_total, steps_total, open_total, size_total = (
        np.bincount(segment, weights=per_label[k], minlength=len(first)) for k in range(4))
    raised = (steps_total > 0) & (down_total >= down_share * (steps_total + open_total))
    # the connected terrain: the largest segment (of equals, the first in row order)
    largest = np.flatnonzero(size_total == size_total.max())
    raised[largest[np.argmin(first[largest])]] = False
    out = np.empty((rows, cols), bool)
    for a in range(0, rows, strip_rows):
        out[a:a + strip_rows] = raised[segment[label[a:a + strip_rows]]]
    return out


def _merge(pairs: list[np.ndarray], count: int) -> tuple[np.ndarray, np.ndarray]:
    """Segments from the strips' labels joined by ``pairs``: the segment of every label, and each
    segment's first label (labels run in row order, so the first is its first cell's)."""
    first_of = np.arange(count)
    if not pairs or not sum(p.shape[1] for p in pairs):
        return first_of, first_of
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    joined = np.concatenate(pairs, axis=1)
    graph = coo_matrix((np.ones(joined.shape[1], np.int8), (joined[0], joined[1])), shape=(count, count))
    n, segment = connected_components(graph, directed=False)
    first = np.full(n, count, np.int64)
    np.minimum.at(first, segment, first_of)
    return segment, first


def _label(join_east: np.ndarray, join_north: np.ndarray, rows: int, cols: int) -> tuple[np.ndarray, int]:
    """Connected components of the grid graph whose edges are the joined neighbour pairs.

    Labelled as an image twice the grid's size in each direction: cell (i, j) is pixel
    (2i, 2j), the pixel between two neighbouring cells is set when they are joined, so
    ``scipy.ndimage.label`` with 4-connectivity joins exactly the joined cells. About 5 bytes
    a cell of grid, against several times that for a sparse graph.
    """
    image = np.zeros((2 * rows - 1, 2 * cols - 1), bool)
    image[::2, ::2] = True
    image[::2, 1::2] = join_east
    image[1::2, ::2] = join_north
    labels, count = ndimage.label(image)
    del image
    label = np.ascontiguousarray(labels[::2, ::2]).astype(np.int32)
    label -= 1  # every cell pixel is set: labels from 1
    return label, int(count)
