"""Compiled loops: numba's ``njit``, cached on disk where a cache can be written.

The few loops over points or cells that numpy cannot vectorise without rebuilding or copying
whole grids (the adaptive TIN, the slope filter's search, local planes) are compiled by numba.
Compiling takes seconds, so the machine code is cached beside the module or, where the package
is installed read-only, in the user's cache directory; where neither can be written (a locked
down cluster node without a home directory) numba refuses to cache when the function is
defined, and it is then compiled in each process instead of failing the import.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from numba import njit


def compiled(**options: Any) -> Callable[[Callable], Callable]:
    """``@compiled(...)``: ``numba.njit(cache=True, ...)``, or uncached where no cache can be kept."""

    def decorate(fn: Callable) -> Callable:
        try:
            return njit(cache=True, **options)(fn)
        except RuntimeError:  # "cannot cache function ...: no locator available"
            return njit(**options)(fn)

    return decorate
