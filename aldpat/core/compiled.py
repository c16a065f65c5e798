"""Compiled loops: numba's ``njit``, cached on disk where a cache can be written.

The few loops over points or cells that numpy cannot vectorise without rebuilding or copying
whole grids (the adaptive TIN, the slope filter's search, local planes) are compiled by numba.
Compiling takes seconds, so the machine code is cached beside the module or, where the package
is installed read-only, in the user's cache directory; where neither can be written (a locked
down cluster node without a home directory) numba refuses to cache when the function is
defined, and it is then compiled in each process instead of failing the import.
"""

from __future__ import annotations

import functools
import logging
import threading
from collections.abc import Callable
from typing import Any

from numba import njit

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
