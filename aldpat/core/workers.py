"""Worker processes of a run (``-j N``, a file's chunks in processes): a pool whose workers share
the cores, stop when told, and never outlive the process that started them.

Workers are forked from a fork server (``forkserver``; ``spawn`` on macOS and Windows), never
from the running process itself. The running process has threads by then -- lazrs decompresses
a LAZ file on a thread pool, and a worksheet reads or writes LAZ in the parent before a ``-j 2``
job -- and a process forked from a threaded one inherits locks held by threads it does not have:
its first LAZ read waited for ever. The server is a fresh process that has read nothing; it
imports aldpat once, so workers start without importing it again. As with ``spawn``, a script
that starts a pool (a task run from Python with ``jobs=2``) needs the ``if __name__ ==
"__main__":`` guard, since each worker imports the script's main module.

A worker must not outlive its run however the run ends. Told to stop (SIGTERM from the parent, or
from the kernel when its own parent, the fork server, ends -- which it does as soon as the run's
process is gone), a worker running a job stops it so that its writers remove their temporary
files, and a worker between jobs -- idle, or sending a result -- exits at once, printing nothing
(:func:`aldpat.interrupt.install_in_worker`). The kernel's signal needs Linux
(``PR_SET_PDEATHSIG``); everywhere a watchdog thread also looks for the parent and the run's
process twice a second.
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import os
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor

from aldpat import interrupt
from aldpat.core.resources import MEMORY_SHARE, available_memory, size_text
from aldpat.core.threads import set_budget, share_for

log = logging.getLogger(__name__)

#: seconds a worker told to stop is given to clean up before the pool's owner kills it
GRACE = 30.0


def _start(threads: int, run: int, level: int, formatter: logging.Formatter | None) -> None:
    interrupt.install_in_worker(run)
    set_budget(threads)  # the workers share the cores: each takes its part of them
    _say_as(level, formatter)


def _messages() -> tuple[int, logging.Formatter | None]:
    """The level (``-q``, ``-v``) and the form (``aldpat: ...``, one line each) of this process's
    messages, for its workers: without them a worker's warnings went to Python's last-resort
    handler, bare, printed under ``-q``, and a file name holding a terminal escape reached the
    terminal as it was."""
    logger = logging.getLogger("aldpat")
    return logger.getEffectiveLevel(), next((h.formatter for h in logger.handlers if h.formatter), None)


def _say_as(level: int, formatter: logging.Formatter | None) -> None:
    """This worker's messages on stderr at ``level`` in ``formatter``'s form, as its parent's."""
    import sys

    handler = logging.StreamHandler(sys.stderr)
    if formatter is not None:
        handler.setFormatter(formatter)
    logger = logging.getLogger("aldpat")
    logger.handlers[:] = [handler]
    logger.setLevel(level)
    logger.propagate = False


#: imported once by the fork server, so that its workers start with them loaded
PRELOADED = ["aldpat.interrupt", "aldpat.jobs.execute", "aldpat.tasks"]


def start_method() -> multiprocessing.context.BaseContext:
    """The fork server where there is one (Linux), else ``spawn``: never a fork of this process."""
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(PRELOADED)
    return context


#: what a worker process holds before its data: the interpreter, numpy, pandas, numba and its
#: compiled kernels (about 190 MB measured on an idle worker)
WORKER_MEMORY = 256 << 20


#: most worker processes a run starts (``-j``, ``local:N``): four per core, sixteen at least (each
#: a whole Python process; more only queue for the cores and fill the memory)
MOST_WORKERS = max(16, 4 * (os.cpu_count() or 1))


def affordable_workers(wanted: int) -> int:
    """``wanted`` worker processes, or :data:`MOST_WORKERS`, or as many as the memory available
    holds at :data:`WORKER_MEMORY` each (within :data:`~aldpat.core.resources.MEMORY_SHARE` of
    it), whichever is fewest, at least one: ``-j 1024`` from a worksheet over a thousand tiles
    started a thousand processes, about 190 GB before any data."""
    room = int(available_memory() * MEMORY_SHARE) // WORKER_MEMORY
    return max(1, min(wanted, MOST_WORKERS, room))


def workers_to_start(wanted: int, asked: str) -> int:
    """:func:`affordable_workers` of ``wanted``, with a warning when that is fewer, saying why;
    ``asked``: what asked for them (``-j 1024``)."""
    affordable = affordable_workers(wanted)
    if affordable < wanted:
        log.warning(f"{asked}: {affordable} worker processes: at most {MOST_WORKERS} here (four per core, "
                    f"sixteen at least), and as many as the memory available holds (about "
                    f"{size_text(WORKER_MEMORY)} a process before its data)")
    return affordable


class WorkerPool:
    """``workers`` processes running submitted calls; :meth:`stop` ends them all."""

    def __init__(self, workers: int):
        self._pool = ProcessPoolExecutor(max_workers=workers, mp_context=start_method(),
                                         initializer=_start, initargs=(share_for(workers), os.getpid(), *_messages()))

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
