"""How many threads one aldpat process may use: all cores, unless the run has several processes.

A process pool of N workers (``-j N``, chunks in processes, a local Dask cluster) sets
``ALDPAT_THREADS`` to cores / N in each worker, so that the threaded steps (gapm's row and column
passes, the TIN and KD-tree gridding) do not ask for more threads than the machine has: on 2
cores, two processes of two threads each ran slower than one process.
"""

from __future__ import annotations

import os

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
