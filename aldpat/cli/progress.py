"""Progress on stderr: a rich bar when stderr is a terminal, nothing otherwise."""

from __future__ import annotations

import contextlib
import sys


@contextlib.contextmanager
def job_progress(task, *, enabled: bool = True, total: int | None = None):
    """Yield a callback ``(JobResult) -> None`` that advances a bar, or ``None`` when silent."""
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
        job = bar.add_task(task.key, total=total)

        def advance(result) -> None:
            bar.advance(job)

        yield advance
