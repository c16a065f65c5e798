"""How many threads one aldpat process may use: all cores, unless the run has several processes.

A process pool of N workers (``-j N``, chunks in processes, a local Dask cluster) sets
``ALDPAT_THREADS`` to cores / N in each worker, so that the threaded steps (gapm's row and column
passes, the TIN and KD-tree gridding) do not ask for more threads than the machine has: on 2
cores, two processes of two threads each ran slower than one process.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

P = TypeVar("P")
T = TypeVar("T")

ENV = "ALDPAT_THREADS"


def thread_budget() -> int:
    """Threads this process may use (at least 1)."""
    value = os.environ.get(ENV)
    if value:
        try:
            return max(1, int(value))
        except ValueError:
            pass
    return max(1, os.cpu_count() or 1)


def share_for(processes: int) -> int:
    """The budget of each of ``processes`` processes running at once on this machine."""
    return max(1, (os.cpu_count() or 1) // max(1, processes))


def set_budget(threads: int) -> None:
    """Set this process's budget (in a pool worker, before it runs anything)."""
    os.environ[ENV] = str(max(1, threads))


def on_threads(work: Callable[[P], T], pieces: Sequence[P], workers: int | None = None) -> list[T]:
    """``work`` of every piece (a strip, a block of lines, a range of points), on up to
    ``workers`` threads at once (default: the process's budget), the results in the pieces'
    order. The pieces must write disjoint parts of their outputs, and the work must let go of
    the interpreter's lock (numpy, scipy and the ``nogil`` compiled loops do) to gain anything.
    With one piece or one thread the work runs here, piece after piece."""
    count = max(1, min(thread_budget() if workers is None else workers, len(pieces)))
    if count == 1:
        return [work(piece) for piece in pieces]
    with ThreadPoolExecutor(count) as pool:
        return list(pool.map(work, pieces))
