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
the connected terrain itself. With ``levels`` it also follows a building's levels inwards:

* a lower level that steps up to taller parts of its building on part of its perimeter and down
  on the rest (a hall against a tower, a lower building in the courtyard of a taller block) is
  raised once those parts are: the steps up into raised segments no longer count, and what is
  left of its perimeter must be steps down all but ``LOOSE_SHARE`` of it -- a segment that also
  steps up into terrain (a terrace below the next one, a yard below a road) stays terrain;
* a level sunk into a roof, stepping only up into raised segments, is raised when it stands more
  than ``step`` above the ground those segments stand on elsewhere; a courtyard at the level of
  that ground stays terrain.

Both are repeated until nothing changes, so a building is taken level by level from the top.

No segment larger than :data:`MAX_OBJECT_AREA` is raised: a plateau above a cliff, a terrace
between escarpments or a tile's block of terrain standing above its neighbour on most of its
perimeter is enclosed by down-steps as a roof is, and only its size tells it from one. The
largest roofs of survey data -- distribution warehouses, airport terminals -- cover up to about
10 ha; the largest raised segment of the seven ISPRS reference samples and the three raw sites
covers 0.47 ha (a station hall).

Where the grid's empty cells were filled from points far apart (sparse data), two neighbouring
cells differ by the terrain's slope times the points' spacing: a 70 % slope sampled every 3 m
gives steps of 2 m between the filled cells of its points. With ``spacing`` (the distance of every
cell from the point it was filled from) a difference counts as a step only where it is steeper
than ``SPACING_SLOPE`` over the two points' distance, for points up to ``SPACING_REACH`` apart;
across a wider data gap every difference above ``step`` remains a step, as the wall beside a gap
is not seen.

Work is one connected-component labelling of the grid's 4-neighbour graph (as an image,
:func:`_label`), a few ``bincount`` calls per strip of rows and, for ``levels``, a few rounds
over the steps between segments: linear in the number of cells, no loop over cells.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from aldpat._lazy import lazy_import
from aldpat.core.height_codes import Decode

ndimage = lazy_import("scipy.ndimage")


#: Grid rows labelled at a time: bounds the labelling image and the height differences to a strip.
STRIP_ROWS = 256
#: Steepest slope (m/m) read as terrain between two points of sparse data, and the farthest apart
#: (m) two points may be for it: beyond that a difference above ``step`` is a step (a data gap).
#: At the ISPRS samples' 1 point/m2 no two neighbouring points are far enough apart for the slope
#: to exceed a step of 1.5 m or more; at 0.1-0.2 points/m2 it keeps slopes of 40-50 % whole.
SPACING_SLOPE = 0.5
SPACING_REACH = 6.0
#: A level peeled off a building may step up into what is not raised, or run out of the grid, on
#: at most this share of its perimeter (a hall against a tower: none; a terrace: about half).
LOOSE_SHARE = 0.1
#: Rounds of peeling at most (a building has a few levels; rounds stop when nothing changes).
LEVEL_ROUNDS = 16
#: The largest area (m2) a raised segment may cover: larger ones are terrain (the module's
#: docstring).
MAX_OBJECT_AREA = 100_000.0


def raised_segments(z: np.ndarray, step: float, down_share: float, *,
                    decode: Decode | None = None,
                    spacing: np.ndarray | None = None, cell: float = 1.0, levels: bool = True,
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
    spacing : (rows, cols) uint8, optional
        the distance (cells) of every cell from the cell it was filled from
        (:func:`aldpat.core.lowest_grid.fill_nearest`): differences between the filled cells of
        sparse points are steps only where steeper than ``SPACING_SLOPE``; ``cell`` is the size
        of a cell (m).
    levels : bool
        also raise a building's lower and sunken levels (the module's docstring); without it, the
        share counts every step of a segment's cells, also those between two of its own cells.

    The grid is labelled a strip of rows at a time, each strip's segments joined to those of the
    strip above it where their cells are joined across the strip's edge (a union of labels,
    :func:`_merge`); the steps between segments are counted as the strips go. Memory: the labels
    (4 bytes a cell) and one strip's scratch.
    """
    rows, cols = z.shape
    if rows * cols < 2:
        return np.zeros(z.shape, bool)
    graph = _segment_graph(z, step, decode, spacing, cell, strip_rows)
    raised = _decide(graph, step, down_share, levels, max_cells=MAX_OBJECT_AREA / (cell * cell))
    out = np.empty((rows, cols), bool)
    for a in range(0, rows, strip_rows):
        out[a:a + strip_rows] = raised[graph.segment[graph.label[a:a + strip_rows]]]
    return out


def step_limits(apart: np.ndarray | None, step: float, cell: float) -> np.ndarray | float:
    """The height difference beyond which two neighbouring cells are a step apart: ``step``, or
    where their points are ``apart`` (the sum of the two cells' distances from the cells they were
    filled from, in cells of ``cell`` m) at most ``SPACING_REACH`` apart, the difference a slope of
    ``SPACING_SLOPE`` makes over that distance where it is more."""
    if apart is None:
        return step
    distance = (apart.astype(np.float32) + 1) * np.float32(cell)
    return np.where(distance <= SPACING_REACH, np.maximum(np.float32(step), SPACING_SLOPE * distance),
                    np.float32(step)).astype(np.float32)


@dataclass
class _Graph:
    """The segments of a grid and the steps between them.

    ``label`` is every cell's label, ``segment`` every label's segment. Per segment: ``open`` (its
    cells on the grid's border), ``size`` (cells) and ``height`` (mean height). Per pair of
    segments with steps between them (``high`` the higher side, ``low`` the lower): ``edges``
    (the steps between neighbouring cells), ``high_cells`` and ``low_cells`` (the cells of either
    side with a step to the other: a cell counts once, however many of its sides step) and
    ``low_sum`` (the sum of those lower cells' heights). A pair of one segment with itself is a
    step between two of its own cells. ``terrain`` is the largest segment.
    """

    label: np.ndarray
    segment: np.ndarray
    open: np.ndarray
    size: np.ndarray
    height: np.ndarray
    high: np.ndarray
    low: np.ndarray
    edges: np.ndarray
    high_cells: np.ndarray
    low_cells: np.ndarray
    low_sum: np.ndarray
    terrain: int


def _segment_graph(z: np.ndarray, step: float, decode: Decode | None, spacing: np.ndarray | None, cell: float,
                   strip_rows: int) -> _Graph:
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
    return _Graph(label, segment, open_total, size_total, height_total / np.maximum(size_total, 1),
                  high, low, edges_per_pair, np.bincount(high_pair, minlength=len(pair_keys)),
                  np.bincount(low_pair, minlength=len(pair_keys)),
                  np.bincount(low_pair, weights=heights_at(z, decode, low_cell), minlength=len(pair_keys)),
                  int(largest[np.argmin(first[largest])]))


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


def _decide(g: _Graph, step: float, down_share: float, levels: bool, max_cells: float) -> np.ndarray:
    """Which segments are raised (one bool per segment); the module's docstring says the rules.
    A segment of more than ``max_cells`` cells never is."""
    n = len(g.open)
    terrain = g.size > max_cells
    terrain[g.terrain] = True
    if not levels:  # every step between neighbouring cells, also between two of a segment's own
        down = np.bincount(g.high, weights=g.edges, minlength=n)
        perimeter = down + np.bincount(g.low, weights=g.edges, minlength=n) + g.open
        raised = (perimeter > g.open) & (down >= down_share * perimeter)
        raised[terrain] = False
        return raised
    between = g.high != g.low  # a step between two of a segment's own cells is no part of its perimeter
    high, low = g.high[between], g.low[between]
    high_cells, low_cells, low_sum = g.high_cells[between], g.low_cells[between], g.low_sum[between]
    down = np.bincount(high, weights=high_cells, minlength=n)
    up = np.bincount(low, weights=low_cells, minlength=n)
    perimeter = down + up + g.open
    raised = (perimeter > g.open) & (down >= down_share * perimeter)
    raised[terrain] = False
    # the ground each segment stands on: the cells its steps down fall to, and their heights
    under_cells = np.bincount(high, weights=low_cells, minlength=n)
    under_sum = np.bincount(high, weights=low_sum, minlength=n)
    for _ in range(LEVEL_ROUNDS):
        into_raised = np.bincount(low, weights=low_cells * raised[high], minlength=n)
        loose = up - into_raised + g.open  # steps up into what is not raised, and open edge
        enclosed = loose <= LOOSE_SHARE * perimeter
        # a lower level: its steps down are the share of what is left of its perimeter
        now = enclosed & (down > 0) & (down >= down_share * (down + loose))
        # a sunken level: only steps up, into raised segments standing lower elsewhere
        sunken = enclosed & (down == 0) & (up > 0)
        now |= _sunken(sunken, raised, g.height, high, low, low_cells, low_sum, under_cells, under_sum, step)
        now |= raised
        now[terrain] = False
        if np.array_equal(now, raised):
            break
        raised = now
    return raised


def _sunken(candidates: np.ndarray, raised: np.ndarray, height: np.ndarray, high: np.ndarray, low: np.ndarray,
            low_cells: np.ndarray, low_sum: np.ndarray, under_cells: np.ndarray, under_sum: np.ndarray,
            step: float) -> np.ndarray:
    """Of the ``candidates`` (segments stepping only up into raised ones), those standing more
    than ``step`` above the ground their raised neighbours step down to elsewhere (the mean height
    of the cells under those neighbours' other steps down, weighted by the cells each candidate
    has against each)."""
    n = len(candidates)
    pick = candidates[low] & raised[high]
    if not pick.any():
        return np.zeros(n, bool)
    around, inner, shared, shared_sum = high[pick], low[pick], low_cells[pick], low_sum[pick]
    elsewhere = under_cells[around] - shared
    weight = np.where(elsewhere > 0, shared, 0.0)
    ground = (under_sum[around] - shared_sum) / np.maximum(elsewhere, 1)
    weights = np.bincount(inner, weights=weight, minlength=n)
    level = np.bincount(inner, weights=weight * ground, minlength=n) / np.maximum(weights, 1e-12)
    return candidates & (weights > 0) & (height > level + step)


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
