"""Priority boundary interpolation of connected empty cells.

``PQBoundInterp`` and ``findEmpConn`` of the GAPM dissertation (``seeds/000_*.txt``, ch. 4
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
"""

from __future__ import annotations

import logging

import numpy as np
from scipy import ndimage

log = logging.getLogger(__name__)

_STRUCTURE = {4: ndimage.generate_binary_structure(2, 1), 8: np.ones((3, 3), dtype=bool)}


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
    max_steps: int = 100_000,
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
        (each empty cell gets ``min over boundary cells b of z(b) + rise * d(b, cell)``,
        ``d`` the chamfer distance through the set).
    max_steps : cap on the propagation sweeps when ``rise > 0``.

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
        filled = _rising_flood(z, valued, work, offsets, float(rise), max_steps)
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


def _rising_flood(z, valued, work, offsets, rise, max_steps) -> np.ndarray:
    """``min_b z(b) + rise * d(b, cell)`` over valued cells ``b``, for the ``work`` cells.

    Min-plus propagation by whole-grid sweeps over the neighbour offsets (each sweep is a
    vectorized slice operation); stops when nothing changes.
    """
    v = np.where(valued, z, np.inf)
    v[~valued & ~work] = np.inf
    rows, cols = v.shape
    steps = [(dr, dc, rise * float(np.hypot(dr, dc))) for dr, dc in offsets]
    for _ in range(max_steps):
        changed = False
        for dr, dc, cost in steps:
            dst = (slice(max(0, -dr), rows - max(0, dr)), slice(max(0, -dc), cols - max(0, dc)))
            src = (slice(max(0, dr), rows - max(0, -dr)), slice(max(0, dc), cols - max(0, -dc)))
            cand = v[src] + cost
            better = work[dst] & (cand < v[dst])
            if better.any():
                v[dst][better] = cand[better]
                changed = True
        if not changed:
            break
    return np.where(work, v, z)
