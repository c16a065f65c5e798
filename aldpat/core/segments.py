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

Work is a few compiled scans of the grid (:func:`_segment_graph`: the steps, a union-find
labelling of its 4-neighbour graph, the steps and cells between each pair of segments) and, for
``levels``, a few rounds over those pairs: linear in the number of cells.
"""

from __future__ import annotations

import itertools
import threading
from dataclasses import dataclass

import numpy as np

from aldpat.core.compiled import compiled
from aldpat.core.height_codes import Decode
from aldpat.core.rise import scale_and_offset
from aldpat.core.threads import on_threads, thread_budget

#: Grid rows labelled at a time: bounds the labelling's scratch to a strip.
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
    strip above it where their cells are joined across the strip's edge; ``strip_rows`` sets the
    order of the float sums of a segment's heights, not the segments. Memory: the segments
    (4 bytes a cell), the steps (1 byte a cell) and one strip's scratch.
    """
    rows, cols = z.shape
    if rows * cols < 2:
        return np.zeros(z.shape, bool)
    graph = _segment_graph(z, step, decode, spacing, cell, strip_rows)
    raised = _decide(graph, step, down_share, levels, max_cells=MAX_OBJECT_AREA / (cell * cell))
    out = np.empty((rows, cols), bool)
    on_threads(lambda strip: _raised_rows(raised, graph.segment, *strip, out), _strips(rows, strip_rows))
    return out


@compiled(nogil=True)
def _raised_rows(raised: np.ndarray, segment: np.ndarray, a: int, b: int,
                 out: np.ndarray) -> None:  # pragma: no cover - compiled
    """Rows ``a:b`` of the cells of raised segments (``raised`` of each cell's segment)."""
    for i in range(a, b):
        for j in range(segment.shape[1]):
            out[i, j] = raised[segment[i, j]]


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

    ``segment`` is every cell's segment; segments are numbered in the row order of their first
    cells. Per segment: ``open`` (its cells on the grid's border), ``size`` (cells) and
    ``height`` (mean height). Per pair of segments with steps between them, in the order of
    (``high``, ``low``) (``high`` the higher side, ``low`` the lower): ``edges`` (the steps
    between neighbouring cells), ``high_cells`` and ``low_cells`` (the cells of either side with
    a step to the other: a cell counts once, however many of its sides step) and ``low_sum``
    (the sum of those lower cells' heights). A pair of one segment with itself is a step between
    two of its own cells. ``terrain`` is the largest segment.
    """

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


#: Bits of a cell's step flags (:func:`_step_flags`): a step to its east neighbour (next column)
#: and whether that neighbour is the higher side; the same to its north neighbour (next row).
EAST_STEP, EAST_UP, NORTH_STEP, NORTH_UP = 1, 2, 4, 8


def _segment_graph(z: np.ndarray, step: float, decode: Decode | None, spacing: np.ndarray | None, cell: float,
                   strip_rows: int) -> _Graph:
    """The graph of :func:`raised_segments` in five compiled scans of the grid.

    1. every cell's steps to its east and north neighbours, and which side is higher;
    2. the segments of each strip of ``strip_rows`` rows (a union-find, numbered in row order
       of their first cells: an image labelling's numbers; the strips on the process's threads),
       then those joined across the strips' edges (numbered in the order of their first strip
       segments);
    3. per strip segment its open edge, size and sum of heights (in row order; the strips on
       threads), summed per segment in the strips' order -- the order of the float sums is kept
       so that a mean height is the same to the last bit whatever the scans and the threads;
    4. the pairs of segments with steps between them and their steps, from each higher
       segment's list of lower ones (a cell has at most four neighbours, so no sort of the grid;
       bands of rows on threads);
    5. per cell the distinct segments above and below it across its steps, adding the cell
       (and, on the lower side, its height, in row order) to each pair's counts (bands of rows
       on threads, the heights of all but the first band's added after, in row order).

    Memory: the segments (4 bytes a cell), the step flags (1 byte a cell) and per segment and
    pair a few numbers.
    """
    rows, cols = z.shape
    linear = scale_and_offset(decode)
    if decode is not None and linear is None:
        z = decode(z)  # another decoding than ``code * scale + offset``: its float64 heights, whole
    scale, offset = linear if linear is not None else (1.0, 0.0)
    z = np.ascontiguousarray(z)
    scaled = linear is not None
    sp = np.ascontiguousarray(spacing) if spacing is not None else np.zeros((1, 1), np.uint8)
    flags = np.empty((rows, cols), np.uint8)
    _flags_on_threads(z, sp, spacing is not None, scaled, scale, offset, step, cell, flags)
    label = np.empty((rows, cols), np.int32)
    count, joins = _label_strips(flags, strip_rows, label)
    segment, first = _join_labels(joins, joins.shape[1], count)
    del joins
    per_label = _label_totals(z, scaled, scale, offset, label, count, strip_rows)
    open_total, size_total, height_total = (np.bincount(segment, weights=per_label[k], minlength=len(first))
                                            for k in range(3))
    del per_label
    _relabel(label, segment, strip_rows)
    del segment
    high, low, edges, pair_start = _pairs(flags, label, len(first))
    high_cells, low_cells, low_sum = _pair_cells(flags, label, z, scaled, scale, offset, low, pair_start)
    del flags
    # the connected terrain: the largest segment (of equals, the first in row order)
    largest = np.flatnonzero(size_total == size_total.max())
    return _Graph(label, open_total, size_total, height_total / np.maximum(size_total, 1), high, low,
                  edges.astype(np.float64), high_cells, low_cells, low_sum, int(largest[np.argmin(first[largest])]))


@compiled(nogil=True)
def _height(code: float, scaled: bool, scale: float, offset: float) -> float:  # pragma: no cover - compiled
    """A cell's float64 height: ``code * scale + offset`` as ``ScaledHeights`` decodes it (a
    multiplication and an addition, never fused), or the value itself."""
    if scaled:
        h = code * scale
        return h + offset
    return np.float64(code)


@compiled(nogil=True)
def step_limit(apart: int, step: np.float32, cell: np.float32, slope: np.float32,
               reach: np.float32) -> np.float32:  # pragma: no cover - compiled
    """:func:`step_limits` of one pair of cells ``apart`` (float32, as there): ``step``, or the
    difference a slope of ``slope`` makes over the points' distance where they are at most
    ``reach`` apart and it is more."""
    distance = (np.float32(apart) + np.float32(1)) * cell
    if distance <= reach:
        return max(step, slope * distance)
    return step


@compiled(nogil=True)
def _cut(first: float, second: float, apart: int, has_spacing: bool, step: np.float32, cell: np.float32,
         slope: np.float32, reach: np.float32) -> int:  # pragma: no cover - compiled
    """Flags of a step from height ``first`` to the neighbour's ``second``: 1 a step, 3 a step up
    to the neighbour, 0 none. The limit is :func:`step_limits`'s, in float32 as there."""
    rise = np.float32(second - first)
    limit = step_limit(apart, step, cell, slope, reach) if has_spacing else step
    if abs(rise) > limit:
        return 3 if rise > 0 else 1
    return 0


def _flags_on_threads(z: np.ndarray, spacing: np.ndarray, has_spacing: bool, scaled: bool, scale: float,
                      offset: float, step: float, cell: float, flags: np.ndarray) -> None:
    """:func:`_step_flags` in bands of rows on the process's threads (each band its own rows)."""
    on_threads(lambda band: _step_flags(z, spacing, has_spacing, scaled, scale, offset, np.float32(step),
                                        np.float32(cell), np.float32(SPACING_SLOPE), np.float32(SPACING_REACH),
                                        *band, flags), _bands(z.shape[0]))


@compiled(nogil=True)
def _step_flags(z: np.ndarray, spacing: np.ndarray, has_spacing: bool, scaled: bool, scale: float, offset: float,
                step: np.float32, cell: np.float32, slope: np.float32, reach: np.float32, first: int, stop: int,
                flags: np.ndarray) -> None:  # pragma: no cover - compiled
    """Rows ``first:stop`` of every cell's step flags (the bits above)."""
    rows, cols = z.shape
    for i in range(first, stop):
        for j in range(cols):
            h = _height(z[i, j], scaled, scale, offset)
            f = 0
            if j + 1 < cols:
                apart = np.int64(spacing[i, j]) + np.int64(spacing[i, j + 1]) if has_spacing else np.int64(0)
                f |= _cut(h, _height(z[i, j + 1], scaled, scale, offset), apart, has_spacing, step, cell, slope,
                          reach)
            if i + 1 < rows:
                apart = np.int64(spacing[i, j]) + np.int64(spacing[i + 1, j]) if has_spacing else np.int64(0)
                f |= _cut(h, _height(z[i + 1, j], scaled, scale, offset), apart, has_spacing, step, cell, slope,
                          reach) << 2
            flags[i, j] = f


@compiled(nogil=True)
def _find(parent: np.ndarray, x: int) -> int:  # pragma: no cover - compiled
    while parent[x] != x:
        parent[x] = parent[parent[x]]
        x = parent[x]
    return x


@compiled(nogil=True)
def _union(parent: np.ndarray, x: int, y: int) -> None:  # pragma: no cover - compiled
    """Join the sets of ``x`` and ``y``; a set's root is its least member."""
    rx, ry = _find(parent, x), _find(parent, y)
    if rx < ry:
        parent[ry] = rx
    elif ry < rx:
        parent[rx] = ry


def _strips(rows: int, strip_rows: int) -> list[tuple[int, int]]:
    """The rows ``(a, b)`` of each strip of ``strip_rows`` rows, top to bottom."""
    return [(a, min(rows, a + strip_rows)) for a in range(0, rows, strip_rows)]


@compiled(nogil=True)
def _label_strip(flags: np.ndarray, a: int, b: int, label: np.ndarray, parent: np.ndarray,
                 own: np.ndarray) -> int:  # pragma: no cover - compiled
    """The segments of the strip of rows ``a:b`` alone, numbered from 0 in the row order of their
    first cells, into ``label[a:b]`` (``parent``, ``own``: scratch of the strip's cells). Returns
    their number."""
    cols = flags.shape[1]
    for i in range(a, b):
        for j in range(cols):
            k = (i - a) * cols + j
            west = j > 0 and not flags[i, j - 1] & EAST_STEP
            north = i > a and not flags[i - 1, j] & NORTH_STEP
            if west:
                parent[k] = _find(parent, k - 1)
                if north:
                    _union(parent, k, k - cols)
            elif north:
                parent[k] = _find(parent, k - cols)
            else:
                parent[k] = k
    # a cell joined to its west or north neighbour takes that one's label (the same set, whose
    # root, its least cell, has neither: it is numbered before any other cell of the set)
    count = 0
    for i in range(a, b):
        for j in range(cols):
            if j > 0 and not flags[i, j - 1] & EAST_STEP:
                label[i, j] = label[i, j - 1]
            elif i > a and not flags[i - 1, j] & NORTH_STEP:
                label[i, j] = label[i - 1, j]
            else:
                k = (i - a) * cols + j
                r = _find(parent, k)
                if r == k:  # a segment's first cell: the next label
                    own[k] = count
                    count += 1
                label[i, j] = own[r]
    return count


@compiled(nogil=True)
def _number_on(label: np.ndarray, a: int, b: int, first: int) -> None:  # pragma: no cover - compiled
    """The labels of rows ``a:b`` numbered on from ``first``."""
    for i in range(a, b):
        for j in range(label.shape[1]):
            label[i, j] += first


@compiled(nogil=True)
def _joins_across(flags: np.ndarray, label: np.ndarray, a: int, joins: np.ndarray) -> int:  # pragma: no cover
    """The pairs of labels joined across the upper edge of the strip starting at row ``a``, in
    column order, into ``joins``; returns their number."""
    joined = 0
    for j in range(flags.shape[1]):
        if not flags[a - 1, j] & NORTH_STEP:
            joins[0, joined] = label[a - 1, j]
            joins[1, joined] = label[a, j]
            joined += 1
    return joined


def _label_strips(flags: np.ndarray, strip_rows: int, label: np.ndarray) -> tuple[int, np.ndarray]:
    """Each strip's segments, numbered on from the strips above in the row order of their first
    cells, into ``label``; and the pairs of labels joined across each strip's upper edge, strip
    after strip. Returns the number of labels and the joins (``(2, joined)``).

    The strips are labelled on the process's threads, each from 0, and then numbered on from the
    strips above: the same numbers as labelling them one after another."""
    rows, cols = flags.shape
    strips = _strips(rows, strip_rows)
    held = threading.local()

    def label_one(strip: tuple[int, int]) -> int:
        if not hasattr(held, "scratch"):  # each thread's parent and own, kept from one strip to the next
            size = min(rows, strip_rows) * cols
            held.scratch = (np.empty(size, np.int32), np.empty(size, np.int32))
        return _label_strip(flags, *strip, label, *held.scratch)

    firsts = [0, *itertools.accumulate(on_threads(label_one, strips))]
    on_threads(lambda k: _number_on(label, *strips[k], firsts[k]), range(1, len(strips)))
    # the joins of each strip's upper edge, once every strip is numbered, in the strips' order
    joins = np.empty((2, max(0, len(strips) - 1) * cols), np.int64)
    joined = 0
    for a, _ in strips[1:]:
        joined += _joins_across(flags, label, a, joins[:, joined:])
    return firsts[-1], joins[:, :joined]


@compiled(nogil=True)
def _join_labels(joins: np.ndarray, joined: int, count: int) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover
    """The segment of every label (labels joined by ``joins``), numbered in the order of their
    first labels, and each segment's first label."""
    parent = np.arange(count)
    for t in range(joined):
        _union(parent, joins[0, t], joins[1, t])
    segment = np.empty(count, np.int64)
    first = np.empty(count, np.int64)
    n = 0
    for k in range(count):
        r = _find(parent, k)
        if r == k:
            segment[k] = n
            first[n] = k
            n += 1
        else:
            segment[k] = segment[r]
    return segment, first[:n].copy()


@compiled(nogil=True)
def _strip_totals(z: np.ndarray, scaled: bool, scale: float, offset: float, label: np.ndarray, a: int, b: int,
                  out: np.ndarray) -> None:  # pragma: no cover - compiled
    """Per label of the strip of rows ``a:b`` (zeros in ``out`` before): its cells on the grid's
    border, its cells, the sum of their heights (in row order, from 0.0: ``np.bincount``'s sums
    over a strip)."""
    rows, cols = label.shape
    for i in range(a, b):
        for j in range(cols):
            k = label[i, j]
            if i == 0 or i == rows - 1 or j == 0 or j == cols - 1:
                out[0, k] += 1.0
            out[1, k] += 1.0
            out[2, k] += _height(z[i, j], scaled, scale, offset)


def _label_totals(z: np.ndarray, scaled: bool, scale: float, offset: float, label: np.ndarray, count: int,
                  strip_rows: int) -> np.ndarray:
    """:func:`_strip_totals` of every strip of ``label`` (``count`` labels), on the process's
    threads: a label lies in one strip, so the strips add into disjoint columns."""
    out = np.zeros((3, count))
    on_threads(lambda strip: _strip_totals(z, scaled, scale, offset, label, *strip, out),
               _strips(label.shape[0], strip_rows))
    return out


@compiled(nogil=True)
def _relabel_rows(label: np.ndarray, segment: np.ndarray, a: int, b: int) -> None:  # pragma: no cover - compiled
    for i in range(a, b):
        for j in range(label.shape[1]):
            label[i, j] = segment[label[i, j]]


def _relabel(label: np.ndarray, segment: np.ndarray, strip_rows: int) -> None:
    """Every cell's label replaced by its segment, strips on the process's threads."""
    on_threads(lambda strip: _relabel_rows(label, segment, *strip), _strips(label.shape[0], strip_rows))


@compiled(nogil=True)
def _higher_and_lower(flags: np.ndarray, segment: np.ndarray, i: int, j: int,
                      north: bool) -> tuple[int, int]:  # pragma: no cover - compiled
    """The higher and the lower segment of the step from cell (i, j) to its east or north
    neighbour."""
    f = flags[i, j]
    if north:
        here, there, up = segment[i, j], segment[i + 1, j], (f & NORTH_UP) != 0
    else:
        here, there, up = segment[i, j], segment[i, j + 1], (f & EAST_UP) != 0
    return (there, here) if up else (here, there)


def _bands(rows: int) -> list[tuple[int, int]]:
    """The rows of each of the process's threads' bands, top to bottom."""
    count = max(1, min(thread_budget(), rows))
    bounds = [rows * k // count for k in range(count + 1)]
    return list(itertools.pairwise(bounds))


def _pairs(flags: np.ndarray, segment: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The pairs of segments with steps between them, ordered by higher then lower segment, the
    steps of each, and where each higher segment's pairs start (``n + 1`` offsets).

    Each step goes into its higher segment's list of lower ones; the grid is read in bands of
    rows on the process's threads, each band's steps counted and then written into its own part
    of every list (the bands' parts in their order: each list in row order, as one scan makes
    it); each list is then sorted and its runs counted, ranges of segments on threads."""
    bands = _bands(flags.shape[0])
    counts = np.zeros((len(bands), n), np.int64)
    on_threads(lambda t: _count_steps(flags, segment, *bands[t], counts[t]), range(len(bands)))
    start, fill = _list_starts(counts)
    lows = np.empty(start[n], np.int64)
    on_threads(lambda t: _write_steps(flags, segment, *bands[t], fill[t], lows), range(len(bands)))
    ranges = [(n * k // len(bands), n * (k + 1) // len(bands)) for k in range(len(bands))]
    distinct = np.zeros(n + 1, np.int64)
    on_threads(lambda r: _sort_lists(lows, start, *r, distinct), ranges)
    pair_start = np.cumsum(distinct)  # distinct[s + 1]: segment s's pairs
    pairs = int(pair_start[n])
    high_of, low_of, edges = (np.empty(pairs, np.int64) for _ in range(3))
    on_threads(lambda r: _list_pairs(lows, start, pair_start, *r, high_of, low_of, edges), ranges)
    return high_of, low_of, edges, pair_start


@compiled(nogil=True)
def _count_steps(flags: np.ndarray, segment: np.ndarray, a: int, b: int,
                 count: np.ndarray) -> None:  # pragma: no cover - compiled
    """The steps of rows ``a:b`` (a cell's to its east and north neighbours) per higher segment."""
    for i in range(a, b):
        for j in range(flags.shape[1]):
            if flags[i, j] & EAST_STEP:
                count[_higher_and_lower(flags, segment, i, j, False)[0]] += 1
            if flags[i, j] & NORTH_STEP:
                count[_higher_and_lower(flags, segment, i, j, True)[0]] += 1


@compiled(nogil=True)
def _list_starts(counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    """Where each higher segment's list starts (``n + 1`` offsets) and where each band's part of
    it does (the bands' parts in their order)."""
    bands, n = counts.shape
    start = np.zeros(n + 1, np.int64)
    fill = np.empty((bands, n), np.int64)
    at = 0
    for s in range(n):
        start[s] = at
        for t in range(bands):
            fill[t, s] = at
            at += counts[t, s]
    start[n] = at
    return start, fill


@compiled(nogil=True)
def _write_steps(flags: np.ndarray, segment: np.ndarray, a: int, b: int, fill: np.ndarray,
                 lows: np.ndarray) -> None:  # pragma: no cover - compiled
    """The lower segment of every step of rows ``a:b`` into its higher segment's list, at the
    band's next place in it (``fill``)."""
    for i in range(a, b):
        for j in range(flags.shape[1]):
            if flags[i, j] & EAST_STEP:
                high, low = _higher_and_lower(flags, segment, i, j, False)
                lows[fill[high]] = low
                fill[high] += 1
            if flags[i, j] & NORTH_STEP:
                high, low = _higher_and_lower(flags, segment, i, j, True)
                lows[fill[high]] = low
                fill[high] += 1


#: Lists of lower segments at most this long are sorted in place by insertion (most are: a
#: segment has a dozen steps on average; a sort call per list cost more than the sorting). Whole
#: numbers come out in the one sorted order whichever way they are sorted.
_SHORT_LIST = 32


@compiled(nogil=True)
def _insertion_sort(values: np.ndarray, a: int, b: int) -> None:  # pragma: no cover - compiled
    """``values[a:b]`` sorted in place, ascending."""
    for k in range(a + 1, b):
        v = values[k]
        m = k - 1
        while m >= a and values[m] > v:
            values[m + 1] = values[m]
            m -= 1
        values[m + 1] = v


@compiled(nogil=True)
def _sort_lists(lows: np.ndarray, start: np.ndarray, first: int, stop: int,
                distinct: np.ndarray) -> None:  # pragma: no cover - compiled
    """Segments ``first:stop``'s lists sorted in place, and the distinct lower segments of each
    (into ``distinct[s + 1]``)."""
    for s in range(first, stop):
        a, b = start[s], start[s + 1]
        if b > a:
            if b - a <= _SHORT_LIST:
                _insertion_sort(lows, a, b)
            else:
                lows[a:b].sort()
            runs = 1
            for k in range(a + 1, b):
                if lows[k] != lows[k - 1]:
                    runs += 1
            distinct[s + 1] = runs


@compiled(nogil=True)
def _list_pairs(lows: np.ndarray, start: np.ndarray, pair_start: np.ndarray, first: int, stop: int,
                high_of: np.ndarray, low_of: np.ndarray, edges: np.ndarray) -> None:  # pragma: no cover - compiled
    """The pairs of segments ``first:stop`` (from their sorted lists) and the steps of each."""
    for s in range(first, stop):
        pairs = pair_start[s] - 1
        for k in range(start[s], start[s + 1]):
            if k == start[s] or lows[k] != lows[k - 1]:
                pairs += 1
                high_of[pairs] = s
                low_of[pairs] = lows[k]
                edges[pairs] = 0
            edges[pairs] += 1


@compiled(nogil=True)
def _pair_of(low: np.ndarray, pair_start: np.ndarray, high: int, lower: int) -> int:  # pragma: no cover - compiled
    a = pair_start[high]
    return a + np.searchsorted(low[a:pair_start[high + 1]], lower)


@compiled(nogil=True)
def _add_once(seen: np.ndarray, count: int, segment: int) -> int:  # pragma: no cover - compiled
    """``segment`` added to the first ``count`` of ``seen`` unless there; the new count."""
    for k in range(count):
        if seen[k] == segment:
            return count
    seen[count] = segment
    return count + 1


def _pair_cells(flags: np.ndarray, segment: np.ndarray, z: np.ndarray, scaled: bool, scale: float, offset: float,
                low: np.ndarray, pair_start: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per pair: the higher side's cells with a step down to the lower segment, the lower side's
    cells with a step up to the higher one, and the sum of the lower cells' heights (in row
    order). A cell counts once per segment across, however many of its sides step to it.

    The grid is read in bands of rows on the process's threads: the first band adds into the
    totals, every other counts into its own and lists its lower cells' pairs and heights, which
    are added after, band after band -- each pair's heights summed in row order from 0.0, as one
    scan of the grid sums them."""
    bands = _bands(flags.shape[0])
    pairs = len(low)
    totals = (np.zeros(pairs, np.int64), np.zeros(pairs, np.int64), np.zeros(pairs))
    # a band's own counts and listed pairs in 4 bytes where they fit (a cell has at most 4 steps)
    small = np.int32 if max(pairs, 4 * flags.size) < 2 ** 31 else np.int64

    def band(t: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        a, b = bands[t]
        if t == 0:
            own, room = totals, 0
        else:  # a lower cell's pair and height for each step into the band at most
            own, room = (np.zeros(pairs, small), np.zeros(pairs, small), np.zeros(0)), _steps_into(flags, a, b)
        at, heights = np.empty(room, small), np.empty(room)
        held = _band_cells(flags, segment, z, scaled, scale, offset, low, pair_start, a, b, *own, t > 0, at, heights)
        return own[0], own[1], at[:held], heights[:held]

    high_cells, low_cells, low_sum = totals
    for t, (high_part, low_part, at, heights) in enumerate(on_threads(band, range(len(bands)))):
        if t > 0:
            high_cells += high_part
            low_cells += low_part
            _add_in_order(low_sum, at, heights)
    return high_cells, low_cells, low_sum


@compiled(nogil=True)
def _steps_into(flags: np.ndarray, a: int, b: int) -> int:  # pragma: no cover - compiled
    """The steps of the cells of rows ``a:b`` and those into row ``a`` from the row before it:
    every step with a cell of the band on its lower side, and more."""
    count = 0
    for i in range(max(a - 1, 0), b):
        for j in range(flags.shape[1]):
            f = flags[i, j]
            count += (f & NORTH_STEP) != 0
            if i >= a:
                count += (f & EAST_STEP) != 0
    return count


@compiled(nogil=True)
def _add_in_order(total: np.ndarray, at: np.ndarray, values: np.ndarray) -> None:  # pragma: no cover - compiled
    for k in range(len(at)):
        total[at[k]] += values[k]


@compiled(nogil=True)
def _band_cells(flags: np.ndarray, segment: np.ndarray, z: np.ndarray, scaled: bool, scale: float, offset: float,
                low: np.ndarray, pair_start: np.ndarray, first: int, stop: int, high_cells: np.ndarray,
                low_cells: np.ndarray, low_sum: np.ndarray, listed: bool, at: np.ndarray,
                heights: np.ndarray) -> int:  # pragma: no cover - compiled
    """:func:`_pair_cells` of rows ``first:stop`` into ``high_cells`` and ``low_cells``, and the
    lower cells' heights into ``low_sum`` or, ``listed``, their pairs and heights in row order
    into ``at`` and ``heights`` (returns how many)."""
    cols = flags.shape[1]
    held = 0
    above = np.empty(4, np.int64)  # the segments across a cell's steps up
    below = np.empty(4, np.int64)  # ... and down
    for i in range(first, stop):
        for j in range(cols):
            ups = downs = 0
            f = flags[i, j]
            if f & EAST_STEP:
                if f & EAST_UP:
                    ups = _add_once(above, ups, segment[i, j + 1])
                else:
                    downs = _add_once(below, downs, segment[i, j + 1])
            if f & NORTH_STEP:
                if f & NORTH_UP:
                    ups = _add_once(above, ups, segment[i + 1, j])
                else:
                    downs = _add_once(below, downs, segment[i + 1, j])
            if j > 0 and flags[i, j - 1] & EAST_STEP:  # the west neighbour's step: this cell is its east
                if flags[i, j - 1] & EAST_UP:
                    downs = _add_once(below, downs, segment[i, j - 1])
                else:
                    ups = _add_once(above, ups, segment[i, j - 1])
            if i > 0 and flags[i - 1, j] & NORTH_STEP:
                if flags[i - 1, j] & NORTH_UP:
                    downs = _add_once(below, downs, segment[i - 1, j])
                else:
                    ups = _add_once(above, ups, segment[i - 1, j])
            s = segment[i, j]
            for k in range(downs):
                high_cells[_pair_of(low, pair_start, s, below[k])] += 1
            if ups:
                h = _height(z[i, j], scaled, scale, offset)
                for k in range(ups):
                    p = _pair_of(low, pair_start, above[k], s)
                    low_cells[p] += 1
                    if listed:
                        at[held] = p
                        heights[held] = h
                        held += 1
                    else:
                        low_sum[p] += h
    return held


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
    return _levels(terrain, g.open, g.height, g.high, g.low, g.high_cells, g.low_cells, g.low_sum,
                   float(down_share), float(step), LOOSE_SHARE, LEVEL_ROUNDS)


@compiled(nogil=True)
def _levels(terrain: np.ndarray, open_: np.ndarray, height: np.ndarray, high: np.ndarray, low: np.ndarray,
            high_cells: np.ndarray, low_cells: np.ndarray, low_sum: np.ndarray, down_share: float, step: float,
            loose_share: float, rounds: int) -> np.ndarray:  # pragma: no cover - compiled
    """:func:`_decide` with ``levels``: the segments raised by their own steps, then the rounds
    that peel a building's levels, each a few loops over the pairs and the segments. A step
    between two of a segment's own cells is no part of its perimeter: those pairs are skipped.
    Every sum runs over the pairs in their order from 0.0, as ``np.bincount`` over the pairs kept
    sums (the numpy form this replaces), so a segment's level is the same to the last bit.

    A sunken level (a candidate: enclosed, only steps up) is raised when it stands more than
    ``step`` above the ground its raised neighbours step down to elsewhere: the mean height of
    the cells under those neighbours' other steps down, weighted by the cells the candidate has
    against each."""
    n = len(open_)
    down = np.zeros(n)
    up = np.zeros(n)
    under_cells = np.zeros(n)  # the ground each segment stands on: the cells its steps down fall to
    under_sum = np.zeros(n)  # ... and their heights
    for p in range(len(high)):
        if high[p] != low[p]:
            down[high[p]] += high_cells[p]
            up[low[p]] += low_cells[p]
            under_cells[high[p]] += low_cells[p]
            under_sum[high[p]] += low_sum[p]
    perimeter = np.empty(n)
    raised = np.empty(n, np.bool_)
    for s in range(n):
        perimeter[s] = down[s] + up[s] + open_[s]
        raised[s] = perimeter[s] > open_[s] and down[s] >= down_share * perimeter[s] and not terrain[s]
    pairs = len(high)
    into_raised = np.empty(n)
    weights = np.empty(n)
    level = np.empty(n)
    now = np.empty(n, np.bool_)
    candidates = np.empty(n, np.bool_)
    for _ in range(rounds):
        into_raised[:] = 0.0
        for p in range(pairs):
            if high[p] != low[p]:
                into_raised[low[p]] += low_cells[p] * (1.0 if raised[high[p]] else 0.0)
        for s in range(n):
            loose = up[s] - into_raised[s] + open_[s]  # steps up into what is not raised, and open edge
            enclosed = loose <= loose_share * perimeter[s]
            # a lower level: its steps down are the share of what is left of its perimeter
            now[s] = enclosed and down[s] > 0 and down[s] >= down_share * (down[s] + loose)
            # a sunken level: only steps up, into raised segments standing lower elsewhere
            candidates[s] = enclosed and down[s] == 0 and up[s] > 0
        # the ground the candidates' raised neighbours step down to elsewhere
        weights[:] = 0.0
        level[:] = 0.0
        for p in range(pairs):
            around, inner = high[p], low[p]
            if around != inner and candidates[inner] and raised[around]:
                shared = np.float64(low_cells[p])
                elsewhere = under_cells[around] - shared
                weight = shared if elsewhere > 0 else 0.0
                ground = (under_sum[around] - low_sum[p]) / max(elsewhere, 1.0)
                weights[inner] += weight
                level[inner] += weight * ground
        changed = False
        for s in range(n):
            if candidates[s] and weights[s] > 0 and height[s] > level[s] / max(weights[s], 1e-12) + step:
                now[s] = True
            now[s] = (now[s] or raised[s]) and not terrain[s]
            changed = changed or now[s] != raised[s]
        if not changed:
            break
        raised[:] = now
    return raised

