"""Grey-scale erosion, dilation, opening and closing of elevation grids.

Flat windows of half-size ``k`` cells (full size ``2k + 1``), as the dissertation counts them
(ch. 5-6: window sizes are half windows; the manual's appendix PM filter uses line or 2-D
windows). Window shapes:

``line``
    ``2k + 1`` cells along one axis: ``axis=1`` runs along x (row filtering), ``axis=0``
    along y (column filtering).
``square``
    ``(2k + 1) x (2k + 1)`` cells (manual task 8 "Morph 2D Filter").
``disk``
    cells whose centre lies within ``k`` cells of the window centre, ``i*i + j*j <= k*k``
    (manual task 8 "Morph Circle Filter").

Every operation uses scipy.ndimage running minima/maxima; a disk is the union of a few
centred rectangles, so its erosion is the minimum of separable rectangle erosions
(O(cells x rectangles) instead of O(cells x k^2)). Borders use ``mode="nearest"``, which
equals clipping the window to the grid: a border cell is compared with the cells that exist.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from aldpat._lazy import lazy_import

ndimage = lazy_import("scipy.ndimage")

WINDOWS = ("line", "square", "disk")


@functools.lru_cache(maxsize=256)
def disk_rectangles(k: int) -> tuple[tuple[int, int], ...]:
    """Centred rectangles ``(half_rows, half_cols)`` whose union is the disk of radius ``k``.

    For every row offset ``dy`` the disk spans ``|dx| <= floor(sqrt(k^2 - dy^2))``; that half
    width only shrinks as ``|dy|`` grows, so one rectangle per distinct half width covers it.
    """
    if k < 0:
        raise ValueError(f"half window must be >= 0, got {k}")
    widths = [math.isqrt(k * k - dy * dy) for dy in range(k + 1)]
    rects = []
    for dy, w in enumerate(widths):
        if dy == k or widths[dy + 1] != w:
            rects.append((dy, w))
    return tuple(rects)


def disk_footprint(k: int) -> np.ndarray:
    """Boolean ``(2k+1, 2k+1)`` footprint of the disk window (for reference and tests)."""
    j, i = np.mgrid[-k:k + 1, -k:k + 1]
    return i * i + j * j <= k * k


def within(k: int, shape: tuple[int, ...], window: str = "square") -> int:
    """The half window ``k`` no wider than what sees the whole grid from any cell: wider is the
    same window (a running min or max repeats the edge cells beyond the grid, or ignores what
    lies beyond it) and would cost time and memory in proportion to its width -- a half window
    of 2**31 cells is a parameter's value, not a grid's."""
    reach = max(shape, default=0)
    if window == "disk":
        reach = math.isqrt(sum(n * n for n in shape)) + 1  # the diagonal
    return min(int(k), reach)


def _check(z: np.ndarray, k: int, window: str, axis: int) -> np.ndarray:
    z = np.asarray(z)
    if z.dtype not in (np.float32, np.float64, np.int32):
        z = z.astype(np.float64)
    if z.ndim != 2:
        raise ValueError(f"expected a 2-D grid, got {z.ndim} dimensions")
    if int(k) != k or k < 0:
        raise ValueError(f"half window must be a whole number >= 0, got {k!r}")
    if window not in WINDOWS:
        raise ValueError(f"window must be one of {', '.join(WINDOWS)}, got {window!r}")
    if window == "line" and axis not in (0, 1):
        raise ValueError(f"axis must be 0 (along y) or 1 (along x), got {axis!r}")
    return z


def _running(z: np.ndarray, k: int, window: str, axis: int, maximum: bool,
             out: np.ndarray | None = None) -> np.ndarray:
    """Running max/min into ``out`` (a new array when None; must not be ``z``)."""
    if out is None:
        out = np.empty_like(z)
    if k == 0 or z.size == 0:
        out[...] = z
        return out
    k = within(k, z.shape, window)
    filt1 = ndimage.maximum_filter1d if maximum else ndimage.minimum_filter1d
    filt2 = ndimage.maximum_filter if maximum else ndimage.minimum_filter
    if window == "line":
        filt1(z, 2 * k + 1, axis=axis, mode="nearest", output=out)
        return out
    if window == "square":
        filt2(z, size=(2 * k + 1, 2 * k + 1), mode="nearest", output=out)
        return out
    pick = np.maximum if maximum else np.minimum
    part = None
    for i, (hr, hc) in enumerate(disk_rectangles(int(k))):
        if i == 0:
            filt2(z, size=(2 * hr + 1, 2 * hc + 1), mode="nearest", output=out)
            continue
        part = filt2(z, size=(2 * hr + 1, 2 * hc + 1), mode="nearest", output=part)
        pick(out, part, out=out)
    return out


def _out(z: np.ndarray, out: np.ndarray | None) -> np.ndarray | None:
    if out is not None and (out.shape != z.shape or out.dtype != z.dtype or np.shares_memory(out, z)):
        raise ValueError("out must be a separate array of the grid's shape and dtype")
    return out


def erosion(z: np.ndarray, k: int, *, window: str = "square", axis: int = 1,
            out: np.ndarray | None = None) -> np.ndarray:
    """Running minimum over the window of half size ``k`` (``k = 0``: a copy).

    ``out``: an array of the same shape and dtype to write into (saves an allocation per call
    on large grids); it must not share memory with ``z``. float32, float64 and int32 grids (height
    codes) keep their dtype; other dtypes are computed as float64.
    """
    z = _check(z, k, window, axis)
    return _running(z, int(k), window, axis, False, _out(z, out))


def dilation(z: np.ndarray, k: int, *, window: str = "square", axis: int = 1,
             out: np.ndarray | None = None) -> np.ndarray:
    """Running maximum over the window of half size ``k`` (``out`` as for :func:`erosion`)."""
    z = _check(z, k, window, axis)
    return _running(z, int(k), window, axis, True, _out(z, out))


def opening(z: np.ndarray, k: int, *, window: str = "square", axis: int = 1,
            out: np.ndarray | None = None, work: np.ndarray | None = None) -> np.ndarray:
    """Erosion then dilation: removes what is higher than its surroundings and narrower than
    the window (manual appendix, PM filter; dissertation §4.1.1 for high outliers).

    ``out`` receives the result and ``work`` the intermediate erosion (both optional, of the
    grid's dtype, separate from ``z`` and from each other).
    """
    z = _check(z, k, window, axis)
    ero = _running(z, int(k), window, axis, False, _out(z, work))
    return _running(ero, int(k), window, axis, True, _out(ero, out) if out is not None else None)


def closing(z: np.ndarray, k: int, *, window: str = "square", axis: int = 1) -> np.ndarray:
    """Dilation then erosion: fills what is lower than its surroundings and narrower than the
    window (dissertation §4.1.1, extremely low outliers)."""
    z = _check(z, k, window, axis)
    return _running(_running(z, int(k), window, axis, True), int(k), window, axis, False)


def opening_along_trend(z: np.ndarray, k: int) -> np.ndarray:
    """Opening of every row of ``z`` (float64 heights) with a line window of half size ``k``,
    each row continued ``k`` cells past both of its ends along the trend of its lower envelope.

    At the end of a row the window reaches past the data. Repeating the end cell there (the
    ``nearest`` border of :func:`opening`) makes a slope rising to the edge of the data look like
    a bump: its last ``k`` cells are opened down to the height ``k`` cells in. Here each end is
    continued along the line through the lowest of the row's last ``k`` cells and the lowest of
    the ``k`` before them: a slope rising to the edge goes on rising, while a roof at the edge
    narrower than ``k`` is continued at the height of the ground beside it and opened away as
    before. Rows shorter than four cells, or ``k`` 0, are
    opened as :func:`opening` opens them. Only cells within ``2 k`` of an end can differ from
    :func:`opening`, and only there can a value be one of the continuation's
    (:func:`trend_opening_at_ends` gives those cells alone).
    """
    z = np.asarray(_check(z, k, "line", 1), dtype=np.float64)
    n = z.shape[1]
    k = int(k)
    if k == 0 or n < 4:
        return opening(z, k, window="line", axis=1)
    left, right = _trend_continuations(z, k)
    padded = np.concatenate([left, z, right], axis=1)
    return np.ascontiguousarray(opening(padded, k, window="line", axis=1)[:, k:k + n])


def trend_opening_at_ends(z: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The first and the last ``min(2 k, n)`` columns of :func:`opening_along_trend` of ``z``
    (``n`` columns; ``k`` >= 1, ``n`` >= 4), the same values, from the ``4 k`` cells at each end.

    Elsewhere the opening along the trend is the plain :func:`opening`: an opening of half
    window ``k`` reads ``2 k`` cells either side of a cell, so only the cells within ``2 k`` of
    an end see the continuation, and they read no further in than ``4 k`` cells. A filter that
    has the plain opening already (on height codes, say) opens these end pieces alone instead of
    a second, padded copy of every row.
    """
    z = np.asarray(_check(z, k, "line", 1), dtype=np.float64)
    n = z.shape[1]
    k = int(k)
    reach = min(2 * k, n)
    if n <= 4 * k:  # the end pieces would cover the row: open it whole
        whole = opening_along_trend(z, k)
        return whole[:, :reach], whole[:, n - reach:]
    left, right = _trend_continuations(z, k)
    inner = 4 * k
    first = opening(np.concatenate([left, z[:, :inner]], axis=1), k, window="line", axis=1)[:, k:k + reach]
    last = opening(np.concatenate([z[:, n - inner:], right], axis=1), k, window="line", axis=1)
    return first, last[:, inner - reach:inner]


def _trend_continuations(z: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` cells continuing every row of ``z`` past its first and its last cell along the
    line through the lowest of its ``k`` end cells and the lowest of the ``k`` before them
    (:func:`opening_along_trend`); ``z`` float64 of at least four columns."""
    rows, n = z.shape
    span = min(k, n // 2)
    cols = np.arange(n)
    line = np.arange(rows)

    def lowest(first: int, last: int) -> tuple[np.ndarray, np.ndarray]:
        at = first + z[:, first:last].argmin(axis=1)
        return z[line, at], cols[at]

    def continued(outer: tuple[np.ndarray, np.ndarray], inner: tuple[np.ndarray, np.ndarray], edge: int,
                  outward: np.ndarray) -> np.ndarray:
        (z_out, c_out), (z_in, c_in) = outer, inner
        slope = (z_out - z_in) / np.abs(c_out - c_in)  # per cell, outwards
        at_edge = z_out + slope * np.abs(edge - c_out)
        return at_edge[:, None] + slope[:, None] * outward[None, :]

    steps = np.arange(1, k + 1)
    right = continued(lowest(n - span, n), lowest(n - 2 * span, n - span), n - 1, steps)
    left = continued(lowest(0, span), lowest(span, 2 * span), 0, steps[::-1])
    return left, right
