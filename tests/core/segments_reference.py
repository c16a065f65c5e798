"""The raised-segment test's graph in its former numpy form (strips labelled as images by
``scipy.ndimage.label``, joined with ``scipy.sparse.csgraph``, pairs found by sorting keys): the
reference the compiled scans of :mod:`aldpat.core.segments` must equal to the bit."""

from __future__ import annotations

from collections.abc import Iterator
from types import SimpleNamespace

import numpy as np
from scipy import ndimage

from aldpat.core.height_codes import Decode
from aldpat.core.segments import step_limits


def segment_graph(z: np.ndarray, step: float, decode: Decode | None, spacing: np.ndarray | None, cell: float,
                   strip_rows: int) -> SimpleNamespace:
    rows, cols = z.shape

    def heights(a: int, b: int) -> np.ndarray:
        return decode(z[a:b]) if decode is not None else np.asarray(z[a:b], dtype=np.float64)

    label = np.empty((rows, cols), np.int32)
    count = 0
    parts: list[tuple[int, np.ndarray]] = []  # first label, its counts: open edge, size, sum of heights
    falls: list[np.ndarray] = []  # per strip: the distinct (higher label, lower label) keys and their steps
    sides: list[tuple[np.ndarray, np.ndarray]] = []  # per strip: (cell, label across) keys of higher, lower cells
    pairs: list[np.ndarray] = []  # segments joined across a strip's upper edge
    above_z = above_label = above_spacing = None
    for a in range(0, rows, strip_rows):
        b = min(rows, a + strip_rows)
        zs = heights(a, b)
        sp = spacing[a:b].astype(np.uint16) if spacing is not None else None
        flat = np.arange(a * cols, b * cols, dtype=np.int64).reshape(b - a, cols)
        # height change to the east and north neighbour of every cell (float32 is ample for a step)
        east = (zs[:, 1:] - zs[:, :-1]).astype(np.float32)
        north = (zs[1:, :] - zs[:-1, :]).astype(np.float32)
        east_cut = np.abs(east) > step_limits(None if sp is None else sp[:, 1:] + sp[:, :-1], step, cell)
        north_cut = np.abs(north) > step_limits(None if sp is None else sp[1:] + sp[:-1], step, cell)
        strip, n = _label(~east_cut, ~north_cut, b - a, cols)
        strip += count
        label[a:b] = strip
        # the labels this strip counts for: its own and those of the row above it
        base = count if above_label is None else min(count, int(above_label.min()))
        span = count + n - base
        edges = [(east, east_cut, strip[:, :-1], strip[:, 1:], flat[:, :-1], flat[:, 1:]),
                 (north, north_cut, strip[:-1, :], strip[1:, :], flat[:-1, :], flat[1:, :])]
        if above_z is not None and above_label is not None:
            rise = (zs[0] - above_z).astype(np.float32)
            cut = np.abs(rise) > step_limits(None if sp is None or above_spacing is None else sp[0] + above_spacing,
                                             step, cell)
            pairs.append(np.stack([above_label[~cut], strip[0][~cut]]))
            edges.append((rise[None, :], cut[None, :], above_label[None, :], strip[:1], flat[:1] - cols, flat[:1]))
        strip_keys, high_side, low_side = [], [], []
        for rise, cut, first_label, second_label, first_cell, second_cell in edges:
            up = rise[cut] > 0  # the second cell is the higher one
            la, lb, ca, cb = first_label[cut], second_label[cut], first_cell[cut], second_cell[cut]
            high, low = np.where(up, lb, la), np.where(up, la, lb)
            strip_keys.append(high.astype(np.int64) << 32 | low)
            high_side.append(np.where(up, cb, ca) << 32 | low)
            low_side.append(np.where(up, ca, cb) << 32 | high)
        falls.append(np.stack(np.unique(np.concatenate(strip_keys), return_counts=True)))
        sides.append((distinct(np.concatenate(high_side)), distinct(np.concatenate(low_side))))
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
        total = np.bincount(strip.ravel() - base, weights=zs.ravel(), minlength=span)
        parts.append((base, np.stack([open_edge, size, total])))
        above_z, above_label = zs[-1].copy(), strip[-1].copy()
        above_spacing = None if sp is None else sp[-1].copy()
        count += n
        del zs, east, north, east_cut, north_cut, strip, sp, flat
    segment, first = _merge(pairs, count)
    per_label = np.zeros((3, count))
    for base, counts in parts:
        per_label[:, base:base + counts.shape[1]] += counts
    del parts
    open_total, size_total, height_total = (np.bincount(segment, weights=per_label[k], minlength=len(first))
                                            for k in range(3))
    # the steps between segments: their pairs, and the cells on either side of them
    label_keys, steps = (np.concatenate([f[k] for f in falls]) for k in range(2))
    del falls
    pair_keys, inverse = np.unique(segment[label_keys >> 32].astype(np.int64) << 32 | segment[label_keys & 0xFFFFFFFF],
                                   return_inverse=True)
    edges_per_pair = np.bincount(inverse, weights=steps, minlength=len(pair_keys))
    high, low = pair_keys >> 32, pair_keys & 0xFFFFFFFF
    side_cells = []
    for side in range(2):  # the higher cells of the steps, then the lower ones
        pair_parts, cell_parts = [], []
        for cells_across in _by_strip([s[side] for s in sides], strip_rows * cols):
            cells = cells_across >> 32
            cells_across = distinct(cells << 32 | segment[cells_across & 0xFFFFFFFF])  # once per segment across
            cells, across = cells_across >> 32, cells_across & 0xFFFFFFFF
            own = segment[label.ravel()[cells]].astype(np.int64)
            pair_parts.append(np.searchsorted(pair_keys, own << 32 | across if side == 0 else across << 32 | own))
            cell_parts.append(cells)
        side_cells.append((np.concatenate(pair_parts), np.concatenate(cell_parts)))
    del sides
    (high_pair, _), (low_pair, low_cell) = side_cells
    # the connected terrain: the largest segment (of equals, the first in row order)
    largest = np.flatnonzero(size_total == size_total.max())
    return SimpleNamespace(segment=segment[label], open=open_total, size=size_total,
                           height=height_total / np.maximum(size_total, 1), high=high, low=low,
                           edges=edges_per_pair, high_cells=np.bincount(high_pair, minlength=len(pair_keys)),
                           low_cells=np.bincount(low_pair, minlength=len(pair_keys)),
                           low_sum=np.bincount(low_pair, weights=heights_at(z, decode, low_cell),
                                               minlength=len(pair_keys)),
                           terrain=int(largest[np.argmin(first[largest])]))


def _by_strip(keys: list[np.ndarray], strip_cells: int) -> Iterator[np.ndarray]:
    """The (cell, label across) keys of every strip, each with the keys of its cells that the next
    strip found (the steps across its upper edge, whose lower cell is this strip's), so that all
    of a cell's keys are seen together: strip by strip, the keys deduplicate as the whole grid's
    would, without a sort of the whole grid's keys."""
    for k, strip in enumerate(keys):
        mine = strip[strip >> 32 >= k * strip_cells]
        if k + 1 < len(keys):
            after = keys[k + 1]
            mine = np.concatenate([mine, after[after >> 32 < (k + 1) * strip_cells]])
        yield mine


def distinct(keys: np.ndarray) -> np.ndarray:
    """The distinct values of ``keys`` in ascending order (``np.unique``'s result), by sorting
    ``keys`` in place. ``np.unique`` of numpy 2.3 and later finds them with a hash table instead,
    which on keys whose low bits repeat -- a cell's index above a label -- ran 20-25 times slower
    than a sort (36 of the test's 45 s on 32 M cells)."""
    keys.sort()
    if len(keys) < 2:
        return keys
    keep = np.empty(len(keys), bool)
    keep[0] = True
    np.not_equal(keys[1:], keys[:-1], out=keep[1:])
    return keys[keep]


def heights_at(z: np.ndarray, decode: Decode | None, cells: np.ndarray) -> np.ndarray:
    """The heights of the cells with flat indices ``cells``."""
    values = z.ravel()[cells]
    return decode(values) if decode is not None else np.asarray(values, dtype=np.float64)


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
