"""Stopping cleanly on SIGINT, SIGTERM and SIGHUP, and saying what was stopped.

Python turns SIGINT into ``KeyboardInterrupt`` but lets SIGTERM (``kill``, a batch scheduler
ending a job, a closing terminal's SIGHUP) end the process on the spot, which would leave the
temporary file of the output being written. :func:`install` makes all three raise
:class:`Interrupted`, so the atomic writers remove their temporary files on the way out
exactly as for Ctrl-C.

What is running is kept by :func:`doing` (a stack of short descriptions: the worksheet job, the
task and its input) so that the command can say what was interrupted.

Worker processes of a pool ignore SIGINT (the parent decides, and ends them with SIGTERM) and
ask the kernel for SIGTERM when their parent dies, so a parent killed outright (SIGKILL) does not
leave workers writing outputs behind a resumed run.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
from collections.abc import Callable, Iterator

_activity: list[str | Callable[[], str]] = []
_interrupted_during: str | None = None


class Interrupted(KeyboardInterrupt):
    """A signal asked aldpat to stop."""

    def __init__(self, signum: int = signal.SIGINT):
        self.signum = signum
        super().__init__(signal.Signals(signum).name)

    @property
    def signal_name(self) -> str:
        return signal.Signals(self.signum).name


def _raise(signum, frame) -> None:
    raise Interrupted(signum)


def install() -> None:
    """Make SIGINT, SIGTERM and SIGHUP raise :class:`Interrupted` in this process."""
    for sig in (signal.SIGINT, signal.SIGTERM, getattr(signal, "SIGHUP", None)):
        if sig is not None:
            signal.signal(sig, _raise)


def _raise_in_worker(signum, frame) -> None:
    if not _activity:  # idle between jobs: nothing to clean up, and nothing to report
        os._exit(128 + signum)
    raise Interrupted(signum)


def install_in_worker() -> None:
    """Signal handling of a pool worker: stop on SIGTERM (from the parent, or the kernel when the
    parent dies); leave SIGINT to the parent."""
    signal.signal(signal.SIGTERM, _raise_in_worker)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _die_with_parent()


def _die_with_parent() -> None:
    if not sys.platform.startswith("linux"):
        return
    import ctypes

    PR_SET_PDEATHSIG = 1
    with contextlib.suppress(OSError, AttributeError):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0)
        if os.getppid() == 1:  # the parent died before the request was made
            raise Interrupted(signal.SIGTERM)


@contextlib.contextmanager
def doing(what: str | Callable[[], str]) -> Iterator[None]:
    """Record ``what`` as running for the duration of the block (a callable is asked only if the
    block is interrupted, so it can tell the state at that instant)."""
    global _interrupted_during
    _activity.append(what)
    try:
        yield
    except KeyboardInterrupt:
        if _interrupted_during is None:  # the innermost block sees it first: keep the whole story
            _interrupted_during = current()
        raise
    finally:
        _activity.pop()


def current() -> str:
    """What is running (or was, when an interruption unwound it), outermost first."""
    return _interrupted_during or "; ".join(a if isinstance(a, str) else a() for a in _activity)


def exit_status(exc: BaseException) -> int:
    """128 + the signal's number, as shells report a process a signal ended."""
    return 128 + (exc.signum if isinstance(exc, Interrupted) else signal.SIGINT)


def describe(exc: BaseException) -> str:
    """The one line shown for an interruption."""
    name = exc.signal_name if isinstance(exc, Interrupted) else "SIGINT"
    where = current()
    return f"interrupted by {name}" + (f" during {where}" if where else "") + \
        "; outputs already finished are kept, no partial output was left"
