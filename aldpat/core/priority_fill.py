"""Priority boundary interpolation of connected empty cells.

``PQBoundInterp`` and ``findEmpConn`` of the GAPM dissertation (Cui 2013, ch. 4
§4.2.4; summarised again in ch. 5 §5.2.3).

``findEmpConn`` is a breadth-first labelling of 4- or 8-connected empty cells: that is
:func:`scipy.ndimage.label`. ``PQBoundInterp`` pops the lowest boundary cell of a set from a
priority queue, fills its empty neighbours with the mean of their valued neighbours and
pushes them. Followed through, the order fixes the result: a freshly filled cell is never
lower than the cell that filled it, so every filled cell is at least the set's lowest
boundary value, and while the cells next to the lowest boundary cell pop first the flood
spreads over the set at that level; only cells that touch higher boundary cells (the ground
rim and the remnants the set surrounds) take part of their height through the mean. We
compute that result directly instead of popping cell by cell:

1. every set is filled with the lowest elevation of the cells that border it;
2. the cells of the set that touch a valued cell take the mean of their valued neighbours,
   the set's own cells counting at the level of step 1.

The one difference from the queue is in corridors one cell wide between higher cells, where
the queue lets the level creep up along the corridor while here it stays at the set's
lowest level. Everything is vectorized (labels, shifted comparisons, ``np.minimum.at``).

On real data the removed sets join into sheets spanning slopes, and a flat flood from the
lowest corner cuts the terrain beside it; ``rise`` lets the level climb with the distance from
the boundary cell it came from (see :func:`priority_fill`). That flood and the rim are compiled
(numba) and work on the result grid in place, a row or a band of columns at a time: on a grid of
tens of millions of cells a grid-sized temporary per step would cost more than the arithmetic.
"""

from __future__ import annotations

import logging
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from numba import njit

from aldpat._lazy import lazy_import
from aldpat.core.threads import thread_budget

ndimage = lazy_import("scipy.ndimage")

log = logging.getLogger(__name__)

#: columns of one band of the column sweep: its rows are read in order, a band's width at a time
_BAND = 256

_STRUCTURE = {4: np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], dtype=bool), 8: np.ones((3, 3), dtype=bool)}


def _offsets(connectivity: int) -> list[tuple[int, int]]:
    if connectivity == 4:
        return [(-1, 0), (1, 0), (0, -1), (0, 1)]
    return [(dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if (dr, dc) != (0, 0)]


def _shifted(a: np.ndarray, dr: int, dc: int, fill: float | bool) -> np.ndarray:
    """``out[r, c] = a[r + dr, c + dc]`` (``fill`` outside the grid)."""
    out = np.full(a.shape, fill, dtype=a.dtype)
    rows, cols = a.shape
    rs_dst = slice(max(0, -dr), rows - max(0, dr))
    cs_dst = slice(max(0, -dc), cols - max(0, dc))
    rs_src = slice(max(0, dr), rows - max(0, -dr))
    cs_src = slice(max(0, dc), cols - max(0, -dc))
    out[rs_dst, cs_dst] = a[rs_src, cs_src]
    return out


def empty_sets(empty: np.ndarray, *, connectivity: int = 8) -> tuple[np.ndarray, int]:
    """Label the connected sets of empty cells (``findEmpConn``, §4.2.4); 0 = not empty."""
    if connectivity not in _STRUCTURE:
        raise ValueError(f"connectivity must be 4 or 8, got {connectivity!r}")
    labels, count = ndimage.label(empty, structure=_STRUCTURE[connectivity])
    return labels, int(count)


def priority_fill(
    z: np.ndarray,
    empty: np.ndarray,
    *,
    min_conn: int = 0,
    connectivity: int = 8,
    rise: float = 0.0,
    in_place: bool = False,
) -> np.ndarray:
    """Fill empty cells from their lowest boundary upward (``PQBoundInterp``, §4.2.4).

    Parameters
    ----------
    z : 2-D grid; values of empty cells are ignored unless their set is too small.
    empty : bool mask of the cells to interpolate.
    min_conn : sets of at most this many cells are left as they are in ``z`` (line 6;
        ``0`` interpolates every set).
    connectivity : 4 or 8 neighbours, for the sets and for the neighbours of a cell.
    rise : height allowed per cell of distance from a boundary cell. ``0`` is the
        dissertation's queue: every set floods at its lowest boundary level. A positive
        value makes the flood from a low boundary cell rise as it travels, so a large set on
        a slope takes the level of its nearby low boundary instead of its far lowest corner
        (each empty cell gets ``min over valued cells b of z(b) + rise * d(b, cell)``,
        ``d`` the city-block distance).
    in_place : ``z`` (float64, C-ordered) may become the result, saving a grid, where that
        gives the same values: a rising flood over every set (``min_conn`` 0) of finite heights,
        which reaches every empty cell, so that no cell falls back to its value in ``z``.

    Returns the filled grid (a new array unless ``in_place``).
    """
    z = np.ascontiguousarray(z, dtype=np.float64)
    empty = np.ascontiguousarray(empty, dtype=bool)
    if connectivity not in _STRUCTURE:
        raise ValueError(f"connectivity must be 4 or 8, got {connectivity!r}")
    if not empty.any() or empty.all():
        return z.copy()
    if min_conn > 0:
        labels, count = empty_sets(empty, connectivity=connectivity)
        sizes = np.bincount(labels.ravel(), minlength=count + 1)
        big = sizes > int(min_conn)
        big[0] = False
        work = big[labels]  # empty cells of the sets to interpolate
        del labels
        if not work.any():
            return z.copy()
    else:
        work = empty  # every set is interpolated: no labels needed
    valued = ~empty
    if rise > 0:
        own = in_place and min_conn <= 0 and z.flags.writeable and bool(np.isfinite(z).all())
        filled = _rising_flood(z, valued, work, float(rise), own=own)
    else:
        labels, count = empty_sets(empty, connectivity=connectivity)
        level = np.full(count + 1, np.inf)
        for dr, dc in _offsets(connectivity):
            nz = _shifted(z, dr, dc, np.nan)
            nv = _shifted(valued, dr, dc, False)
            hit = work & nv
            np.minimum.at(level, labels[hit], nz[hit])
        filled = np.where(work, level[labels], z)
        del labels
    # the rim: cells of a set touching valued cells take the mean of their neighbours
    offsets = np.array(_offsets(connectivity), dtype=np.int64)
    _rim_means(filled, valued, work, offsets)
    bad = work & ~np.isfinite(filled)
    if bad.any():  # a set with no valued neighbour at all (the whole grid empty around it)
        filled[bad] = z[bad]
    log.debug("priority fill: %d cells interpolated", int(work.sum()))
    return filled


@njit(cache=True, nogil=True)
def _rim_means(filled: np.ndarray, valued: np.ndarray, work: np.ndarray,
               offsets: np.ndarray) -> None:  # pragma: no cover - compiled
    """In place: every ``work`` cell touching a ``valued`` cell takes the mean of its valued and
    ``work`` neighbours (summed in ``offsets`` order). Rows are written one row late, so every
    mean reads the values before the rim was set."""
    rows, cols = filled.shape
    pending = np.empty(cols)
    current = np.empty(cols)
    for r in range(rows + 1):
        if r < rows:
            for c in range(cols):
                current[c] = filled[r, c]
                if not work[r, c]:
                    continue
                total = 0.0
                count = 0
                rim = False
                for k in range(offsets.shape[0]):
                    nr = r + offsets[k, 0]
                    nc = c + offsets[k, 1]
                    if nr < 0 or nr >= rows or nc < 0 or nc >= cols:
                        continue
                    if valued[nr, nc] or work[nr, nc]:
                        total += filled[nr, nc]
                        count += 1
                        if valued[nr, nc]:
                            rim = True
                if rim and count > 0:
                    current[c] = total / count
        if r > 0:
            for c in range(cols):
                filled[r - 1, c] = pending[c]
        pending, current = current, pending


def _rising_flood(z: np.ndarray, valued: np.ndarray, work: np.ndarray, rise: float, max_sweeps: int = 64, *,
                  own: bool = False) -> np.ndarray:
    """``min_b z(b) + rise * d(b, cell)`` over valued cells ``b``, for the ``work`` cells.

    ``d`` is the city-block length of the shortest path from ``b`` through the set. Exact row
    and column envelopes alternate until nothing changes; each turn of the shortest paths costs
    one more sweep, a few on real sets. A stretch of ``work`` cells along a row (or column) ends
    at any other cell: a valued cell passes its value into the stretch, a barrier (an empty cell
    of a set left alone) passes nothing. One running minimum per direction serves the whole
    line: each stretch is offset by a multiple of ``step``, larger than any value, so that the
    stretches before it never win (the offsets cost a few ulps per sweep). ``own``: ``z`` is
    the result (filled in place).
    """
    n = max(z.shape)
    # the largest |height| of a valued cell, without a copy of the valued cells
    span = max(abs(float(np.max(z, where=valued, initial=-np.inf))), abs(float(np.min(z, where=valued, initial=np.inf))))
    span = span if valued.any() else 0.0
    step = 4.0 * (span + rise * n + 1.0)
    out = z if own else z.copy()  # the envelopes run in it: only its work cells change
    out[work] = np.inf
    rows, cols = out.shape
    workers = max(1, min(thread_budget(), rows // 64, cols // 256))
    row_parts = _parts(rows, workers, 1)
    column_parts = _parts(cols, workers, _BAND)
    with ThreadPoolExecutor(workers) as pool:  # rows, and bands of columns, are independent
        for _ in range(max_sweeps):
            changed = any([*pool.map(lambda ab: _row_envelopes(out, valued, work, rise, step, *ab), row_parts)])
            changed |= any([*pool.map(lambda ab: _column_envelopes(out, valued, work, rise, step, *ab), column_parts)])
            if not changed:
                break
    return out


def _parts(n: int, count: int, multiple: int) -> list[tuple[int, int]]:
    """``count`` ranges covering ``0..n``, their starts multiples of ``multiple``."""
    size = -(-n // count)
    size = -(-size // multiple) * multiple
    return [(a, min(n, a + size)) for a in range(0, n, size)]


@njit(cache=True, nogil=True)
def _row_envelopes(v: np.ndarray, valued: np.ndarray, work: np.ndarray, rise: float, step: float,
                   r0: int, r1: int) -> bool:  # pragma: no cover - compiled
    """One row sweep of :func:`_rising_flood`, in place; whether a ``work`` cell fell by more than
    1e-6. Along each row, the forward and backward running minima of ``v - rise * i + offset``;
    a cell neither valued nor ``work`` (a barrier) counts as +inf, and every cell but a ``work``
    cell ends a stretch."""
    n = v.shape[1]
    quarter = step / 4.0
    forward = np.empty(n)
    changed = False
    for r in range(r0, r1):
        total = 0
        for x in range(n):
            total += not work[r, x]
        seen = 0
        acc = np.inf
        for x in range(n):
            seen += not work[r, x]
            offset = float(total - seen) * step
            ramp = float(x) * rise
            t = ((v[r, x] if valued[r, x] or work[r, x] else np.inf) - ramp) + offset
            if t < acc or np.isnan(t):  # NaN carries on, as np.minimum.accumulate
                acc = t
            res = (acc + ramp) - offset
            forward[x] = np.inf if res > quarter else res
        seen = 0
        acc = np.inf
        for i in range(n):
            x = n - 1 - i
            seen += not work[r, x]
            offset = float(total - seen) * step
            ramp = float(i) * rise
            old = v[r, x] if valued[r, x] or work[r, x] else np.inf
            t = (old - ramp) + offset
            if t < acc or np.isnan(t):  # NaN carries on, as np.minimum.accumulate
                acc = t
            res = (acc + ramp) - offset
            if res > quarter:
                res = np.inf
            best = forward[x]
            best = min(best, res)
            if work[r, x] and best < old:
                if old - best > 1e-6:
                    changed = True
                v[r, x] = best
    return changed


@njit(cache=True, nogil=True)
def _column_envelopes(v: np.ndarray, valued: np.ndarray, work: np.ndarray, rise: float, step: float,
                      c_first: int, c_last: int) -> bool:  # pragma: no cover - compiled
    """:func:`_row_envelopes` along the columns, a band of columns at a time (row-major reads)."""
    n = v.shape[0]
    quarter = step / 4.0
    band = _BAND
    forward = np.empty((n, band))
    total = np.zeros(band, np.int64)
    seen = np.zeros(band, np.int64)
    acc = np.empty(band)
    changed = False
    for c0 in range(c_first, c_last, band):
        w = min(band, c_last - c0)
        total[:] = 0
        for y in range(n):
            for j in range(w):
                total[j] += not work[y, c0 + j]
        seen[:] = 0
        acc[:] = np.inf
        for y in range(n):
            ramp = float(y) * rise
            for j in range(w):
                c = c0 + j
                seen[j] += not work[y, c]
                offset = float(total[j] - seen[j]) * step
                t = ((v[y, c] if valued[y, c] or work[y, c] else np.inf) - ramp) + offset
                if t < acc[j] or np.isnan(t):
                    acc[j] = t
                res = (acc[j] + ramp) - offset
                forward[y, j] = np.inf if res > quarter else res
        seen[:] = 0
        acc[:] = np.inf
        for i in range(n):
            y = n - 1 - i
            ramp = float(i) * rise
            for j in range(w):
                c = c0 + j
                seen[j] += not work[y, c]
                offset = float(total[j] - seen[j]) * step
                old = v[y, c] if valued[y, c] or work[y, c] else np.inf
                t = (old - ramp) + offset
                if t < acc[j] or np.isnan(t):
                    acc[j] = t
                res = (acc[j] + ramp) - offset
                if res > quarter:
                    res = np.inf
                best = forward[y, j]
                best = min(best, res)
                if work[y, c] and best < old:
                    if old - best > 1e-6:
                        changed = True
                    v[y, c] = best
    return changed
