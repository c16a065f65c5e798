"""Units of work inside a job -- the chunks of a file filtered or gridded chunk by chunk -- told to
whoever shows the run's progress.

A job that splits its work says how many units it planned (:func:`planned`) and when each is
finished (:func:`finished`). In the process that shows the progress, the listener set by
:func:`listening` hears it at once. A job running on a Dask worker (``--scheduler``) has no
listener: its counts go to the client as Dask events on :data:`TOPIC`, each tagged with the key of
the job's own task, which names the run (:mod:`aldpat.jobs.cluster` subscribes to them). Anywhere
else -- a job in a worker process of ``-j N`` -- the counts are dropped: the bar counts the job.

A job also tells which pass over its points it is in (:func:`stage`: read, grid, filter,
classify, write) and how many points of it are done (:func:`advance`), so that one big file
shows its progress. Those are told only to a listener in this process, at most once per chunk of
points: nothing is done per point, and nothing at all when no one listens (a Python caller, a
worker process).
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Callable, Iterable, Iterator
from typing import TypeVar

T = TypeVar("T")

#: Dask event topic of the units of jobs running on a cluster.
TOPIC = "aldpat-units"

#: ``listener(kind, n, name)``: ``kind`` is ``"planned"`` or ``"finished"`` (``n`` units),
#: ``"stage"`` (the pass ``name`` begins over ``n`` points, -1: not counted) or ``"advance"``
#: (``n`` more points of the pass are done).
Listener = Callable[[str, int, str], None]

# the listener, and the process it belongs to: a forked worker process inherits the variable,
# not the terminal the progress is drawn on
_listener: tuple[Listener, int] | None = None


def on_dask_worker() -> bool:
    """True inside a task running on a Dask worker."""
    distributed = sys.modules.get("distributed")  # never imported here: a worker has it already
    if distributed is None:
        return False
    try:
        distributed.get_worker()
    except ValueError:
        return False
    return True


def planned(n: int) -> None:
    """``n`` more units of work in this job."""
    _tell("planned", n)


def finished(n: int = 1) -> None:
    """``n`` units of work of this job are done."""
    _tell("finished", n)


def stage(name: str, total: int | None = None) -> None:
    """This job's work moves on to the pass ``name`` over ``total`` points (None: not counted)."""
    if _listener is not None and _listener[1] == os.getpid():
        _listener[0]("stage", -1 if total is None else int(total), name)


def advance(n: int) -> None:
    """``n`` more points of the current pass are done."""
    if _listener is not None and _listener[1] == os.getpid():
        _listener[0]("advance", int(n), "")


def counted(tables: Iterable[T], name: str, total: int | None = None) -> Iterator[T]:
    """``tables`` (chunks of points, anything with a length) as the pass ``name``, each chunk told
    as done once it has been used."""
    stage(name, total)
    for table in tables:
        yield table
        advance(len(table))  # type: ignore[arg-type]


def _tell(kind: str, n: int) -> None:
    if _listener is not None and _listener[1] == os.getpid():
        _listener[0](kind, n, "")
    elif on_dask_worker():
        import distributed

        worker = distributed.get_worker()
        worker.log_event(TOPIC, {"kind": kind, "n": n, "job": worker.get_current_task()})


@contextlib.contextmanager
def listening(listener: Listener | None) -> Iterator[None]:
    """Send this process's unit counts to ``listener`` (none: drop them) while inside."""
    global _listener
    before = _listener
    _listener = (listener, os.getpid()) if listener is not None else None
    try:
        yield
    finally:
        _listener = before
