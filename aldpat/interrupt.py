"""Stopping cleanly on SIGINT, SIGTERM and SIGHUP, and saying what was stopped.

Python turns SIGINT into ``KeyboardInterrupt`` but lets SIGTERM (``kill``, a batch scheduler
ending a job, a closing terminal's SIGHUP) end the process on the spot, which would leave the
temporary file of the output being written. :func:`install` makes all three raise
:class:`Interrupted`, so the atomic writers remove their temporary files on the way out
exactly as for Ctrl-C.

What is running is kept by :func:`doing` (a stack of short descriptions: the worksheet job, the
task and its input) so that the command can say what was interrupted.

Worker processes of a pool ignore SIGINT and SIGHUP (the parent decides, and ends them with
SIGTERM), and ask the kernel for SIGTERM when their parent dies, with a watchdog thread where the
kernel cannot or did not: a parent killed outright (SIGKILL) leaves no worker behind, writing
outputs under a resumed run or blocked on a pipe (:mod:`aldpat.core.workers`).
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time
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


_stopping = False


def _raise_in_worker(signum, frame) -> None:
    global _stopping
    if not _activity:  # between jobs (idle, or sending a result): nothing to clean up, nothing to say
        os._exit(128 + signum)
    if _stopping:  # told twice (the parent and the kernel): the first is being honoured
        return
    _stopping = True
    raise Interrupted(signum)


def install_in_worker(parent: int) -> None:
    """Signal handling of a pool worker of process ``parent``: stop on SIGTERM (from the parent,
    or the kernel when the parent dies); leave SIGINT and SIGHUP, which a terminal sends to every
    process of the command, to the parent; end with the parent however it ends."""
    global _interrupted_during, _stopping
    _activity.clear()  # a forked worker starts with a copy of what its parent was doing
    _interrupted_during = None
    _stopping = False
    signal.signal(signal.SIGTERM, _raise_in_worker)
    for sig in TERMINAL:
        signal.signal(sig, signal.SIG_IGN)
    _die_with_parent()
    threading.Thread(target=_watch_parent, args=(parent,), name="aldpat-parent-watch", daemon=True).start()
    if hasattr(signal, "pthread_sigmask"):  # held back while the pool started this worker
        signal.pthread_sigmask(signal.SIG_UNBLOCK, STOPPING)


def _die_with_parent() -> None:
    """Ask Linux for SIGTERM when the parent dies (``PR_SET_PDEATHSIG``)."""
    if not sys.platform.startswith("linux"):
        return
    import ctypes

    PR_SET_PDEATHSIG = 1
    with contextlib.suppress(OSError, AttributeError):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0)


#: seconds between two looks for the parent, and given to a job to clean up once it is gone
WATCH_EVERY = 0.5
WATCH_GRACE = 20.0


def _watch_parent(parent: int, every: float = WATCH_EVERY, grace: float = WATCH_GRACE) -> None:
    """Where the kernel sends no signal (or it was missed): once the parent is gone (this process
    was handed to another), stop as SIGTERM stops a worker, and exit after ``grace`` seconds
    whatever the job is doing."""
    while os.getppid() == parent:
        time.sleep(every)
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(grace)
    os._exit(128 + signal.SIGTERM)


def run_job(fn: Callable, *args):
    """``fn(*args)`` in a pool worker, as one job for :func:`_raise_in_worker`: told to stop
    during it, the job unwinds (its writers remove their temporary files) and the worker exits
    without sending anything back -- the queues it shares with the other workers may be held by a
    worker that was ended the same way."""
    try:
        with doing("job"):
            return fn(*args)
    except Interrupted as exc:
        os._exit(128 + exc.signum)


#: the signals that stop aldpat (:func:`install`)
STOPPING = frozenset({signal.SIGINT, signal.SIGTERM, *([signal.SIGHUP] if hasattr(signal, "SIGHUP") else [])})
#: the signals a terminal sends to every process of a command, which workers leave to the parent
TERMINAL = frozenset({signal.SIGINT, *([signal.SIGHUP] if hasattr(signal, "SIGHUP") else [])})


@contextlib.contextmanager
def held_back(signals: frozenset[signal.Signals] = STOPPING) -> Iterator[None]:
    """``signals`` held back in this thread for the block (they arrive when it ends). Processes
    and threads started in it keep them held back: a worker forked here meets none before its own
    handlers are set, a process spawned here never meets them."""
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    before = signal.pthread_sigmask(signal.SIG_BLOCK, signals)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


@contextlib.contextmanager
def ignored_by_new_processes(signals: frozenset[signal.Signals] = TERMINAL) -> Iterator[None]:
    """``signals`` ignored while the block starts processes (Dask's workers), which keep ignoring
    them whatever starts them: an ignored signal stays ignored across ``exec``, and Python and
    asyncio then install no handler for it. This process ignores them for the block too."""
    before = {sig: signal.getsignal(sig) for sig in signals}
    for sig in signals:
        signal.signal(sig, signal.SIG_IGN)
    try:
        yield
    finally:
        for sig, handler in before.items():
            signal.signal(sig, handler)


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
