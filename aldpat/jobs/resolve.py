"""A task's parameters resolved from their layers (defaults, settings, parameter file, worksheet,
command line), split among the task's own params class and the options every command has."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aldpat.errors import InputMissingError, ParamError, UsageError
from aldpat.io.toml import load_toml
from aldpat.jobs.task import Task
from aldpat.options import InputParams, OutputParams, RunParams
from aldpat.params import Resolved, coerce, renamed_keys, resolve, specs, unknown_key_error, with_current_names


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
    #: the parameter files its values came from (``--params``): read by the run, so no output
    #: may replace one (:func:`aldpat.jobs.outputs.path_parameter_files`)
    params_files: tuple[Path, ...] = ()

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
    given = layers
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
    files = tuple(m.path for _, m in given if isinstance(m, ParamsFile))
    return ResolvedRun(task, parts[task.params], output, parts.get(InputParams), parts[RunParams], params_files=files)


class ParamsFile(dict):
    """The keys and values of a parameter file, which knows its file (:func:`load_params_file`)."""

    def __init__(self, mapping: Mapping[str, Any], path: str | Path):
        super().__init__(mapping)
        self.path = Path(path)


def load_params_file(task: Task, path: str | Path, rebase: Callable[[dict], dict] | None = None) -> ParamsFile:
    """The parameter file ``path`` of ``task``, its paths made what ``rebase`` makes of them (a
    worksheet's are relative to the file), checked (:func:`check_params_file`). A file that is
    not there is a usage error, as click says of any option naming a missing file: the command
    cannot start, whatever its inputs."""
    try:
        mapping = load_toml(path)
    except InputMissingError as exc:
        raise UsageError(exc.message, path=exc.path) from None
    if rebase is not None:
        mapping = rebase(mapping)
    check_params_file(task, mapping, path)
    return ParamsFile(mapping, path)


def check_params_file(task: Task, mapping: Mapping[str, Any], path: object) -> None:
    """Every key of the parameter file ``path`` (``--params``, a job's ``params``) one of
    ``task``'s and each value of its kind and range, the :class:`ParamError` naming the file.

    Merged with the other layers, a bad key of the file was said as if typed ("unknown key
    'foo'", "job 1: cell: -1 is out of range"), and the user looked for it on the command line or
    in the worksheet. Rules between values (a window series and its smallest window) are the
    merged parameters' to check, as before."""
    known = {s.name: s for s in task.all_specs()}
    renames = renamed_keys(known.values())  # said once, when the layers are merged
    where = f"{path}: "
    for raw_key, value in mapping.items():
        key = renames.get(raw_key.replace("-", "_"), raw_key.replace("-", "_"))
        spec = known.get(key)
        if spec is None:
            raise unknown_key_error(raw_key, known, where)
        coerce(spec, value, where)

