"""Hand freed memory back to the system between the large steps of a run.

The grid steps allocate scratch a strip or a block at a time, on several threads. glibc gives
each thread its own arena and keeps what they free there and in the heap below any block still
in use, so the resident size a run reports -- and the memory the machine has left -- counts
scratch that is long dead: on 1 m cells over 10 M points, about 100 MB after gapm's passes
even once trimmed. :func:`one_arena` makes the threads share one arena (their allocations are
a few large blocks per strip, so they hardly contend: the run was faster, not slower) and
:func:`release_free_memory` returns its free pages. Elsewhere (another C library, another
system) both do nothing.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools

#: glibc's ``mallopt`` parameter for the largest number of arenas (malloc.h).
_M_ARENA_MAX = -8


@functools.cache
def _libc() -> ctypes.CDLL | None:
    name = ctypes.util.find_library("c")
    if not name:
        return None
    try:
        libc = ctypes.CDLL(name)
        libc.malloc_trim, libc.mallopt  # noqa: B018  (glibc only)
    except (OSError, AttributeError):
        return None
    return libc


def release_free_memory() -> None:
    """Return the memory freed so far to the system (glibc ``malloc_trim(0)``)."""
    libc = _libc()
    if libc is not None:
        libc.malloc_trim(0)


@functools.cache
def one_arena() -> None:
    """Let every thread allocate from the one main arena (glibc ``mallopt(M_ARENA_MAX, 1)``);
    threads that have allocated already keep their arenas, so call it before starting any."""
    libc = _libc()
    if libc is not None:
        libc.mallopt(_M_ARENA_MAX, 1)
