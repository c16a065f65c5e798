"""Ending the ``aldpat`` process once its command is done, without the interpreter's teardown.

When a command has finished -- every output written, renamed and closed, the log and the summary
printed -- what is left of an ordinary interpreter exit is the teardown of every module: with the
compiled loops loaded that takes a third of a second or more (numba's and LLVM's objects freed one
by one) on every command, whatever its data (``bench/bench_startup.py`` measures what it saves). :func:`leave` runs what
an exit must run -- the ``atexit`` handlers (the logs' flushing, the removal of temporary folders,
a local Dask cluster's shutdown, the worker processes' joining), then the standard streams'
flushing -- and ends the process with its status, skipping only that teardown.

It falls back to the ordinary exit whenever that could lose anything: while a thread other than
a daemon is still running (the interpreter would wait for it), or when a standard stream cannot
be flushed (a closed pipe: the interpreter says so in its own way).
"""

from __future__ import annotations

import atexit
import os
import sys
import threading
from typing import NoReturn


def status_of(exc: SystemExit) -> int:
    """The exit status the interpreter gives ``exc``: 0 for None, the number, else 1."""
    code = exc.code
    if code is None:
        return 0
    return code if isinstance(code, int) else 1


def leave_after(exc: SystemExit) -> NoReturn:
    """End the process as ``exc`` would (a text is printed to stderr, as the interpreter prints
    it), without the teardown (see the module's note)."""
    if exc.code is not None and not isinstance(exc.code, int):
        print(exc.code, file=sys.stderr)
    leave(status_of(exc))


def leave(status: int) -> NoReturn:
    """End the process with ``status`` once its command is done (see the module's note)."""
    if _ordinary_exit_needed():
        sys.exit(status)
    atexit._run_exitfuncs()
    if _ordinary_exit_needed():  # an exit handler started a thread or broke a stream
        sys.exit(status)
    os._exit(status)


def _ordinary_exit_needed() -> bool:
    """A thread the interpreter would wait for still runs, or a standard stream cannot be flushed."""
    return _threads_still_running() or not _flushed()


def _threads_still_running() -> bool:
    main = threading.main_thread()
    return any(t is not main and not t.daemon and t.is_alive() for t in threading.enumerate())


def _flushed() -> bool:
    try:
        for stream in (sys.stdout, sys.stderr):
            if stream is not None:
                stream.flush()
    except (OSError, ValueError):
        return False
    return True
