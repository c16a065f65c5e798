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
the boundary cell it came from (see :func:`priority_fill`).
"""

from __future__ import annotations

import logging

import numpy as np

from aldpat._lazy import lazy_import

ndimage = lazy_import("scipy.ndimage")

log = logging.getLogger(__name__)

_STRUCTURE = {4: np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], dtype=bool), 8: np.ones((3, 3), dtype=bool)}


def _offsets(connectivity: int) -> list[tuple[int, int]]:
    if connectivity == 4:
        return [(-1, 0), (1, 0), (0, -1), (0, 1)]
    return [(dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if (dr, dc) != (0, 0)]


def _shifted(a: np.ndarray, dr: int, dc: int, fill) -> np.ndarray:
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

    Returns a new array.
    """
    z = np.asarray(z, dtype=np.float64)
    empty = np.asarray(empty, dtype=bool)
    out = z.copy()
    labels, count = empty_sets(empty, connectivity=connectivity)
    if count == 0 or empty.all():
        return out
    sizes = np.bincount(labels.ravel(), minlength=count + 1)
    big = sizes > max(int(min_conn), 0)
    big[0] = False
    work = big[labels]  # empty cells of the sets to interpolate
    if not work.any():
        return out
    offsets = _offsets(connectivity)
    valued = ~empty
    if rise > 0:
        filled = _rising_flood(z, valued, work, float(rise))
    else:
        level = np.full(count + 1, np.inf)
        for dr, dc in offsets:
            nz = _shifted(z, dr, dc, np.nan)
            nv = _shifted(valued, dr, dc, False)
            hit = work & nv
            np.minimum.at(level, labels[hit], nz[hit])
        filled = np.where(work, level[labels], z)
    # the rim: cells of a set touching valued cells take the mean of their neighbours
    total = np.zeros(z.shape)
    count_n = np.zeros(z.shape)
    rim = np.zeros(z.shape, dtype=bool)
    for dr, dc in offsets:
        nv = _shifted(valued, dr, dc, False)
        nw = _shifted(work, dr, dc, False)
        nz = _shifted(filled, dr, dc, np.nan)
        use = work & (nv | nw)
        total[use] += nz[use]
        count_n[use] += 1
        rim |= work & nv
    np.copyto(out, filled, where=work)
    np.divide(total, count_n, out=out, where=rim & (count_n > 0))
    bad = work & ~np.isfinite(out)
    if bad.any():  # a set with no valued neighbour at all (the whole grid empty around it)
        out[bad] = z[bad]
    log.debug("priority fill: %d sets, %d interpolated", count, int(big.sum()))
    return out


def _segment_envelope(v: np.ndarray, offsets: tuple[np.ndarray, np.ndarray], rise: float,
                      step: float) -> np.ndarray:
    """Along each row: ``min_y v(y) + rise * |x - y|`` over ``y`` reachable from ``x``.

    Valued cells and barriers (``v`` +inf) end a stretch of interpolated cells: a value passes
    into the stretch from them but not through them. Each stretch is made independent of the
    earlier ones by a per-stretch offset larger than any value (``offsets``, from
    :func:`_stretch_offsets`), so one running minimum per direction serves the whole row.
    """
    _rows, n = v.shape
    ramp = np.arange(n, dtype=np.float64)[None, :] * rise
    out = np.full(v.shape, np.inf)
    for sign, offset in zip((1, -1), offsets):
        vv = v if sign == 1 else v[:, ::-1]
        acc = np.minimum.accumulate(vv - ramp + offset, axis=1)
        acc += ramp
        acc -= offset
        acc[acc > step / 4.0] = np.inf     # from an earlier stretch: not reachable
        if sign == -1:
            acc = acc[:, ::-1]
        np.minimum(out, acc, out=out)
    return out


def _stretch_offsets(stop: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Per-stretch offsets for the forward and the backward running minimum of each row."""
    out = []
    for src in (stop, stop[:, ::-1]):
        seg = np.cumsum(src, axis=1, dtype=np.float64)
        out.append((seg[:, -1:] - seg) * step)   # earlier stretches lie higher
    return out[0], out[1]


def _rising_flood(z, valued, work, rise, max_sweeps: int = 64) -> np.ndarray:
    """``min_b z(b) + rise * d(b, cell)`` over valued cells ``b``, for the ``work`` cells.

    ``d`` is the city-block length of the shortest path from ``b`` through the set. Exact row
    and column envelopes (:func:`_segment_envelope`) alternate until nothing changes; each
    turn of the shortest paths costs one more sweep, a few on real sets.
    """
    barrier = ~valued & ~work
    stop = valued | barrier
    n = max(z.shape)
    span = float(np.abs(z[valued]).max()) if valued.any() else 0.0
    step = 4.0 * (span + rise * n + 1.0)
    offs = _stretch_offsets(stop, step)
    offs_t = _stretch_offsets(np.ascontiguousarray(stop.T), step)
    work_t = np.ascontiguousarray(work.T)
    v = np.where(valued, z, np.inf)
    for _ in range(max_sweeps):
        before = v[work]
        np.copyto(v, np.minimum(v, _segment_envelope(v, offs, rise, step)), where=work)
        vt = np.ascontiguousarray(v.T)
        np.copyto(vt, np.minimum(vt, _segment_envelope(vt, offs_t, rise, step)), where=work_t)
        v = np.ascontiguousarray(vt.T)
        if not (before - v[work] > 1e-6).any():  # the offsets cost a few ulps per sweep
            break
    out = z.copy()
    out[work] = v[work]
    return out
