"""Loading and validating a worksheet before anything runs.

Every job is checked up front -- unknown keys (with a did-you-mean), wrong types, out-of-range
values, missing inputs -- and each problem is reported with the job number and key. Paths in a
worksheet are relative to the worksheet's folder.
"""

from __future__ import annotations

import dataclasses
import difflib
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from aldpat.errors import ParamError, UsageError
from aldpat.io.toml import load_toml
from aldpat.jobs.cluster import scheduler_for
from aldpat.jobs.inputs import expand_inputs
from aldpat.jobs.registry import Task, get_task
from aldpat.jobs.resolve import ResolvedRun, resolve_run

JOB_KEYS = ("task", "algorithm", "inputs", "params")
TOP_KEYS = ("settings", "job")
#: ``[settings]`` keys of the run itself, not of its jobs: ``report = true`` writes the HTML report
RUN_SETTINGS = ("report",)


@dataclass
class Job:
    number: int  # 1-based, as the worksheet lists them
    task: Task
    raw: dict
    inputs: list[str]  # as written, made absolute against the worksheet folder
    run: ResolvedRun
    depends_on: set[int] = field(default_factory=set)

    @property
    def label(self) -> str:
        return f"job {self.number} ({self.task.key})"

    def output_places(self) -> list[Path]:
        """Folders (and explicit files) where this job's outputs land."""
        out = self.run.output.values if self.run.output is not None else None
        places: list[Path] = []
        explicit = getattr(self.run.params.values, "output", None)
        if explicit:
            places.append(Path(explicit).resolve())
            places.append(Path(explicit).resolve().parent)
        if out is not None and out.odir:
            places.append(Path(out.odir).resolve())
        elif not explicit:
            places += sorted({Path(p).resolve().parent for p in self.inputs if not p.startswith("@")})
        for field_ in dataclasses.fields(self.run.params.values):  # e.g. separate-returns' last_odir
            value = getattr(self.run.params.values, field_.name)
            if field_.name.endswith("_odir") and value:
                places.append(Path(value).resolve())
        return places


@dataclass
class Worksheet:
    path: Path
    settings: dict
    jobs: list[Job]

    @property
    def folder(self) -> Path:
        return self.path.parent

    @property
    def wants_report(self) -> bool:
        """``report = true`` in ``[settings]``: every run writes the HTML report."""
        value = self.settings.get("report", False)
        if not isinstance(value, bool):
            raise UsageError(f"settings: report: expected true or false, got {value!r}", path=self.path)
        return value


def parse_set(items: tuple[str, ...] | list[str]) -> list[tuple[str, int | None, str, Any]]:
    """``--set job.2.cell=2.0`` / ``--set settings.jobs=2`` -> (scope, job, key, value)."""
    out: list[tuple[str, int | None, str, Any]] = []
    for item in items:
        if "=" not in item:
            raise UsageError(f"--set {item!r}: expected job.N.key=value or settings.key=value")
        target, text = item.split("=", 1)
        try:
            value = tomllib.loads(f"v = {text}")["v"]
        except tomllib.TOMLDecodeError:
            value = text
        parts = target.split(".")
        if len(parts) == 3 and parts[0] == "job" and parts[1].isdigit():
            out.append(("job", int(parts[1]), parts[2], value))
        elif len(parts) == 2 and parts[0] == "settings":
            out.append(("settings", None, parts[1], value))
        else:
            raise UsageError(f"--set {item!r}: expected job.N.key=value or settings.key=value")
    return out


def _rebase(value: Any, folder: Path) -> Any:
    if isinstance(value, str) and value and not value.startswith("@") and not Path(value).expanduser().is_absolute():
        return str(folder / value)
    if isinstance(value, str) and value.startswith("@") and not Path(value[1:]).is_absolute():
        return "@" + str(folder / value[1:])
    return value


def load_worksheet(path: str | Path, overrides: list[str] | tuple[str, ...] = (), *,
                   scheduler: str | None = None) -> Worksheet:
    """Read, override and validate a worksheet; raise UsageError naming job and key.

    ``scheduler`` is ``aldpat run --scheduler``: the user's own choice, which every job takes (a
    worksheet's own ``scheduler`` may name only ``local[:N]``, ``none``, or this same address or
    ``$ALDPAT_SCHEDULER``'s: :func:`aldpat.jobs.cluster.scheduler_for`)."""
    path = Path(path).resolve()
    doc = load_toml(path)
    for key in doc:
        if key not in TOP_KEYS:
            hint = difflib.get_close_matches(key, TOP_KEYS, n=1)
            raise UsageError(f"unknown top-level key {key!r}" + (f"; did you mean {hint[0]!r}?" if hint else ""),
                             path=path)
    settings = dict(doc.get("settings", {}))
    raw_jobs = doc.get("job", [])
    if not isinstance(raw_jobs, list) or not raw_jobs:
        raise UsageError("a worksheet needs at least one [[job]] table", path=path)
    raw_jobs = [dict(j) for j in raw_jobs]
    for scope, number, key, value in parse_set(overrides):
        if scope == "settings" or number is None:
            settings[key] = value
        elif not 1 <= number <= len(raw_jobs):
            raise UsageError(f"--set job.{number}: the worksheet has {len(raw_jobs)} jobs")
        else:
            raw_jobs[number - 1][key] = value
    folder = path.parent
    given = {"scheduler": scheduler} if scheduler is not None else {}
    jobs = [_load_job(n, raw, settings, folder, path, given) for n, raw in enumerate(raw_jobs, start=1)]
    _check_settings(settings, jobs, path)
    _link_and_check_inputs(jobs, path)
    return Worksheet(path, settings, jobs)


def _load_job(number: int, raw: dict, settings: dict, folder: Path, wpath: Path, given: dict) -> Job:
    where = f"job {number}: "
    name = raw.get("task")
    if not isinstance(name, str):
        raise UsageError(f"{where}missing key 'task'", path=wpath)
    if name == "run":
        raise UsageError(f"{where}a worksheet cannot run another worksheet", path=wpath)
    algorithm = raw.get("algorithm")
    if name == "filter" and not algorithm:
        raise UsageError(f"{where}task 'filter' needs key 'algorithm'", path=wpath)
    try:
        task = get_task(name, algorithm if name == "filter" else None)
    except UsageError as exc:
        raise UsageError(f"{where}{exc}", path=wpath) from None
    if algorithm and name != "filter":
        raise UsageError(f"{where}key 'algorithm' belongs to task 'filter' only", path=wpath)
    specs = {s.name: s for s in task.all_specs()}
    inputs = raw.get("inputs", [])
    if isinstance(inputs, str):
        inputs = [inputs]
    if not isinstance(inputs, list) or not all(isinstance(i, str) for i in inputs):
        raise UsageError(f"{where}inputs: expected a list of paths or patterns", path=wpath)
    if task.inputs == "many" and not inputs:
        raise UsageError(f"{where}inputs: task {task.key!r} needs at least one input", path=wpath)
    inputs = [_rebase(i, folder) for i in inputs]

    def rebased(mapping: dict, base: Path) -> dict:
        return {k: (_rebase(v, base) if k.replace("-", "_") in specs and specs[k.replace("-", "_")].path else v)
                for k, v in mapping.items()}

    layers = []
    applicable = {k: v for k, v in settings.items() if k.replace("-", "_") in specs}
    if applicable:
        layers.append(("settings", rebased(applicable, folder)))
    params = raw.get("params")
    if isinstance(params, str):
        pfile = Path(_rebase(params, folder))
        try:
            layers.append(("params file", rebased(load_toml(pfile), pfile.parent)))
        except UsageError as exc:
            raise UsageError(f"{where}params: {exc}", path=wpath) from None
    elif isinstance(params, dict):
        layers.append(("worksheet", rebased(params, folder)))
    elif params is not None:
        raise UsageError(f"{where}params: expected a file name or a table", path=wpath)
    own = {k: v for k, v in raw.items() if k not in JOB_KEYS}
    layers.append(("worksheet", rebased(own, folder)))
    if given:
        layers.append(("cli", given))
    try:
        run = resolve_run(task, layers, where=where)
    except ParamError as exc:
        raise UsageError(str(exc), path=wpath) from None
    try:  # refused now, before any job runs, rather than when the job comes
        scheduler_for(run.run.values.scheduler, run.run.sources["scheduler"])
    except UsageError as exc:
        raise UsageError(f"{where}{exc.message}", path=wpath) from None
    return Job(number, task, raw, inputs, run)


def _check_settings(settings: dict, jobs: list[Job], wpath: Path) -> None:
    from aldpat.jobs.registry import TASKS

    known = set()  # a setting may serve any task, not only those in this worksheet
    for task in TASKS.values():
        known |= {s.name for s in task.all_specs()}
    from aldpat.options import RunParams
    from aldpat.params import specs as param_specs

    known |= {s.name for s in param_specs(RunParams)} | set(RUN_SETTINGS)
    for key in settings:
        if key.replace("-", "_") not in known:
            hint = difflib.get_close_matches(key.replace("-", "_"), sorted(known), n=1)
            raise UsageError(f"settings: unknown key {key!r}" + (f"; did you mean {hint[0]!r}?" if hint else ""),
                             path=wpath)


def _link_and_check_inputs(jobs: list[Job], wpath: Path) -> None:
    """Each job depends on the earlier jobs whose output places its inputs read from; an input
    that matches nothing and is not produced by an earlier job is an error now, not later."""
    for job in jobs:
        for pattern in job.inputs:
            target = Path(pattern.lstrip("@")).resolve()
            producers = {earlier.number for earlier in jobs[: job.number - 1]
                         if any(target == place or target.parent == place or place in target.parents
                                for place in earlier.output_places())}
            job.depends_on |= producers
            if producers:
                continue
            _, errors = expand_inputs([pattern])
            if errors:
                raise UsageError(f"job {job.number}: inputs: {errors[0]}", path=wpath)
