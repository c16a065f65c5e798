"""One pass of a line filter over a block of grid lines, compiled: open, rise, decide.

A pass of the adaptive morphological filter (dissertation §6.2.4, ``AdaptiveMorphFilter`` lines
13-17) opens every line of the surface -- a row, or a column -- with a line window of half size
``k``, takes every cell's height above the opening and removes the unfiltered cells rising more
than a threshold; between a lower and an upper threshold an adaptive threshold decides, so those
cells are listed for it. In numpy and scipy that is a running minimum and maximum, two decodings,
a subtraction, masks, ``nonzero``, a vectorised threshold analysis and, for a column, a transposed
copy of the block and of its marks there and back. Here one compiled loop does all of it for a
block of lines, in place on the surface grid and the mark matrix, and holds no lock, so blocks
run on several threads at once.

Lines are taken :data:`LANES` at a time, side by side: a group of columns is read where it lies
(neighbours in each grid row), and each step of the opening serves every line of the group. The
opening is van Herk's and Gil and Werman's running minimum and maximum: three comparisons a
cell whatever the window. A window reaching past the end of a line sees the end cell repeated
(:func:`aldpat.core.morphology.opening` with its ``nearest`` border), or, with ``trend`` edges,
the line continued along the trend of its lowest cells
(:func:`aldpat.core.morphology.opening_along_trend`, as the filter's
:func:`aldpat.filters.gapm.opened_along_trend` brings it back onto the grid's own values). The
adaptive threshold is :func:`aldpat.core.trend.row_thresholds`.

Every value is numpy's to the bit: a height is ``code * scale + offset`` as
:class:`aldpat.core.height_codes.ScaledHeights` decodes it (a multiplication and an addition, never
fused), an opening only picks values, and the trend's continuation is computed with the same
operations in the same order as :mod:`aldpat.core.morphology` computes it.
"""

from __future__ import annotations

import threading

import numpy as np

from aldpat.core.compiled import compiled, prefetch
from aldpat.core.trend import row_thresholds

#: Lines filtered side by side: a group of columns of 4-byte codes reads one 64-byte cache line of
#: each grid row it crosses.
LANES = 16
#: Grid rows ahead whose cells of a column group are asked for while this row's are copied in: a
#: column group's cells lie a grid row apart, farther than the processor's own prefetching looks,
#: so each row of the copy waited on memory (``aldpat.core.compiled.prefetch``).
_AHEAD = 16


def filter_lines(grid: np.ndarray, mark: np.ndarray, first: int, last: int, axis: int, k: int, label: int,
                 cap: float, floor: float, threshold: tuple[float, float] | None, trend: bool,
                 scale_offset: tuple[float, float] | None) -> None:
    """One pass over the lines ``first:last`` of ``grid`` (rows, ``axis=1``; columns, ``axis=0``).

    Each line of ``grid`` is replaced by its opening (half window ``k``; ``trend``: continued past
    its ends along its trend), and ``label`` is written into ``mark`` where an unfiltered cell
    (``mark`` 0 before the pass) rises above it more than ``cap``, or more than ``floor`` and more
    than its adaptive threshold (:func:`aldpat.core.trend.candidate_thresholds` with
    ``threshold`` = (cluster threshold, cap's divisor); None: no adaptive threshold). ``grid``
    holds height codes decoded by ``scale_offset`` (``(scale, offset)``), or float64 heights
    without NaN when it is None.
    """
    along_rows = axis == 1
    n = grid.shape[1] if along_rows else grid.shape[0]
    decoded = scale_offset is not None
    scale, offset = scale_offset if scale_offset is not None else (1.0, 0.0)
    adaptive = threshold is not None
    ct, divisor = threshold if threshold is not None else (1.0, 1.0)
    kk = min(int(k), n)  # wider sees the whole line from every cell: the same opening
    _filter_lines(grid, mark, int(first), int(last), along_rows, int(k), kk, int(label), float(cap), float(floor),
                  adaptive, float(ct), float(divisor), bool(trend), decoded, float(scale), float(offset),
                  *_scratch(n, n + 2 * kk, grid.dtype))


_held = threading.local()


def _scratch(n: int, padded: int, dtype: np.dtype) -> tuple[np.ndarray, ...]:
    """This thread's work arrays for lines of ``n`` cells (a pass's openings need ``padded``
    cells): kept from one block to the next, since fresh pages for every block cost more than
    filtering it (page faults and zeroing)."""
    held = getattr(_held, "arrays", None)
    if held is None or held[0].shape[0] != n or held[3].shape[0] < padded or held[0].dtype != dtype:
        lanes = LANES
        held = (np.empty((n, lanes), dtype), np.empty((n, lanes), dtype), np.empty((n, lanes), dtype),
                np.empty((padded, lanes), dtype), np.empty((padded, lanes), dtype), np.empty((lanes, n)),
                np.empty((n, lanes)), np.empty((lanes, n), np.bool_), np.empty((n, lanes), np.bool_),
                np.empty((lanes, n), np.int64), np.empty(n), np.empty((3, n), np.int64))
        _held.arrays = held
    return held


@compiled(nogil=True)
def _pick(a: float, b: float, maximum: bool) -> float:  # pragma: no cover - compiled
    return max(a, b) if maximum else min(a, b)


@compiled(nogil=True)
def _running(src: np.ndarray, n: int, k: int, out: np.ndarray, g: np.ndarray, h: np.ndarray,
             maximum: bool) -> None:  # pragma: no cover - compiled
    """``out[i]``: the minimum (``maximum``: the maximum) of ``src[i - k:i + k + 1]`` for every
    ``i < n``, lane by lane (the columns of ``src``), the end cells repeated past the line: van
    Herk / Gil-Werman, the prefix and suffix extremes of blocks of ``2k + 1`` cells of the padded
    line in ``g`` and ``h``."""
    lanes = src.shape[1]
    w = 2 * k + 1
    size = n + 2 * k
    for start in range(0, size, w):
        stop = min(start + w, size)
        at = min(max(start - k, 0), n - 1)
        for r in range(lanes):
            g[start, r] = src[at, r]
        for i in range(start + 1, stop):
            at = min(max(i - k, 0), n - 1)
            for r in range(lanes):
                g[i, r] = _pick(g[i - 1, r], src[at, r], maximum)
        at = min(max(stop - 1 - k, 0), n - 1)
        for r in range(lanes):
            h[stop - 1, r] = src[at, r]
        for i in range(stop - 2, start - 1, -1):
            at = min(max(i - k, 0), n - 1)
            for r in range(lanes):
                h[i, r] = _pick(h[i + 1, r], src[at, r], maximum)
    for i in range(n):
        for r in range(lanes):
            out[i, r] = _pick(h[i, r], g[i + w - 1, r], maximum)


@compiled(nogil=True)
def _lanes_opening(src: np.ndarray, n: int, k: int, out: np.ndarray, eroded: np.ndarray, g: np.ndarray,
                   h: np.ndarray) -> None:  # pragma: no cover - compiled
    """``out[:n]``: the opening of every lane of ``src[:n]`` (erosion, then dilation of the
    erosion, each with the end cells repeated); ``g``, ``h``: ``(n + 2k, lanes)`` at least."""
    if k == 0:
        out[:n] = src[:n]
        return
    _running(src, n, k, eroded, g, h, False)
    _running(eroded, n, k, out, g, h, True)


@compiled(nogil=True)
def _opening(src: np.ndarray, n: int, k: int, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """``out[:n]``: the opening of the line ``src[:n]`` (one lane)."""
    lane = np.empty((n, 1))
    lane[:, 0] = src[:n]
    size = n + 2 * k
    opened = np.empty((n, 1))
    _lanes_opening(lane, n, k, opened, np.empty((n, 1)), np.empty((size, 1)), np.empty((size, 1)))
    out[:n] = opened[:, 0]


@compiled(nogil=True)
def _lowest(z: np.ndarray, first: int, last: int) -> int:  # pragma: no cover - compiled
    """Where the first lowest of ``z[first:last]`` lies (numpy's ``argmin``, without NaN)."""
    at = first
    for i in range(first + 1, last):
        if z[i] < z[at]:
            at = i
    return at


@compiled(nogil=True)
def _continuation(z: np.ndarray, outer: int, inner: int, edge: int, k: int, towards_start: bool,
                  out: np.ndarray) -> None:  # pragma: no cover - compiled
    """The ``k`` cells continuing a line past ``edge`` along the line through its heights at
    ``outer`` and ``inner``, into ``out`` in the line's order (morphology's ``continued``)."""
    slope = (z[outer] - z[inner]) / abs(outer - inner)
    at_edge = z[outer] + slope * abs(edge - outer)
    for j in range(k):
        step = k - j if towards_start else j + 1
        out[j] = at_edge + slope * step


@compiled(nogil=True)
def _trend_ends(z: np.ndarray, n: int, k: int, first: np.ndarray, last: np.ndarray) -> None:  # pragma: no cover
    """The first and the last ``min(2k, n)`` cells of the opening of ``z[:n]`` continued ``k``
    cells past both ends along its trend (``n`` >= 4, ``k`` >= 1), as
    :func:`aldpat.core.morphology.trend_opening_at_ends` computes them."""
    span = min(k, n // 2)
    reach = min(2 * k, n)
    left = np.empty(k)
    right = np.empty(k)
    _continuation(z, _lowest(z, n - span, n), _lowest(z, n - 2 * span, n - span), n - 1, k, False, right)
    _continuation(z, _lowest(z, 0, span), _lowest(z, span, 2 * span), 0, k, True, left)
    if n <= 4 * k:  # the end pieces would cover the line: open it whole
        size = n + 2 * k
        padded = np.empty(size)
        padded[:k] = left
        padded[k:k + n] = z[:n]
        padded[k + n:] = right
        opened = np.empty(size)
        _opening(padded, size, k, opened)
        first[:reach] = opened[k:k + reach]
        last[:reach] = opened[k + n - reach:k + n]
        return
    inner = 4 * k
    piece = np.empty(5 * k)
    opened = np.empty(5 * k)
    piece[:k] = left
    piece[k:] = z[:inner]
    _opening(piece, 5 * k, k, opened)
    first[:reach] = opened[k:k + reach]
    piece[:inner] = z[n - inner:n]
    piece[inner:] = right
    _opening(piece, 5 * k, k, opened)
    last[:reach] = opened[inner - reach:inner]


@compiled(nogil=True)
def _onto_own_heights(z: np.ndarray, codes: np.ndarray, trend: np.ndarray, ends: int, near: int, reach: int,
                      pool: int, rise: np.ndarray, opened: np.ndarray) -> None:  # pragma: no cover - compiled
    """Cells ``ends:ends + reach`` of a line: their rise above the trend's opening, and their opened
    code the highest of the line's own heights in ``near:near + pool`` not above the trend's opening
    there (the lowest, if all are; the first of equals), as ``opened_along_trend`` picks it."""
    for t in range(reach):
        cell = ends + t
        target = trend[t]
        rise[cell] = z[cell] - target
        pick = -1
        for q in range(near, near + pool):
            if z[q] <= target and (pick < 0 or z[q] > z[pick]):
                pick = q
        if pick < 0:
            pick = _lowest(z, near, near + pool)
        opened[cell] = codes[pick]


@compiled(nogil=True)
def _filter_lines(grid: np.ndarray, mark: np.ndarray, first: int, last: int, along_rows: bool, k: int, kk: int,
                  label: int, cap: float, floor: float, adaptive: bool, ct: float, divisor: float, trend: bool,
                  decoded: bool, scale: float, offset: float, codes: np.ndarray, opened: np.ndarray,
                  eroded: np.ndarray, g: np.ndarray, h: np.ndarray, heights: np.ndarray, rise: np.ndarray,
                  unfiltered: np.ndarray, removed: np.ndarray, band: np.ndarray, thresholds: np.ndarray,
                  work: np.ndarray) -> None:  # pragma: no cover - compiled
    n = grid.shape[1] if along_rows else grid.shape[0]
    lanes = LANES
    count = np.empty(lanes, np.int64)
    ends = trend and k > 0 and n >= 4
    reach = min(2 * k, n)
    pool = min(4 * k, n)
    first_end = np.empty(reach if ends else 0)
    last_end = np.empty(reach if ends else 0)
    for start in range(first, last, lanes):
        width = min(lanes, last - start)
        # a group of lines side by side, each a lane: a column group is read where it lies (its
        # cells in a grid row are neighbours), a row group a row at a time
        if along_rows:
            for r in range(width):
                for j in range(n):
                    codes[j, r] = grid[start + r, j]
                    unfiltered[r, j] = mark[start + r, j] == 0
        else:
            for j in range(n):
                if j + _AHEAD < n:
                    prefetch(grid, j + _AHEAD, start)
                    prefetch(grid, j + _AHEAD, start + width - 1)
                    prefetch(mark, j + _AHEAD, start)
                    prefetch(mark, j + _AHEAD, start + width - 1)
                for r in range(width):
                    codes[j, r] = grid[j, start + r]
                    unfiltered[r, j] = mark[j, start + r] == 0
        for j in range(n):  # the lanes past the last line: copies of the first, never written back
            for r in range(width, lanes):
                codes[j, r] = codes[j, 0]
        _lanes_opening(codes, n, kk, opened, eroded, g, h)
        for j in range(n):
            for r in range(lanes):
                if decoded:
                    z = codes[j, r] * scale
                    z = z + offset
                    o = opened[j, r] * scale
                    o = o + offset
                else:
                    z = codes[j, r]
                    o = opened[j, r]
                heights[r, j] = z
                rise[j, r] = z - o
        removed[:] = False
        if ends:
            for r in range(width):
                z, d = heights[r], rise[:, r]
                _trend_ends(z, n, k, first_end, last_end)
                _onto_own_heights(z, codes[:, r], last_end, n - reach, n - pool, reach, pool, d, opened[:, r])
                _onto_own_heights(z, codes[:, r], first_end, 0, 0, reach, pool, d, opened[:, r])
        count[:] = 0
        for j in range(n):
            for r in range(width):
                if unfiltered[r, j]:
                    if rise[j, r] > cap:
                        removed[j, r] = True
                    elif rise[j, r] > floor:
                        band[r, count[r]] = j
                        count[r] += 1
        if adaptive:
            for r in range(width):
                if count[r]:
                    line_band = band[r, :count[r]]
                    row_thresholds(heights[r], unfiltered[r], line_band, k, ct, divisor, thresholds, work)
                    for q in range(count[r]):
                        if rise[line_band[q], r] > thresholds[q]:
                            removed[line_band[q], r] = True
        if along_rows:
            for r in range(width):
                for j in range(n):
                    grid[start + r, j] = opened[j, r]
                    if removed[j, r]:
                        mark[start + r, j] = label
        else:
            for j in range(n):
                for r in range(width):
                    grid[j, start + r] = opened[j, r]
                    if removed[j, r]:
                        mark[j, start + r] = label
