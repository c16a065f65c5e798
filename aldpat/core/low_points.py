"""Low outliers found on a grid of lowest heights: small pits below the terrain around them.

Cui (2013) §4.1.1 finds isolated low points (multipath, a pulse through a window) as cells
sinking below a small *closing* of the lowest-point grid. A closing also fills every street,
yard or gap between wagons narrower than its window -- ground far below the roofs around it --
so here a cell is a low outlier only when two tests agree:

1. **a pit**: it lies more than the threshold below every cell holding a point at a distance
   of ``d`` to ``2 d`` cells (a square band around it; a low street or a ditch runs out of the
   band, a pit does not). ``d`` is first 1 -- single low points -- and then ``2 * window``:
   clumps at most that many cells across, the single ones, set aside by then, no longer
   hiding them;
2. **below the terrain's floor**: it also lies below the floor of the terrain within
   ``reach`` metres -- a plane fitted to the heights there, raised by the height above the
   plane that ``FLOOR_RANK`` % of the cells reach (a slope is no relief, and a clump smaller
   than that share does not pull the floor down) -- by more than the threshold or, where the
   heights there spread more (buildings, wagons), by more than that spread (median minus
   floor): the ground seen through a gap among roofs, at the level of the ground elsewhere
   around it, stays terrain.

The test runs on cells about as wide as the points are spaced (the grid's cells, or blocks of
them where the points are sparser: a single low point must stand out among points, not among
empty cells filled from it). The spacing is the whole input's (its points over its extent), so
every part of a file filtered alone takes the blocks the whole file takes.

What it gives is a height limit for each flagged cell of the grid: a point is a low outlier when
it lies below the limit of its cell. So it is the same whether the points are held in memory or
read again in a second pass (:mod:`aldpat.filters.streamed`). The cells it flags are left out of
the grid the filter sees (filled from their neighbours, as an empty cell is); their other
points are classified against the final ground surface, as a cell's points above its lowest are.

Work: a few running minima over the grid, a strip of rows at a time; only the few cells found by
the first test have the terrain around them read.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from aldpat.core.compiled import compiled
from aldpat.core.height_codes import Decode
from aldpat.core.lowest_grid import CellGridSpec, rows_per_block
from aldpat.core.threads import on_threads

#: Share of the terrain's cells (%) below its floor.
FLOOR_RANK = 10
#: The terrain's cells read around a pit: at most this many a side (a lattice stands for more).
SAMPLES = 21
#: Fewer points than this around a cell, and the terrain's floor there is unknown: no outlier.
MIN_AROUND = 4
#: Heights read at once from the terrain around pits (bounds the scratch).
_BATCH_VALUES = 1 << 21


@dataclass(frozen=True)
class LowPoints:
    """The grid cells holding low outliers (flat indices, ascending) and the height below which a
    point of each is one."""

    cells: np.ndarray  # int64 (k,)
    limits: np.ndarray  # float64 (k,)

    def __len__(self) -> int:
        return len(self.cells)

    def below(self, cell_index: np.ndarray, z: np.ndarray) -> np.ndarray:
        """Which points (flat cell ``cell_index``, height ``z``) are low outliers."""
        out = np.zeros(len(z), bool)
        if not len(self.cells) or not len(z):
            return out
        pos = np.searchsorted(self.cells, cell_index)
        pos[pos == len(self.cells)] = 0
        hit = np.flatnonzero(self.cells[pos] == cell_index)
        out[hit] = z[hit] < self.limits[pos[hit]]
        return out


NO_LOW_POINTS = LowPoints(np.zeros(0, np.int64), np.zeros(0))


def point_spacing(points: int, extent: tuple[float, float, float, float] | None) -> float | None:
    """The mean spacing of ``points`` spread over ``extent`` (xmin, ymin, xmax, ymax); ``None``
    when either says nothing."""
    if not points or extent is None:
        return None
    area = (extent[2] - extent[0]) * (extent[3] - extent[1])
    return math.sqrt(area / points) if area > 0 else None


def block_factor(spacing: float | None, cell: float) -> int:
    """Cells a side of the test's blocks: the points' spacing in cells, at least one."""
    if spacing is None or not spacing > cell:
        return 1
    return max(1, round(spacing / cell))


def find_low_points(codes: np.ndarray, decode: Decode, real: np.ndarray,
                    spec: CellGridSpec, *, origin: tuple[float, float] | None = None, spacing: float | None = None,
                    threshold: float, window: int, reach: float) -> LowPoints:
    """The low outliers of the grid ``spec``.

    ``codes`` holds its cells' lowest heights, as float64 heights or as height codes whose order
    is the heights' (the LAS integers: :mod:`aldpat.core.height_codes`); ``decode`` turns codes
    into float64 heights; ``real`` is the mask of cells holding a point (only they are read).
    ``origin``: the grids' alignment (blocks lie on whole multiples of theirs from it);
    ``spacing``: the input's point spacing (:func:`point_spacing`). ``threshold`` in metres;
    ``window``: a pit is at most twice this many cells (or blocks) across; ``reach`` the
    terrain's half size in metres.
    """
    if spec.rows == 0 or spec.cols == 0:
        return NO_LOW_POINTS
    m = block_factor(spacing, spec.cell)
    ox, oy = origin if origin is not None else (0.0, 0.0)
    offset = (round((spec.y0 - oy) / spec.cell) % m, round((spec.x0 - ox) / spec.cell) % m)
    if m == 1:
        test_codes, test_real = codes, real.copy()
    else:
        test_codes, test_real = block_lowest(codes, real, m, offset)
    k = max(1, math.ceil(reach / (spec.cell * m) - 1e-9))
    flagged: list[np.ndarray] = []
    limits: list[np.ndarray] = []
    # the widest band stays within the terrain read around a pit: where the points are sparse,
    # a block holds a whole clump and the single pits' round finds it
    for d in sorted({1, max(1, min(2 * window, k // 2))}):
        cand, band = _pits(test_codes, decode, test_real, d, threshold)
        if not len(cand):
            continue
        z = decode(test_codes.ravel()[cand])
        floor, relief = _floor_and_relief(test_codes, decode, test_real, cand, k)
        limit = np.minimum(band - threshold, floor - np.maximum(threshold, relief))
        keep = z < limit  # NaN (too few points around) compares False
        if keep.any():
            flagged.append(cand[keep])
            limits.append(limit[keep])
            test_real.ravel()[cand[keep]] = False  # no part of the terrain around the next ones
    if not flagged:
        return NO_LOW_POINTS
    cells = np.concatenate(flagged)
    limit = np.concatenate(limits)
    if m > 1:
        cells, limit = _cells_below(codes, decode, real, cells, limit, m, offset, test_codes.shape[1])
    order = np.argsort(cells, kind="stable")
    return LowPoints(cells[order].astype(np.int64), limit[order])


def _top(codes: np.ndarray) -> float:
    """A value above every height code (what a cell without a point holds for a minimum)."""
    return np.inf if np.issubdtype(codes.dtype, np.floating) else np.iinfo(codes.dtype).max


def block_lowest(codes: np.ndarray, real: np.ndarray, m: int, offset: tuple[int, int]
                 ) -> tuple[np.ndarray, np.ndarray]:
    """The lowest code of the cells holding a point in each block of ``m`` x ``m`` cells, and
    which blocks hold one; block (0, 0) starts ``offset`` (rows, cols) cells before the grid."""
    rows, cols = codes.shape
    r_off, c_off = offset
    brows, bcols = -(-(rows + r_off) // m), -(-(cols + c_off) // m)
    top = codes.dtype.type(_top(codes))
    out = np.empty((brows, bcols), codes.dtype)
    step = max(1, rows_per_block(cols, 1 << 20) // m)  # rows of blocks a piece
    # each piece writes its own rows of blocks; a minimum only picks a value: exact in any order
    on_threads(lambda b0: _block_rows_lowest(codes, real, m, r_off, c_off, top, b0, min(brows, b0 + step), out),
               range(0, brows, step))
    return out, out != top


@compiled(nogil=True)
def _block_rows_lowest(codes: np.ndarray, real: np.ndarray, m: int, r_off: int, c_off: int, top: np.generic,
                       b0: int, b1: int, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """Rows ``b0:b1`` of :func:`block_lowest`'s blocks: the lowest code of each block's cells
    holding a point (``top`` where none does; cells beyond the grid hold none), the grid read a
    row at a time."""
    rows, cols = codes.shape
    for bi in range(b0, b1):
        for bj in range(out.shape[1]):
            out[bi, bj] = top
        for i in range(max(0, bi * m - r_off), min(rows, (bi + 1) * m - r_off)):
            for j in range(cols):
                if real[i, j]:
                    bj = (j + c_off) // m
                    out[bi, bj] = min(out[bi, bj], codes[i, j])


def _cells_below(codes: np.ndarray, decode: Decode, real: np.ndarray, blocks: np.ndarray, limit: np.ndarray, m: int,
                 offset: tuple[int, int], bcols: int) -> tuple[np.ndarray, np.ndarray]:
    """The grid cells of flagged ``blocks`` whose lowest point lies below the block's limit."""
    rows, cols = codes.shape
    br, bc = np.divmod(blocks, bcols)
    t = np.arange(m)
    rr = (br * m - offset[0])[:, None, None] + t[None, :, None]
    cc = (bc * m - offset[1])[:, None, None] + t[None, None, :]
    rr, cc = np.broadcast_arrays(rr, cc)
    inside = (rr >= 0) & (rr < rows) & (cc >= 0) & (cc < cols)
    flat = np.clip(rr, 0, rows - 1) * cols + np.clip(cc, 0, cols - 1)
    lim = np.broadcast_to(limit[:, None, None], flat.shape)
    hit = inside & real.ravel()[flat]
    hit &= decode(codes.ravel()[flat]) < lim
    return flat[hit], lim[hit]


def _pits(codes: np.ndarray, decode: Decode, real: np.ndarray, d: int, threshold: float
          ) -> tuple[np.ndarray, np.ndarray]:
    """Cells holding a point that lie more than ``threshold`` below every cell holding a point at
    distance ``d`` to ``2 d`` around them (and there is one): flat indices (ascending) and the
    lowest height of that band."""
    rows, cols = codes.shape
    top = _top(codes)
    step = rows_per_block(cols, 1 << 20)

    def strip(a: int) -> tuple[np.ndarray, np.ndarray]:
        b = min(rows, a + step)
        lo, hi = max(0, a - 2 * d), min(rows, b + 2 * d)
        # a minimum moves values only: on codes it is the minimum of the heights
        band = band_minimum(np.where(real[lo:hi], codes[lo:hi], top), d, top)[a - lo:b - lo]
        flat = np.flatnonzero(real[a:b] & (band != top))
        low = decode(band.ravel()[flat])
        keep = low - decode(codes[a:b].ravel()[flat]) > threshold
        return flat[keep] + a * cols, low[keep]

    found = on_threads(strip, range(0, rows, step))  # in the strips' order: flat indices ascending
    if not found:
        return np.zeros(0, np.int64), np.zeros(0)
    return np.concatenate([f for f, _ in found]), np.concatenate([low for _, low in found])


def band_minimum(z: np.ndarray, d: int, top: float) -> np.ndarray:
    """The lowest value at distance ``d`` to ``2 d`` (Chebyshev) from each cell, ``top`` where
    there is none (beyond the grid's edge there is nothing: ``top``).

    The band is four rectangles, each the minimum of a running minimum: north and south of a
    cell, rows ``d`` to ``2 d`` away over the columns within ``2 d``; east and west, columns
    ``d`` to ``2 d`` away over the rows within ``d - 1``. A minimum only picks values, so the
    result is exact in any order. Memory: three grids of ``z``'s size."""
    z = np.ascontiguousarray(z)
    beyond: np.generic = z.dtype.type(top)
    e = 2 * d
    out = np.empty_like(z)
    near = np.empty_like(z)
    _running_min_rows(z, -e, e, beyond, near, False)  # the columns within 2d
    _running_min_columns(near, -e, -d, beyond, out, False)  # north: rows r-2d..r-d
    _running_min_columns(near, d, e, beyond, out, True)  # south: rows r+d..r+2d
    _running_min_columns(z, 1 - d, d - 1, beyond, near, False)  # the rows within d - 1
    _running_min_rows(near, -e, -d, beyond, out, True)  # west: columns c-2d..c-d
    _running_min_rows(near, d, e, beyond, out, True)  # east: columns c+d..c+2d
    return out


#: Windows at most this many cells long are taken cell by cell, not by prefix and suffix minima
#: (the single pits' band: windows of one and two cells, where those cost more than the reads).
_NARROW = 2


@compiled(nogil=True)
def _narrow_min(z: np.ndarray, first: int, last: int, top: np.generic, out: np.ndarray, lower: bool,
                along_rows: bool) -> None:  # pragma: no cover - compiled
    """:func:`_running_min_rows` (``along_rows``) or :func:`_running_min_columns` for a window of a
    cell or two, whose cells are read as they are, a grid row at a time."""
    rows, cols = z.shape
    n = cols if along_rows else rows
    for i in range(rows):
        for j in range(cols):
            here = j if along_rows else i
            v = top
            for at in range(max(here + first, 0), min(here + last + 1, n)):
                v = min(v, z[i, at] if along_rows else z[at, j])
            out[i, j] = min(out[i, j], v) if lower else v


@compiled(nogil=True)
def _running_min_rows(z: np.ndarray, first: int, last: int, top: np.generic, out: np.ndarray,
                      lower: bool) -> None:  # pragma: no cover - compiled
    """``out[i, j]``: the minimum of ``z[i, j + first:j + last + 1]`` (``first <= last``), ``top``
    beyond the grid's edge; with ``lower``, ``out`` keeps its own value where that is lower. Van
    Herk / Gil-Werman over each row continued with ``top``: the prefix and suffix minima of
    blocks of the window's width."""
    rows, cols = z.shape
    first, last = _within(first, cols), _within(last, cols)
    w = last - first + 1
    if w <= _NARROW:  # a window of a cell or two: its cells read as they are
        _narrow_min(z, first, last, top, out, lower, True)
        return
    size = cols + w  # the row's positions first .. cols - 1 + last, in blocks of w
    g = np.empty(size, z.dtype)
    h = np.empty(size, z.dtype)
    for i in range(rows):
        for start in range(0, size, w):
            stop = min(start + w, size)
            for k in range(start, stop):
                at = k + first
                v = z[i, at] if 0 <= at < cols else top
                g[k] = v if k == start else min(g[k - 1], v)
            for k in range(stop - 1, start - 1, -1):
                at = k + first
                v = z[i, at] if 0 <= at < cols else top
                h[k] = v if k == stop - 1 else min(h[k + 1], v)
        for j in range(cols):
            v = min(h[j], g[j + w - 1])
            out[i, j] = min(out[i, j], v) if lower else v


@compiled(nogil=True)
def _within(offset: int, n: int) -> int:  # pragma: no cover - compiled
    """A window's offset along a line of ``n`` cells clamped to ``-n .. n``: every cell further
    off lies beyond the line from each of its cells, as the clamped offset does, so the window
    reads the same and its scratch follows the grid, not the window."""
    return min(max(offset, -n), n)


#: Columns taken side by side by :func:`_running_min_columns` (its scratch: two runs of them).
COLUMN_GROUP = 64


@compiled(nogil=True)
def _running_min_columns(z: np.ndarray, first: int, last: int, top: np.generic, out: np.ndarray,
                         lower: bool) -> None:  # pragma: no cover - compiled
    """:func:`_running_min_rows` along each column, ``COLUMN_GROUP`` columns side by side (read
    where they lie)."""
    rows, cols = z.shape
    first, last = _within(first, rows), _within(last, rows)
    w = last - first + 1
    if w <= _NARROW:  # as in :func:`_running_min_rows`, a row at a time
        _narrow_min(z, first, last, top, out, lower, False)
        return
    size = rows + w
    g = np.empty((size, COLUMN_GROUP), z.dtype)
    h = np.empty((size, COLUMN_GROUP), z.dtype)
    for c0 in range(0, cols, COLUMN_GROUP):
        width = min(COLUMN_GROUP, cols - c0)
        for start in range(0, size, w):
            stop = min(start + w, size)
            for k in range(start, stop):
                at = k + first
                for j in range(width):
                    v = z[at, c0 + j] if 0 <= at < rows else top
                    g[k, j] = v if k == start else min(g[k - 1, j], v)
            for k in range(stop - 1, start - 1, -1):
                at = k + first
                for j in range(width):
                    v = z[at, c0 + j] if 0 <= at < rows else top
                    h[k, j] = v if k == stop - 1 else min(h[k + 1, j], v)
        for i in range(rows):
            for j in range(width):
                v = min(h[i, j], g[i + w - 1, j])
                out[i, c0 + j] = min(out[i, c0 + j], v) if lower else v


def _floor_and_relief(codes: np.ndarray, decode: Decode, real: np.ndarray, cells: np.ndarray, k: int
                      ) -> tuple[np.ndarray, np.ndarray]:
    """The terrain's floor under each of ``cells`` (flat indices) and the spread of the heights
    around it, from the other cells holding a point within ``k`` cells (a lattice of at most
    ``SAMPLES`` a side): a plane is fitted to their heights, the floor is the plane at the cell
    plus the ``FLOOR_RANK`` % height above the plane, the spread the median height above the
    plane minus that. NaN where fewer than ``MIN_AROUND`` cells hold a point."""
    rows, cols = codes.shape
    flat_codes = codes.ravel()
    flat_real = real.ravel()
    floor = np.full(len(cells), np.nan)
    relief = np.full(len(cells), np.nan)
    stride = max(1, math.ceil((2 * k + 1) / SAMPLES))
    offsets = stride * np.arange(-(k // stride), k // stride + 1)
    dr, dc = (o.ravel() for o in np.meshgrid(offsets, offsets, indexing="ij"))
    fdr, fdc = dr.astype(np.float64), dc.astype(np.float64)
    batch = max(1, _BATCH_VALUES // len(dr))
    for s in range(0, len(cells), batch):
        sel = slice(s, s + batch)
        r, c = np.divmod(cells[sel], cols)
        rr = r[:, None] + dr[None, :]
        cc = c[:, None] + dc[None, :]
        use = (rr >= 0) & (rr < rows) & (cc >= 0) & (cc < cols)
        idx = np.clip(rr, 0, rows - 1) * cols + np.clip(cc, 0, cols - 1)
        use &= flat_real[idx]
        use &= idx != cells[sel][:, None]
        base, above = _plane_residuals(decode(flat_codes[idx]), use, fdc, fdr)
        above[~use] = np.inf
        above.sort(axis=1)
        n = use.sum(axis=1)
        enough = n >= MIN_AROUND
        at_floor = np.take_along_axis(above, ((FLOOR_RANK * n) // 100)[:, None], axis=1)[:, 0]
        at_median = np.take_along_axis(above, (n // 2)[:, None], axis=1)[:, 0]
        with np.errstate(invalid="ignore"):
            floor[sel] = np.where(enough, base + at_floor, np.nan)
            relief[sel] = np.where(enough, at_median - at_floor, np.nan)
    return floor, relief


def _plane_residuals(z: np.ndarray, use: np.ndarray, dc: np.ndarray, dr: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares planes ``z = a + b dc + c dr`` through the heights ``use`` marks, one per row
    of ``z``: ``a`` (the plane at the centre) and every height minus its plane. A row whose points
    do not fix a slope (all on one line) gets no slope across that line."""
    w = use.astype(np.float64)
    n = w.sum(axis=1)
    m = np.empty((len(z), 3, 3))
    m[:, 0, 0] = np.maximum(n, 1.0)
    m[:, 0, 1] = m[:, 1, 0] = w @ dc
    m[:, 0, 2] = m[:, 2, 0] = w @ dr
    m[:, 1, 1] = w @ (dc * dc)
    m[:, 2, 2] = w @ (dr * dr)
    m[:, 1, 2] = m[:, 2, 1] = w @ (dc * dr)
    # a whisker of ridge on the slopes: a degenerate set of points gets a defined plane
    ridge = 1e-9 * (1.0 + m[:, 1, 1] + m[:, 2, 2])
    m[:, 1, 1] += ridge
    m[:, 2, 2] += ridge
    zw = np.where(use, z, 0.0)
    rhs = np.stack([zw.sum(axis=1), zw @ dc, zw @ dr], axis=1)
    coef = np.linalg.solve(m, rhs[:, :, None])[:, :, 0]
    above = z - coef[:, :1] - coef[:, 1:2] * dc[None, :] - coef[:, 2:3] * dr[None, :]
    return coef[:, 0], above
