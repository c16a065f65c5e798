"""Loading and validating a worksheet before anything runs.

Every job is checked up front -- unknown keys (with a did-you-mean), wrong types, out-of-range
values, missing inputs -- and each problem is reported with the job number and key. Paths in a
worksheet are relative to the worksheet's folder.
"""

from __future__ import annotations

import bisect
import dataclasses
import difflib
import fnmatch
import logging
import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from aldpat.core.paths import expand_home
from aldpat.errors import ParamError, UsageError, shown
from aldpat.io.sidefiles import KEEP, other_names
from aldpat.io.toml import load_toml
from aldpat.jobs.cluster import scheduler_for
from aldpat.jobs.inputs import expand_inputs
from aldpat.jobs.outputs import (
    Reads,
    case_twin,
    check_outputs,
    forget_folders,
    literal_prefix,
    path_parameter_files,
    real,
    without_own_outputs,
)
from aldpat.jobs.registry import get_task
from aldpat.jobs.resolve import ResolvedRun, load_params_file, resolve_run
from aldpat.jobs.run import refused_by_name
from aldpat.jobs.task import Planned, Task

log = logging.getLogger(__name__)

JOB_KEYS = ("task", "algorithm", "inputs", "params")
TOP_KEYS = ("settings", "job")
#: ``[settings]`` keys of the run itself, not of its jobs: ``report = true`` writes the HTML report
RUN_SETTINGS = ("report",)
#: the files a run writes beside its worksheet (``<stem>.state.json``...), and what they are
RUN_FILES = ((".state.json", "run state"), (".log", "log"), (".lock", "lock"), (".html", "report"))


@dataclass
class Job:
    number: int  # 1-based, as the worksheet lists them
    task: Task
    raw: dict
    inputs: list[str]  # as written, made absolute against the worksheet folder
    run: ResolvedRun
    depends_on: set[int] = field(default_factory=set)
    planned: list[Planned] = field(default_factory=list)  # its outputs, as far as known before it runs
    params_file: Path | None = None  # its ``params = "FILE.toml"``

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


def _is_number(text: str) -> bool:
    """Whether ``text`` is a job number as typed: ASCII digits (``str.isdigit`` also takes
    superscripts, which ``int`` refuses)."""
    return text.isascii() and text.isdigit()


def parse_set(items: tuple[str, ...] | list[str]) -> list[tuple[str, int | None, str, Any]]:
    """``--set job.2.cell=2.0`` / ``--set settings.jobs=2`` -> (scope, job, key, value)."""
    out: list[tuple[str, int | None, str, Any]] = []
    for item in items:
        if "=" not in item:
            raise UsageError(f"--set {item!r}: expected job.N.key=value or settings.key=value")
        target, text = item.split("=", 1)
        try:
            value = tomllib.loads(f"v = {text}")["v"]
        except (tomllib.TOMLDecodeError, RecursionError):
            value = text
        parts = target.split(".")
        if len(parts) == 3 and parts[0] == "job" and _is_number(parts[1]):
            out.append(("job", int(parts[1]), parts[2], value))
        elif len(parts) == 2 and parts[0] == "settings":
            out.append(("settings", None, parts[1], value))
        else:
            raise UsageError(f"--set {item!r}: expected job.N.key=value or settings.key=value")
    return out


def _rebase(value: Any, folder: Path) -> Any:
    """A path of the worksheet (an input, ``@list``, or a path parameter) as the run takes it:
    relative to the worksheet's folder, and a leading ``~`` the home folder, as a shell expands it
    on a command line -- for every path, not for the inputs alone (an ``odir = "~/out"`` made a
    folder named ``~`` wherever the run was started). ``$VAR`` is left as it is: a worksheet is
    data, and what it names may not depend on the environment of whoever runs it."""
    if not isinstance(value, str) or not value:
        return value
    at = "@" if value.startswith("@") else ""
    path = value[len(at):]
    path = expand_home(path)
    if Path(path).is_absolute():
        return at + path
    return at + str(folder / path)


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
    # ``settings = "x"`` or ``job = [1, 2]`` are valid TOML of the wrong shape: said here, where
    # the worksheet is named, not by ``dict()`` ("dictionary update sequence element #0 ...")
    settings = doc.get("settings", {})
    if not isinstance(settings, dict):
        raise UsageError("settings: expected a table ([settings] and its keys below it), got "
                         + ("an array of tables ([[settings]])" if isinstance(settings, list) else shown(settings)),
                         path=path)
    settings = dict(settings)
    raw_jobs = doc.get("job", [])
    if not isinstance(raw_jobs, list) or not raw_jobs:
        raise UsageError("a worksheet needs at least one [[job]] table", path=path)
    for n, job in enumerate(raw_jobs, start=1):
        if not isinstance(job, dict):
            raise UsageError(f"job {n}: expected a [[job]] table of keys, got {shown(job)}", path=path)
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
    if name is None:
        raise UsageError(f"{where}missing key 'task'", path=wpath)
    if not isinstance(name, str):
        raise UsageError(f"{where}task: expected a task name such as \"thin\", got {shown(name)}", path=wpath)
    if name == "run":
        raise UsageError(f"{where}a worksheet cannot run another worksheet", path=wpath)
    algorithm = raw.get("algorithm")
    if name == "filter" and not algorithm:
        raise UsageError(f"{where}task 'filter' needs key 'algorithm'", path=wpath)
    try:
        task = get_task(name, algorithm if name == "filter" else None)
    except UsageError as exc:
        raise UsageError(f"{where}{exc}", path=wpath) from None
    specs = {s.name: s for s in task.all_specs()}
    if algorithm and name != "filter" and "algorithm" not in specs:
        raise UsageError(f"{where}key 'algorithm' belongs to task 'filter' only", path=wpath)
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
    params_file = None
    if isinstance(params, str):
        pfile = params_file = Path(_rebase(params, folder))
        try:
            layers.append(("params file", load_params_file(task, pfile, lambda m: rebased(m, pfile.parent))))
        except UsageError as exc:
            raise UsageError(f"{where}params: {exc}", path=wpath) from None
    elif isinstance(params, dict):
        layers.append(("worksheet", rebased(params, folder)))
    elif params is not None:
        raise UsageError(f"{where}params: expected a file name or a table", path=wpath)
    # ``algorithm`` names a filter task; of another task (dtm's ground filter) it is a parameter
    own = {k: v for k, v in raw.items() if k not in JOB_KEYS or (k == "algorithm" and name != "filter")}
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
    return Job(number, task, raw, inputs, run, params_file=params_file)


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


class _Planned:
    """The outputs planned by the jobs so far, found by file, by folder, and by the start of a name
    (a pattern's literal beginning): each lookup costs the same however many jobs there are, so
    checking a worksheet takes time in proportion to its jobs."""

    def __init__(self) -> None:
        self.exact: dict[str, tuple[int, Planned]] = {}  # realpath -> (job, output)
        self.folded: dict[str, str] = {}  # casefolded realpath -> the realpath of the first so named
        self.names: dict[str, list[str]] = {}  # folder -> sorted names of exact outputs
        self.families: dict[str, list[tuple[int, Planned]]] = {}  # folder -> (job, family)
        self.by_folder: dict[str, set[int]] = {}  # folder -> jobs writing there
        #: folder -> jobs writing there under names not known before they run (their inputs are
        #: an earlier job's family: its strips, its tiles)
        self.unnamed: dict[str, set[int]] = {}

    def add(self, number: int, planned: list[Planned], places: list[Path], unnamed: bool = False) -> None:
        """Job ``number``'s outputs, and the folders it writes in; ``unnamed``: its outputs of
        inputs that are themselves a family's are known only by their folder."""
        for place in places:
            self.by_folder.setdefault(real(place), set()).add(number)
            if unnamed:
                self.unnamed.setdefault(real(place), set()).add(number)
        for out in planned:
            folder = real(out.path.parent)
            self.by_folder.setdefault(folder, set()).add(number)
            if out.family:
                self.families.setdefault(folder, []).append((number, out))
                continue
            key = real(out.path)
            if key not in self.exact:
                bisect.insort(self.names.setdefault(folder, []), os.path.basename(key))
            self.exact[key] = (number, out)
            self.folded.setdefault(key.casefold(), key)

    def writer(self, out: Planned) -> tuple[int, Planned] | None:
        """The job and its output that write the file ``out`` would write: by its path, or by
        another spelling in case where the folder's file system folds case (:func:`case_twin`)."""
        key = real(out.path)
        twin = case_twin(key, self.folded)
        return self.exact.get(key if twin is None else twin)

    def writers_of(self, item: str) -> tuple[set[int], list[Path]]:
        """The jobs that write what the input ``item`` (a file, a folder or a pattern) names, and
        the files of it they write (known by name; a family's are not)."""
        target = Path(item)
        if target.is_dir() or real(target) in self.by_folder:  # a folder, or one a job writes in
            folder = real(target)
            files = [Path(folder, n) for n in self.names.get(folder, [])]
            return set(self.by_folder.get(folder, ())), files
        folder, name = real(target.parent), target.name
        jobs: set[int] = set()
        files = []
        if any(ch in name for ch in "*?["):
            names = self.names.get(folder, [])
            prefix = literal_prefix(name)
            for candidate in names[bisect.bisect_left(names, prefix):]:
                if not candidate.startswith(prefix):
                    break
                if fnmatch.fnmatchcase(candidate, name):
                    files.append(Path(folder, candidate))
            # a pattern reads what the jobs writing in its folder write, whichever names they take
            jobs |= self.by_folder.get(folder, set())
        else:
            hit = self.exact.get(os.path.join(folder, name))
            if hit is not None:
                jobs.add(hit[0])
                files.append(Path(folder, name))
            jobs |= {n for n, fam in self.families.get(folder, ()) if fam.matches(Path(folder, name))}
            if not jobs:  # a job whose own inputs were a family's wrote there under names not known yet
                jobs = set(self.unnamed.get(folder, set()))
        return jobs, files


def run_files(wpath: Path) -> dict[str, str]:
    """The worksheet and the files its run writes beside it (under aldpat's other names too, and
    the previous logs), by real path: what each is. No job's output may be one of them -- the
    worksheet replaced by a job's points is the project lost, and a job's output under the
    state's or the log's name would be taken for the run's, or the run's for it."""
    files = {real(wpath): "the worksheet itself"}
    for suffix, what in RUN_FILES:
        for name in other_names(wpath.with_name(wpath.stem + suffix)):
            files[real(name)] = f"the worksheet's {what}"
            if suffix == ".log":
                files.update({real(name.with_name(f"{name.name}.{k}")): "a log of the worksheet's earlier runs"
                              for k in range(1, KEEP + 1)})
    return files


def _refuse_unknown_formats(job: Job, found: list[Path], where: str, wpath: Path) -> None:
    """Refuse, before anything runs, an input of a points job whose extension is of no format the
    task reads (without ``format``): as an input that matches nothing, not a job that fails when
    the run reaches it after a dry run said "Ready"."""
    for f in found:
        why = refused_by_name(job.task, job.run, f)
        if why is not None:
            raise UsageError(f"{where}inputs: {why}", path=wpath)


def _link_and_check_inputs(jobs: list[Job], wpath: Path) -> None:
    """Each job depends on the earlier jobs that write what its inputs name; an input that matches
    nothing and is not written by an earlier job is an error now, not later. And no job may write
    an output that replaces an input it or an earlier job reads as an original (not an earlier
    job's output) -- a file of its inputs, its ``params`` file, a file a path parameter reads (a
    polygon, a reference) --, an output of another job (:mod:`aldpat.jobs.outputs`), or the
    worksheet and the files its run keeps beside it (:func:`run_files`)."""
    forget_folders()
    planned = _Planned()
    originals = Reads()
    readers: dict[str, int] = {}  # realpath of an original input -> the first job reading it
    reserved = run_files(wpath)

    def read_as_original(f: Path, number: int) -> None:
        if not planned.exact.get(real(f)) and not any(
                fam.matches(f) for _, fam in planned.families.get(real(f.parent), ())):
            originals.add(f)
            readers.setdefault(real(f), number)
    for job in jobs:
        where = f"job {job.number}: "
        sources: list[Path] = []
        gathered: set[Path] = set()
        originals_found: list[Path] = []
        unnamed = False  # reads files of earlier jobs not known by name: writes under names not known
        for pattern in job.inputs:
            if pattern.startswith("@"):  # the list file is read too
                read_as_original(Path(pattern[1:]), job.number)
            producers, made = planned.writers_of(pattern.lstrip("@")) if not pattern.startswith("@") else (set(), [])
            job.depends_on |= producers
            unnamed |= bool(producers) and not made
            found, errors = expand_inputs([pattern], gathered=gathered)
            if errors and not producers:
                raise UsageError(f"{where}inputs: {errors[0]}", path=wpath)
            _refuse_unknown_formats(job, found, where, wpath)
            originals_found += found
            sources += found + made
        unique = {real(f): f for f in reversed(sources)}  # each file once, the first spelling
        sources = [unique[k] for k in dict.fromkeys(real(f) for f in sources)]
        try:
            sources, own = without_own_outputs(job.task, sources, job.run, gathered)
            if own:
                log.warning("%s%s", where, own)
            kept = {real(f) for f in sources}
            for f in originals_found:
                if real(f) in kept:
                    read_as_original(f, job.number)
            job.planned = check_outputs(job.task, sources, job.run)
        except UsageError as exc:
            raise UsageError(f"{where}{exc.message}", path=wpath) from None
        for f in [*([job.params_file] if job.params_file is not None else []),
                  *path_parameter_files(job.run, job.planned)]:
            read_as_original(f, job.number)
        for out in job.planned:
            what = None if out.family else reserved.get(real(out.path))
            if what is not None:
                raise UsageError(f"{where}output {out.path} would replace {what}; give the job another output name",
                                 path=wpath)
            victim = originals.replaced_by(out)
            if victim is not None:
                reader = readers.get(real(victim), job.number)
                raise UsageError(f"{where}output {out.path} would replace {victim}, which job {reader} reads; give "
                                 "the job another --odir or --suffix", path=wpath)
            if not out.family and not getattr(job.run.params.values, "append", False):
                other = planned.writer(out)
                if other is not None and other[0] != job.number:
                    spelt = "" if other[1].path.name == out.path.name else f" (as {other[1].path.name})"
                    raise UsageError(f"{where}output {out.path} is also written by job {other[0]}{spelt}; give the "
                                     "jobs their own --odir or --suffix", path=wpath)
        planned.add(job.number, job.planned, job.output_places(), unnamed)
