"""The progressive opening every progressive morphological filter runs (one engine).

ALDPAT 1.0 user manual (2007), Appendix "Progressive Morphological (PM) Filter" (Zhang et al.
2003); Cui (2013) §5.1 and §5.2.2 lines 3-18: at every window the surface is opened, a cell
whose height above the opened surface exceeds the window's threshold is removed (marked with
the window), and the opened surface goes on to the next window. ``pm``, ``pm2d``, ``pmcircle``,
``cluster-pm`` and ``multipass`` all run this loop; what differs is the window shape and
direction of each opening (``passes``), whether cells are set back after an opening (the cluster
recovery of ``cluster-pm``, a :data:`Recovery`), the cells never marked (``skip``) and the
precision of the surface.

Precision: ``pm``, ``pm2d`` and ``pmcircle`` open float32 surfaces (half the memory and time on
large grids; elevations to 0.1 mm below 1000 m), ``cluster-pm`` and ``multipass`` float64, as
each was published and tested. The two can disagree on a cell whose height above the opened
surface equals the threshold to within float32 rounding; the precision is therefore an argument
of the one loop, not a second implementation.

Memory: one grid-sized surface of the chosen precision and the int16 (:func:`mark_dtype`) mark
matrix, whatever the number of windows, when every opening is along a line without a recovery: the
lines are independent, so each is opened, compared and replaced in place a block of lines at a
time. Square and disk windows, and a recovery (which needs the surface before the opening beside
the one after it), take two more grid-sized surfaces (opened, work). ``z`` is not changed unless
given to the run (``in_place``).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence

import numpy as np

from aldpat.core import morphology
from aldpat.core.height_codes import Decode
from aldpat.core.lowest_grid import rows_per_block
from aldpat.core.threads import on_threads

log = logging.getLogger(__name__)

#: ``recover(before, candidates, removed, axis)`` -> cells to set back to ground after one
#: opening: ``before`` is the surface the opening was applied to, ``candidates`` the cells that
#: could be removed, ``removed`` those it removed, ``axis`` the pass's axis.
Recovery = Callable[[np.ndarray, np.ndarray, np.ndarray, int], np.ndarray]


def mark_dtype(largest: int) -> np.dtype:
    """The smallest integer type a mark matrix needs: int16 (half the memory of int32 on grids of
    tens of millions of cells) unless a window, or the marks the driver adds (-7777, 9000),
    would not fit."""
    return np.dtype(np.int16 if max(int(largest), 9000) <= np.iinfo(np.int16).max else np.int32)


def progressive_opening(z: np.ndarray, windows: Sequence[int], thresholds: Sequence[float],
                        passes: Sequence[tuple[str, int]], *, dtype: type = np.float32,
                        skip: np.ndarray | None = None,
                        recover: Callable[[int], Recovery | None] | None = None,
                        decode: Decode | None = None,
                        in_place: bool = False) -> np.ndarray:
    """Mark matrix (:func:`mark_dtype`: 0 ground, else the half window that removed the cell) of
    the progressive opening.

    ``passes`` lists the ``(window shape, axis)`` openings applied in turn at every half window
    ``k`` of ``windows`` (``"line"`` along ``axis`` 1 = rows / x or 0 = columns / y, ``"square"``,
    ``"disk"``); each compares the surface before and after itself. A cell keeps the first
    window that removed it. ``skip`` cells only support the openings, never being marked.
    ``recover(k)`` gives the recovery applied after each opening at window ``k`` (or None).
    ``decode``: ``z`` holds height codes (:mod:`aldpat.core.height_codes`), turned into the
    surface's heights a block of rows at a time (no float64 copy of the grid). ``in_place``: ``z``
    (heights of ``dtype``, C-ordered) is the run's to open in place instead of a copy.
    """
    given = in_place and decode is None and isinstance(z, np.ndarray) and z.dtype == dtype and z.flags.c_contiguous
    if dtype == np.float64 and all(w == "line" for w, _ in passes) and \
            (recover is None or all(recover(k) is None for k in windows)):
        compiled = _compiled_lines(z, windows, thresholds, [axis for _, axis in passes], skip, decode, given)
        if compiled is not None:
            return compiled
    surface: np.ndarray = z if given else heights_grid(z, dtype, decode)
    opened: np.ndarray | None = None  # whole-grid scratch, only for the openings that need it
    work: np.ndarray | None = None
    marks = np.zeros(surface.shape, mark_dtype(max(windows, default=0)))
    candidates = np.ones(surface.shape, bool) if skip is None else ~skip  # marks == 0, kept current
    removed = None
    for k, dh in zip(windows, thresholds, strict=False):
        recovery = recover(k) if recover is not None else None
        for window, axis in passes:
            if window == "line" and recovery is None:
                _line_pass(surface, k, axis, dtype(dh), candidates, marks)
                continue
            if opened is None or work is None or removed is None:
                opened, work = np.empty_like(surface), np.empty_like(surface)
                removed = np.empty(surface.shape, bool)
            morphology.opening(surface, k, window=window, axis=axis, out=opened, work=work)
            np.subtract(surface, opened, out=work)
            np.greater(work, dtype(dh), out=removed)
            removed &= candidates
            if recovery is not None:
                removed &= ~recovery(surface, candidates, removed, axis)
            marks[removed] = k
            candidates &= ~removed
            surface, opened = opened, surface
        log.debug("window %d (threshold %.3g): %d cells removed so far", k, dh, int((marks > 0).sum()))
    return marks


#: Lines a thread's block of the compiled line passes holds (:func:`_compiled_lines`).
BLOCK_LINES = 32


def _compiled_lines(z: np.ndarray, windows: Sequence[int], thresholds: Sequence[float], axes: Sequence[int],
                    skip: np.ndarray | None, decode: Decode | None, given: bool) -> np.ndarray | None:
    """The progressive opening along lines in float64 by gapm's compiled pass over blocks of lines
    (:func:`aldpat.core.line_pass.filter_lines`: open, rise, mark, in place, on the process's
    threads), or None where it does not apply -- codes of another decoding than a scale and an
    offset, heights holding NaN.

    The same marks as the numpy loop to the bit: an opening only picks values, so opening the
    codes and decoding them gives the opening of the heights; the rise is the same subtraction
    of the same float64 values and the threshold the same comparison. A cell of ``skip`` is held
    marked (-1) while the passes run, so that no pass marks it, and is 0 again in the result."""
    from aldpat.core import line_pass
    from aldpat.core.rise import scale_and_offset

    linear = scale_and_offset(decode)
    if decode is not None and linear is None:
        return None
    if decode is None and (z.dtype != np.float64 or np.isnan(z).any()):
        return None
    grid = z if given and decode is None else np.array(z, copy=True)  # the caller's grid is not opened
    marks = np.zeros(grid.shape, mark_dtype(max(windows, default=0)))
    if skip is not None:
        marks[skip] = -1
    rows, cols = grid.shape
    for k, dh in zip(windows, thresholds, strict=False):
        for axis in axes:
            lines = rows if axis == 1 else cols

            def one(a: int, k: int = k, dh: float = float(dh), axis: int = axis, lines: int = lines) -> None:
                line_pass.filter_lines(grid, marks, a, min(a + BLOCK_LINES, lines), axis, k, k, dh, math.inf, None,
                                       False, linear)

            on_threads(one, range(0, lines, BLOCK_LINES))
    if skip is not None:
        marks[skip] = 0
    return marks


def _line_pass(surface: np.ndarray, k: int, axis: int, dh: np.floating, candidates: np.ndarray,
               marks: np.ndarray) -> None:
    """One opening along ``axis`` of the progressive loop, in place: the cells of ``candidates``
    standing more than ``dh`` above the opened surface are marked ``k`` and leave
    ``candidates``, and ``surface`` becomes the opened one. The lines are independent, so a block
    of them at a time gives the same values as the whole grid at once, and blocks run on threads
    (scipy's running min and max release the GIL)."""
    rows, cols = surface.shape
    lines = rows if axis == 1 else cols
    along = cols if axis == 1 else rows
    step = max(1, (1 << 20) // max(1, along))

    def one(a: int) -> None:
        part = (slice(a, a + step), slice(None)) if axis == 1 else (slice(None), slice(a, a + step))
        block = surface[part]
        opened = np.empty(block.shape, surface.dtype)
        work = np.empty(block.shape, surface.dtype)
        morphology.opening(block, k, window="line", axis=axis, out=opened, work=work)
        np.subtract(block, opened, out=work)
        removed = work > dh
        removed &= candidates[part]
        marks[part][removed] = k
        candidates[part] &= ~removed
        block[...] = opened

    on_threads(one, range(0, lines, step))


def heights_grid(z: np.ndarray, dtype: type, decode: Decode | None) -> np.ndarray:
    """A copy of the heights ``z`` (or of the heights of codes ``z``) in ``dtype``, decoded a block
    of rows at a time (no grid-sized temporary)."""
    if decode is None:
        return np.array(z, dtype=dtype, copy=True)
    surface: np.ndarray = np.empty(z.shape, dtype)
    step = rows_per_block(z.shape[1])
    for a in range(0, z.shape[0], step):
        surface[a:a + step] = decode(z[a:a + step])
    return surface
