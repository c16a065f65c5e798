"""A task's parameters resolved from their layers (defaults, settings, parameter file, worksheet,
command line), split among the task's own params class and the options every command has."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from aldpat.errors import ParamError
from aldpat.jobs.task import Task
from aldpat.options import InputParams, OutputParams, RunParams
from aldpat.params import Resolved, renamed_keys, resolve, specs, with_current_names


@dataclass
class ResolvedRun:
    task: Task
    params: Resolved  # the task's own parameters
    output: Resolved | None
    input: Resolved | None  # None for a task whose inputs are not point files
    run: Resolved
    #: processes a job may use for its chunks (``--chunk``): the ``-j`` workers when the run is
    #: one job, else 1 (the jobs already use them)
    chunk_workers: int = 1
    #: which function the jobs run: the task's own (``"main"``) or its first pass (``"first"``)
    stage: str = "main"
    #: the run's scratch folder, shared by its passes (None when the task has no first pass)
    scratch: str | None = None

    def record(self) -> list[tuple[str, str, str]]:
        rows = self.params.record()
        for part in (self.input, self.output):
            if part is not None:
                rows += part.record()
        return rows


def resolve_run(task: Task, layers: Sequence[tuple[str, Mapping[str, Any]]], where: str = "") -> ResolvedRun:
    """Split raw values among the task's params classes, validating each (unknown keys -> error),
    then the task's own rules (:attr:`Task.check`)."""
    known = {s.name for s in task.all_specs()}
    renames = renamed_keys(task.all_specs())
    layers = [(source, with_current_names(mapping, renames, where)) for source, mapping in layers]
    for _, mapping in layers:
        for key in mapping:
            if key.replace("-", "_") not in known:
                from aldpat.params import unknown_key_error

                raise unknown_key_error(key, known, where)
    parts = {}
    for cls in task.option_classes:
        names = {s.name for s in specs(cls)}
        sub = [(src, {k: v for k, v in m.items() if k.replace("-", "_") in names}) for src, m in layers]
        parts[cls] = resolve(cls, sub, where)
    if task.check is not None:
        try:
            task.check(parts[task.params].values)
        except ParamError as exc:
            raise ParamError(f"{where}{exc.message}") from None
    output = next((part for cls, part in parts.items() if issubclass(cls, OutputParams)), None)
    return ResolvedRun(task, parts[task.params], output, parts.get(InputParams), parts[RunParams])
