"""Ending the ``aldpat`` process once its command is done, without the interpreter's teardown.

When a command has finished -- every output written, renamed and closed, the log and the summary
printed -- what is left of an ordinary interpreter exit is the teardown of every module: with the
compiled loops loaded that takes about 0.35 s (numba's and LLVM's objects freed one by one), as
long as filtering a tile of a hundred thousand points, on every command. :func:`leave` runs what
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
    """The exit status the interpreter gives ``exc``: 0 for None, the number, else 1 (the
    message, a text, printed to stderr as the interpreter prints it)."""
    code = exc.code
    if code is None:
        return 0
    if isinstance(code, int):
        return code
    print(code, file=sys.stderr)
    return 1


def leave(status: int) -> NoReturn:
    """End the process with ``status`` once its command is done (see the module's note)."""
    if _threads_still_running() or not _flushed():
        sys.exit(status)
    atexit._run_exitfuncs()
    if _threads_still_running() or not _flushed():  # an exit handler started or wrote something
        sys.exit(status)
    os._exit(status)


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
