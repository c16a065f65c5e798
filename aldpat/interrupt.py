"""Stopping cleanly on SIGINT, SIGTERM and SIGHUP, and saying what was stopped.

Python turns SIGINT into ``KeyboardInterrupt`` but lets SIGTERM (``kill``, a batch scheduler
ending a job, a closing terminal's SIGHUP) end the process on the spot, which would leave the
temporary file of the output being written. :func:`install` makes all three raise
:class:`Interrupted`, so the atomic writers remove their temporary files on the way out
exactly as for Ctrl-C.

What is running is kept by :func:`doing` (a stack of short descriptions: the worksheet job, the
task and its input) so that the command can say what was interrupted.

Worker processes of a pool ignore SIGINT and SIGHUP (the run's process decides, and ends them
with SIGTERM), and ask the kernel for SIGTERM when their parent (the fork server, which ends with
the run's process) dies, with a watchdog thread where the kernel cannot or did not: a run killed
outright (SIGKILL) leaves no worker behind, writing outputs under a resumed run or blocked on a
pipe (:mod:`aldpat.core.workers`).
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from types import FrameType
from typing import Any, TypeVar

#: what a job returns (:func:`run_job`)
T = TypeVar("T")

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


#: the signal that asked this process to stop, once one has
_requested: int | None = None


def _raise(signum: int, frame: FrameType | None) -> None:
    global _requested
    _requested = signum
    raise Interrupted(signum)


def stop_requested() -> int | None:
    """The signal that asked this process to stop, if one has."""
    return _requested


def reraise_if_stopping() -> None:
    """Raise :class:`Interrupted` again if a signal asked this process to stop. A library that
    calls back into Python may turn the :class:`Interrupted` raised in the callback into an error
    of its own -- lazrs writes a LAZ file through the file object's ``write`` and reports a
    failed write as an ``OSError`` -- and that error must not pass for a failure of the job:
    the job stops, and so does the run."""
    if _requested is not None:
        raise Interrupted(_requested)


def install() -> None:
    """Make SIGINT, SIGTERM and SIGHUP raise :class:`Interrupted` in this process."""
    global _requested
    _requested = None
    for sig in (signal.SIGINT, signal.SIGTERM, getattr(signal, "SIGHUP", None)):
        if sig is not None:
            signal.signal(sig, _raise)
    sys.unraisablehook = _unraisable


_stopping = False

#: seconds after a callback swallowed an interruption before it is asked for again
AGAIN_AFTER = 0.05


def _unraisable(unraisable: Any) -> None:
    """``sys.unraisablehook``: an :class:`Interrupted` raised inside a callback from C code is
    asked for again, without a word, once the callback is done; anything else goes to Python's
    own hook.

    A signal's handler raises where the main thread happens to be, and that may be a callback from
    C: LLVM's, compiling a numba loop of a fresh installation (its object cache callback), or a
    codec's. C cannot take the exception, so Python printed it as "Exception ignored in ..." with
    a traceback, and dropped it -- the run went on, and a worker ignored the SIGTERMs after it. A
    moment later, the signal is sent again (from a thread: the handler then runs back in Python's
    own code, and raises there)."""
    if isinstance(unraisable.exc_value, Interrupted):
        global _stopping
        _stopping = False  # the worker's handler raises again
        again = threading.Timer(AGAIN_AFTER, os.kill, (os.getpid(), unraisable.exc_value.signum))
        again.daemon = True
        again.start()
        return
    sys.__unraisablehook__(unraisable)


def _raise_in_worker(signum: int, frame: FrameType | None) -> None:
    global _stopping, _requested
    _requested = signum
    if not _activity:  # between jobs (idle, or sending a result): nothing to clean up, nothing to say
        os._exit(128 + signum)
    if _stopping:  # told twice (the parent and the kernel): the first is being honoured
        return
    _stopping = True
    raise Interrupted(signum)


def install_in_worker(run: int) -> None:
    """Signal handling of a pool worker of the run's process ``run``: stop on SIGTERM (from the
    run, or the kernel when the worker's parent dies); leave SIGINT and SIGHUP, which a terminal
    sends to every process of the command, to the run; end with the run however it ends."""
    global _interrupted_during, _stopping, _requested
    _activity.clear()  # a forked worker starts with a copy of what its parent was doing
    _interrupted_during = None
    _stopping = False
    _requested = None
    signal.signal(signal.SIGTERM, _raise_in_worker)
    for sig in TERMINAL:
        signal.signal(sig, signal.SIG_IGN)
    _die_with_parent()
    threading.Thread(target=_watch_parent, args=(os.getppid(), run), name="aldpat-parent-watch",
                     daemon=True).start()
    sys.unraisablehook = _unraisable
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


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # there, though not ours to signal
        return True
    return True


def _watch_parent(parent: int, run: int, every: float = WATCH_EVERY, grace: float = WATCH_GRACE) -> None:
    """Where the kernel sends no signal (or it was missed): once the parent is gone (this process
    was handed to another) or the run's process is, stop as SIGTERM stops a worker, and exit after
    ``grace`` seconds whatever the job is doing. The parent is the run itself when the worker was
    forked from it, or the fork server, which ends when the run does.

    The signal goes to the main thread: Python runs handlers there only, and a main thread blocked
    in a read (an idle worker waiting for its next job) wakes only for a signal delivered to it.
    For the same reason this thread refuses the stopping signals, so that the kernel's
    (``PR_SET_PDEATHSIG``) reaches the main thread rather than this one."""
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_BLOCK, STOPPING)
    while os.getppid() == parent and _alive(run):
        time.sleep(every)
    main = threading.main_thread().ident
    if hasattr(signal, "pthread_kill") and main is not None:
        signal.pthread_kill(main, signal.SIGTERM)
    else:
        os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(grace)
    os._exit(128 + signal.SIGTERM)


def run_job(fn: Callable[..., T], *args: Any) -> T:
    """``fn(*args)`` in a pool worker, as one job for :func:`_raise_in_worker`: told to stop
    during it, the job unwinds (its writers remove their temporary files) and the worker exits
    without sending anything back -- the queues it shares with the other workers may be held by a
    worker that was ended the same way."""
    try:
        with doing("job"):
            result = fn(*args)
    except Interrupted as exc:
        os._exit(128 + exc.signum)
    if _requested is not None:  # told to stop, and the job ended another way (see reraise_if_stopping)
        os._exit(128 + _requested)
    return result


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
