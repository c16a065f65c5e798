"""Compiled loops: numba's ``njit``, cached on disk where a cache can be written.

The few loops over points or cells that numpy cannot vectorise without rebuilding or copying
whole grids (the adaptive TIN, the slope filter's search, local planes) are compiled by numba.
Compiling takes seconds, so the machine code is cached beside the module or, where the package
is installed read-only, in the user's cache directory; where neither can be written (a locked
down cluster node without a home directory) numba refuses to cache when the function is
defined, and it is then compiled in each process instead of failing the import.

The compiler itself takes a fraction of a second to load in each process: a run starts loading it
on a thread while it reads its input (:func:`load_compiler_in_background`). And a loop over a large
grid that reads its cells out of order waits on memory for each: :func:`prefetch` lets it ask for
the cells it will read next (a hint, which changes no result).
"""

from __future__ import annotations

import functools
import logging
import threading
from collections.abc import Callable
from typing import Any

import numpy as np
from llvmlite import ir
from numba import literal_unroll, njit, types
from numba.core import cgutils
from numba.extending import intrinsic

log = logging.getLogger(__name__)


def compiled(**options: Any) -> Callable[[Callable], Callable]:
    """``@compiled(...)``: ``numba.njit(cache=True, ...)``, or uncached where no cache can be kept."""

    def decorate(fn: Callable) -> Callable:
        try:
            return njit(cache=True, **options)(fn)
        except RuntimeError:  # "cannot cache function ...: no locator available"
            return njit(**options)(fn)

    return decorate


@functools.cache
def load_compiler_in_background() -> None:
    """Start loading numba's compiler (its typing and target contexts: about 0.3 s of imports and
    tables, the first compiled call's) on a thread of its own, once a process, so that it overlaps
    work that needs none, such as the first reading of a file. A compiled call meanwhile waits on
    numba's own lock for it to finish."""
    threading.Thread(target=_first_call, name="aldpat-load-compiler", daemon=True).start()


def _first_call() -> None:
    try:
        _nothing(0)
    except Exception as exc:  # noqa: BLE001 - the run's own compiled calls meet the fault and say so
        log.debug("loading the compiler ahead of the run failed: %s", exc)


@compiled(nogil=True)
def _nothing(k: int) -> int:  # pragma: no cover - compiled
    return k


#: Points whose cells are asked for ahead at a time (:func:`prefetch_cells`): the next block's
#: while this one is worked on. Fewer, and the loads have not arrived when they are needed; many
#: more, and the first of them are evicted again.
PREFETCH_BLOCK = 512


@intrinsic
def _prefetch(typingctx: Any, grid: Any, row: Any, col: Any) -> Any:
    """The compiled form of :func:`prefetch`: LLVM's ``llvm.prefetch`` of the element's address."""
    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        grid_type = signature.args[0]
        array = context.make_array(grid_type)(context, builder, args[0])
        item = cgutils.get_item_pointer(context, builder, grid_type, array, [args[1], args[2]])
        address = builder.bitcast(item, ir.IntType(8).as_pointer())
        hint = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(ir.VoidType(), [address.type, *([ir.IntType(32)] * 3)]),
            "llvm.prefetch.p0i8")
        read, keep, data_cache = (ir.Constant(ir.IntType(32), v) for v in (0, 3, 1))
        builder.call(hint, [address, read, keep, data_cache])
        return context.get_dummy_value()

    return types.void(grid, types.intp, types.intp), codegen


#: ``prefetch(grid, row, col)`` in a compiled loop: ask the processor to bring the cache line of
#: ``grid[row, col]`` (a 2-D array, any strides) in, for reading, and go on without waiting. A
#: hint: it never faults, changes nothing and gives the same results.
prefetch: Callable[[np.ndarray, int, int], None] = _prefetch  # type: ignore[assignment]  # numba's typing context first


@compiled(nogil=True)
def prefetch_cells(grids: Any, x: np.ndarray, y: np.ndarray, first: int, stop: int, x0: float, y0: float,
                   cell: float) -> None:  # pragma: no cover - compiled
    """Ask for the cells points ``first:stop`` will read of each of ``grids`` (a tuple of 2-D
    arrays of one shape, lower-left corner ``x0, y0``): the two rows of cell centres around each
    point, at its column.

    A per-point loop over a large grid waits on memory: consecutive points of a flight line lie
    rows apart, so each point's cells are a cache miss on every grid (at 1 m cells over 10 M
    points, 60 % of a surface test's time). Asked for a block ahead
    (:data:`PREFETCH_BLOCK`), the loads of many points are under way at once."""
    rows, cols = grids[0].shape
    for k in range(first, stop):
        col = int(min(max((x[k] - x0) / cell - 0.5, 0.0), cols - 1.0))
        row = int(min(max((y[k] - y0) / cell - 0.5, 0.0), rows - 1.0))
        below = min(row + 1, rows - 1)
        for grid in literal_unroll(grids):
            prefetch(grid, row, col)
            prefetch(grid, below, col)


@compiled(nogil=True)
def prefetch_run(grid: np.ndarray, row: int, first: int, stop: int) -> None:  # pragma: no cover - compiled
    """Ask for the cells ``grid[row, first:stop]`` (a 2-D array, ``row`` inside it), a cache line
    at a time: a loop taking a block of columns a grid row at a time reads rows farther apart than
    the processor's own prefetching looks, and asks for a row some rows ahead of the one it reads."""
    if stop <= first:
        return
    line = max(1, 64 // grid.itemsize)
    for c in range(first, stop, line):
        prefetch(grid, row, c)
    prefetch(grid, row, stop - 1)
