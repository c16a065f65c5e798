"""Progress on stderr: a rich bar when stderr is a terminal, nothing otherwise."""

from __future__ import annotations

import contextlib
import sys
import threading


class _Bar:
    """A run's bar: one step per job, and one per unit of work inside the jobs (the chunks of a
    file processed chunk by chunk), the total growing as jobs plan their units."""

    def __init__(self, bar, task_id):
        self._bar, self._id = bar, task_id
        self._lock = threading.Lock()  # units from a cluster arrive on the client's thread
        self._total = 0

    def started(self, jobs: int) -> None:
        self._grow(jobs)

    def job_done(self, result) -> None:
        self._bar.advance(self._id)

    def units(self, kind: str, n: int) -> None:
        if kind == "planned":
            self._grow(n)
        else:
            self._bar.advance(self._id, n)

    def _grow(self, n: int) -> None:
        with self._lock:
            self._total += n
            self._bar.update(self._id, total=self._total)


@contextlib.contextmanager
def job_progress(task, *, enabled: bool = True):
    """Yield the run's :class:`~aldpat.jobs.execute.Progress` bar, or ``None`` when silent."""
    if not enabled or not sys.stderr.isatty():
        yield None
        return
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
    )

    with Progress(TextColumn(f"[bold]{task.key}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  console=Console(stderr=True), transient=True) as bar:
        yield _Bar(bar, bar.add_task(task.key, total=None))
