"""Progress on stderr: a rich bar when stderr is a terminal, nothing otherwise.

A run's bar counts its jobs, and the units of work inside them (the chunks of a file processed
chunk by chunk, :mod:`aldpat.core.units`). A job running in this process also tells which pass
over its points it is in -- read, grid, filter, classify, write -- and how many points each
pass has done: a second line shows it (the only line of a run of one job, whose own count
"0/1" says nothing). The passes are told at most once per chunk of points, never per point.
"""

from __future__ import annotations

import contextlib
import sys
import threading
from collections.abc import Iterator
from typing import TYPE_CHECKING

from aldpat.jobs.context import JobResult
from aldpat.jobs.task import Task

if TYPE_CHECKING:  # rich is imported when a bar is drawn, not when aldpat starts
    from rich.progress import Progress, ProgressColumn, TaskID
    from rich.progress import Task as Line
    from rich.text import Text


class _Bar:
    """A run's bar: one step per job and per unit of work, and the line of the current pass."""

    def __init__(self, bar: Progress, task_id: TaskID, label: str) -> None:
        self._bar, self._id, self._label = bar, task_id, label
        self._lock = threading.Lock()  # units from a cluster arrive on the client's thread
        self._total = 0
        self._pass: TaskID | None = None  # the line of the pass the running job is in
        self._chunked = False  # the job counts its chunks: the chunks are its progress

    def started(self, jobs: int) -> None:
        self._grow(jobs)

    def job_done(self, result: JobResult) -> None:
        self._bar.advance(self._id)
        self._chunked = False
        if self._pass is not None:
            self._bar.refresh()
            self._bar.remove_task(self._pass)
            self._pass = None
            self._bar.update(self._id, visible=True)

    def units(self, kind: str, n: int, name: str = "") -> None:
        if kind == "planned":
            self._chunked = True
            self._grow(n)
        elif kind == "finished":
            self._bar.advance(self._id, n)
        elif self._chunked:
            return  # each chunk's own passes would flicker past: the chunk count says more
        elif kind == "stage":
            self._stage(name, n if n >= 0 else None)
        elif kind == "advance" and self._pass is not None:
            self._bar.advance(self._pass, n)

    def _stage(self, name: str, total: int | None) -> None:
        one_job = self._total <= 1
        label = f"{self._label}: {name}" if one_job else f"  {name}"
        if self._pass is not None:
            self._bar.refresh()  # the pass ending is drawn done
            self._bar.remove_task(self._pass)  # a new line: its own total (or none) and elapsed time
        self._pass = self._bar.add_task(label, total=total, stage=True)
        self._bar.update(self._id, visible=not one_job)
        self._bar.refresh()  # a pass is drawn even when it ends before the next tick

    def _grow(self, n: int) -> None:
        with self._lock:
            self._total += n
            self._bar.update(self._id, total=self._total)


def _count_column() -> ProgressColumn:
    from rich.progress import ProgressColumn
    from rich.text import Text

    class Count(ProgressColumn):
        """Jobs and chunks as done/total; a pass's points as "n of N points"."""

        def render(self, task: Line) -> Text:
            if task.fields.get("stage"):
                done = f"{int(task.completed):,}"
                if task.total:
                    return Text(f"{done} of {int(task.total):,} points")
                return Text(f"{done} points" if task.completed else "")
            if task.total is None or task.total <= 1:
                return Text("")
            return Text(f"{int(task.completed)}/{int(task.total)}")

    return Count()


@contextlib.contextmanager
def job_progress(task: Task, *, enabled: bool = True) -> Iterator[_Bar | None]:
    """Yield the run's :class:`~aldpat.jobs.execute.Progress` bar, or ``None`` when silent."""
    if not enabled or not sys.stderr.isatty():
        yield None
        return
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), _count_column(), TimeElapsedColumn(),
                  console=Console(stderr=True), transient=True) as bar:
        yield _Bar(bar, bar.add_task(task.key, total=None), task.key)
