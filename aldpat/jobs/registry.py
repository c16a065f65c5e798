"""The task registry: every task registers a :class:`~aldpat.jobs.task.Task` under its command name.

A task is one module in ``aldpat/tasks/`` that declares its parameters once (a frozen dataclass
of :func:`aldpat.params.param` fields) and registers a :class:`Task` with either

* ``run_one(source, params, ctx)`` -- one job per input file, run in parallel with ``-j``; or
* ``run_all(sources, params, ctx)`` -- one job for all inputs (merge, tile, shapefile...);

and says, with ``outputs``, every file it will write before it runs (one hook for every task:
:meth:`Task.planned_outputs`), so that an output that would replace an input, or another output,
is refused before anything runs.

The CLI command and the worksheet job for a task are derived from the same registration, so
adding a task is one module plus its tests. The registry sits above the modules that run tasks
(:mod:`aldpat.jobs.run`): a registered task runs when called from Python, which the declaration
in the leaf :mod:`aldpat.jobs.task` that they all import cannot do without importing them back.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from aldpat.errors import UsageError
from aldpat.jobs.run import RunReport, run_task
from aldpat.jobs.task import Task


class RegisteredTask(Task):
    """A registered :class:`Task`: called from Python it runs, and it travels to worker processes
    by its registry key."""

    def __call__(self, inputs: Iterable[str | Path] = (), **kwargs: Any) -> RunReport:
        """Run from Python with the same parameter names as the CLI and worksheets."""
        return run_task(self, list(inputs), [("python", kwargs)])

    def __reduce__(self) -> tuple[Callable[[str], RegisteredTask], tuple[str]]:
        # A task travels to worker processes by its registry key: its functions may be closures
        # (one per filter algorithm) that pickle cannot carry.
        return (_registered_task, (self.key,))


TASKS: dict[str, RegisteredTask] = {}


def _registered_task(key: str) -> RegisteredTask:
    import aldpat.tasks  # noqa: F401  (a spawned worker registers the tasks again)

    return TASKS[key]


def register_task(task: Task) -> RegisteredTask:
    """Register ``task`` under its command name (:attr:`Task.key`); the registered task it returns
    is what :func:`get_task` gives."""
    if task.key in TASKS:
        raise ValueError(f"task {task.key!r} registered twice")
    registered = RegisteredTask(**{f.name: getattr(task, f.name) for f in dataclasses.fields(Task)})
    TASKS[task.key] = registered
    return registered


def get_task(name: str, algorithm: str | None = None) -> RegisteredTask:
    import aldpat.tasks  # noqa: F401  (registers every task module)

    key = f"{name} {algorithm}" if algorithm else name
    if key not in TASKS:
        import difflib

        options = sorted(TASKS)
        hint = difflib.get_close_matches(key, options, n=1)
        did = f"; did you mean {hint[0]!r}?" if hint else ""
        raise UsageError(f"unknown task {key!r}{did}")
    return TASKS[key]
