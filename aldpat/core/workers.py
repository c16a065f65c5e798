"""Worker processes of a run (``-j N``, a file's chunks in processes): a pool whose workers share
the cores, stop when told, and never outlive the process that started them.

A worker must not outlive its run however the run ends. Told to stop (SIGTERM from the parent, or
from the kernel when the parent dies), a worker running a job stops it so that its writers remove
their temporary files, and a worker between jobs -- idle, or sending a result -- exits at once,
printing nothing (:func:`aldpat.interrupt.install_in_worker`). The kernel's signal needs Linux
(``PR_SET_PDEATHSIG``); everywhere a watchdog thread also looks for the parent twice a second.

Signals are blocked while the pool starts its workers, so that none arrives between the fork
and the worker's own handlers: the worker would otherwise die in multiprocessing's start-up and
print a traceback (``Process ForkProcess-3: ... Interrupted: SIGTERM``).
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import sys
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor

from aldpat import interrupt
from aldpat.core.threads import set_budget, share_for

#: seconds a worker told to stop is given to clean up before the pool's owner kills it
GRACE = 30.0


def _start(threads: int, parent: int) -> None:
    interrupt.install_in_worker(parent)
    set_budget(threads)  # the workers share the cores: each takes its part of them


class WorkerPool:
    """``workers`` processes running submitted calls; :meth:`stop` ends them all."""

    def __init__(self, workers: int):
        method = "spawn" if sys.platform == "darwin" else "fork"
        self._pool = ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context(method),
                                         initializer=_start, initargs=(share_for(workers), os.getpid()))

    def submit_all(self, fn: Callable, jobs: list[tuple]) -> list[Future]:
        """``fn(*job)`` for every job, each a job of :func:`aldpat.interrupt.run_job` (the workers
        start with the first, signals held back)."""
        with interrupt.held_back():
            return [self._pool.submit(interrupt.run_job, fn, *job) for job in jobs]

    def close(self) -> None:
        """Every call done: let the workers go."""
        self._pool.shutdown(wait=True)

    def stop(self) -> None:
        """Cancel what has not started; SIGTERM the workers, which end their calls cleanly, and
        kill those still there after :data:`GRACE` seconds."""
        processes = list(getattr(self._pool, "_processes", {}).values())
        self._pool.shutdown(wait=False, cancel_futures=True)
        for p in processes:
            with contextlib.suppress(Exception):
                p.terminate()
        for p in processes:
            with contextlib.suppress(Exception):
                p.join(timeout=GRACE)
                if p.is_alive():
                    p.kill()
                    p.join(timeout=5)
