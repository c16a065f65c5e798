"""Running a task: expand the inputs, resolve the parameters, plan the jobs (one per input, or
one for all), hand them to an executor, and report what happened (exit status 0, 1 or 2)."""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import os
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aldpat.core import units
from aldpat.core.workers import workers_to_start
from aldpat.errors import InputFormatError, NoSuchFile, UsageError
from aldpat.io.chunks import scratch_folder
from aldpat.io.registry import detect_format
from aldpat.jobs.cluster import scheduler_for
from aldpat.jobs.context import JobResult, Written
from aldpat.jobs.execute import Progress, execute_finish, refuse_existing, report_result
from aldpat.jobs.executors import run_in_processes, run_in_this_process
from aldpat.jobs.inputs import expand_inputs
from aldpat.jobs.outputs import check_outputs, forget_folders, without_own_outputs
from aldpat.jobs.resolve import ResolvedRun, resolve_run
from aldpat.jobs.task import Planned, Task

log = logging.getLogger(__name__)


@dataclass
class RunReport:
    task: str
    results: list[JobResult]
    input_errors: list[str]
    params: Any = None  # the task's resolved parameters (``json`` says how to show the records)
    #: the result of the task's finish step (``--mosaic``), also the last of ``results``: its
    #: inputs are the run's outputs, no input of the user's
    finish: JobResult | None = None

    @property
    def failed(self) -> int:
        return sum(not r.ok for r in self.results) + len(self.input_errors)

    @property
    def inputs_failed(self) -> tuple[int, int]:
        """(inputs that failed, inputs) of the user's: "2 of 3 inputs failed" counted the mosaic
        of a run over two grids as a third input."""
        jobs = [r for r in self.results if r is not self.finish]
        return sum(not r.ok for r in jobs) + len(self.input_errors), len(jobs) + len(self.input_errors)

    @property
    def exit_code(self) -> int:
        if any(r.usage for r in self.results):
            return 2
        return 1 if self.failed else 0

    @property
    def outputs(self) -> list[Written]:
        return [w for r in self.results for w in r.outputs]


def plan_jobs(task: Task, sources: list[Path], run: ResolvedRun) -> list[list[str]]:
    """The inputs of each job: one each (``run_one``), all (``run_all``), or as the task plans."""
    if task.plan is not None:
        return task.plan(sources, run.params.values, run.input.values if run.input else None)
    if task.run_one is not None:
        return [[str(s)] for s in sources]
    return [[str(s) for s in sources]]


@dataclass
class PlannedRun:
    """What a run would do, everything checked that can be before a point is read."""

    run: ResolvedRun
    sources: list[Path]
    input_errors: list[str]
    jobs: list[list[str]]  # the inputs of each job
    outputs: list[Planned]
    #: of the input errors, the files named that do not exist (:class:`~aldpat.errors.NoSuchFile`)
    lost: int = 0


def plan_run(task: Task, inputs: Sequence[str | Path], layers: Sequence[tuple[str, Mapping[str, Any]]], *,
             base: Path | None = None, resolved: ResolvedRun | None = None) -> PlannedRun:
    """Resolve and check the parameters (the task's rules too), expand the inputs, refuse an
    output that would replace an input or another output, and plan the jobs: what
    :func:`run_task` does before running anything, and all that ``--dry-run`` does."""
    run = resolved or resolve_run(task, layers)
    skipped: list[str] = []
    gathered: set[Path] = set()
    sources, errors = expand_inputs(inputs, base, skipped, gathered) if task.inputs != "none" else ([], [])
    sources, own = without_own_outputs(task, sources, run, gathered)
    for line in [*skipped, *([own] if own and resolved is None else [])]:  # a worksheet said it, planning
        log.warning(line)
    input_errors = [str(e) for e in errors]
    for e in input_errors:
        log.error(e)
    if task.inputs == "many" and not sources:
        if not input_errors:
            raise UsageError("no inputs given")
        return PlannedRun(run, [], input_errors, [], [])
    forget_folders()
    outputs = check_outputs(task, sources, run)  # before anything runs: no output replaces an input or another
    jobs = plan_jobs(task, sources, run) if task.inputs != "none" else [[]]
    return PlannedRun(run, sources, input_errors, jobs, outputs, sum(isinstance(e, NoSuchFile) for e in errors))


def refused_by_name(task: Task, run: ResolvedRun, source: Path) -> str | None:
    """Why a job of ``task`` refuses ``source`` by its name alone -- an extension of no point
    format the task reads, without ``--format`` -- said as the job says it; None: it does not."""
    if not task.reads_points or run.input is None or source.suffix.lower() in task.other_inputs:
        return None
    try:
        detect_format(source, getattr(run.input.values, "format", "auto"))
    except InputFormatError as exc:
        return str(exc)
    return None


def formats_refused(task: Task, plan: PlannedRun) -> list[str]:
    """What the jobs of ``plan`` refuse of their inputs by name alone (:func:`refused_by_name`),
    reading nothing: for ``--dry-run``, which said a job of ``pic.png`` would write
    ``pic_gapm.png`` and the run then refused it."""
    named = (refused_by_name(task, plan.run, Path(s)) for s in dict.fromkeys(s for job in plan.jobs for s in job))
    return [why for why in named if why is not None]


def run_task(task: Task, inputs: Sequence[str | Path], layers: Sequence[tuple[str, Mapping[str, Any]]], *,
             command: str | None = None, base: Path | None = None, progress: Progress | None = None,
             resolved: ResolvedRun | None = None) -> RunReport:
    """Expand inputs, resolve parameters, run the jobs (in a pool with ``jobs`` > 1)."""
    plan = plan_run(task, inputs, layers, base=base, resolved=resolved)
    command = command or f"aldpat {task.key} " + " ".join(map(str, inputs))
    made = _missing_folders(plan.run)
    try:
        return _run_planned(task, plan, command, progress)
    finally:
        _remove_if_empty(made)


def _missing_folders(run: ResolvedRun) -> list[Path]:
    """The output folder (``--odir``) and those of its parents that do not exist yet, innermost
    first: what the jobs create, and a run that writes nothing removes again."""
    odir = getattr(run.output.values, "odir", None) if run.output is not None else None
    missing: list[Path] = []
    folder = Path(odir).absolute() if odir else None
    while folder is not None and not folder.exists() and folder != folder.parent:
        missing.append(folder)
        folder = folder.parent
    return missing


def _remove_if_empty(folders: list[Path]) -> None:
    """Remove each of ``folders`` (innermost first) the run left empty: a refused or failed run
    leaves no empty ``--odir`` behind, and one that holds anything stays."""
    for folder in folders:
        try:
            folder.rmdir()  # only an empty folder: a file or a log in it keeps it
        except OSError:
            return  # not empty (or not removable): its parents are not empty either


def _run_planned(task: Task, plan: PlannedRun, command: str, progress: Progress | None) -> RunReport:
    run, sources, input_errors, jobs = plan.run, plan.sources, plan.input_errors, plan.jobs
    if task.inputs == "many" and not sources:
        return RunReport(task.key, [], input_errors)
    if task.run_all is not None and plan.lost:
        # one product of every input (merge, tile): made of those found, it would be put in place
        # under its final name without a file the user named -- a merged site missing a tile -- as
        # lasmerge and PDAL's merge stop at a file they cannot open; so it is not made at all, as
        # when an input found cannot be read. (A pattern matching nothing, or a folder without
        # points, names no file: the others are made, with its line.)
        return RunReport(task.key, [JobResult(inputs=[str(s) for s in sources], error=(
            f"{task.key} not run: {plan.lost} of its inputs cannot be found, and it makes one product of them all"))],
            input_errors, run.params.values)
    if task.finish is not None and not (run.output is not None and run.output.values.overwrite):
        # the finish step writes its output (a mosaic) once every job is done: refused now, not
        # after the work, as each job refuses its own outputs before it reads anything
        refuse_existing([p for p in plan.outputs if p.source is None and not p.family])
    first = task.first(sources, run.params.values, run.input.values if run.input else None) \
        if task.first is not None and sources else []
    wanted = run.run.values.jobs or (os.cpu_count() or 1)
    if len(jobs) == 1 and wanted > 1:
        run = dataclasses.replace(run, chunk_workers=wanted)  # one big input: its chunks use the cores
    results: list[JobResult] = []
    scheduler = scheduler_for(run.run.values.scheduler, run.run.sources.get("scheduler", "cli"))
    if progress is not None:
        progress.started(len(first) + len(jobs))
    with units.listening(progress.units if progress is not None else None), \
            _scratch(run, sources) if first else contextlib.nullcontext(run) as run:
        if first:
            passed: list[JobResult] = []
            _execute(task, first, dataclasses.replace(run, stage="first"), command, scheduler, wanted, passed,
                     progress)
            failed = [r for r in passed if not r.ok]
            results += failed  # the task's jobs say what it means for the others
            # an input whose first pass failed has said why: its own job would only say it again
            said = {Path(r.inputs[0]).resolve() for r in failed if r.inputs}
            jobs = [job for job in jobs if Path(job[0]).resolve() not in said]
        _execute(task, jobs, run, command, scheduler, wanted, results, progress)
    last = None
    if task.finish is not None:
        last = execute_finish(task, results, run, command)
        if last.outputs or not last.ok:  # a finish step with nothing to do is not a job
            results.append(last)
            report_result(last, None)
        else:
            last = None
    return RunReport(task.key, results, input_errors, run.params.values, finish=last)


def _execute(task: Task, jobs: list[list[str]], run: ResolvedRun, command: str, scheduler: str | None,
             wanted: int, results: list[JobResult], progress: Progress | None) -> None:
    """Run ``jobs`` on the cluster, here, or in up to ``wanted`` worker processes."""
    workers = max(1, min(wanted, len(jobs)))
    if scheduler is None:
        workers = workers_to_start(workers, f"-j {wanted}")
    if scheduler is not None:
        from aldpat.jobs.cluster import run_on_cluster

        run_on_cluster(task, jobs, run, command, scheduler, results, progress)
    elif workers == 1:
        run_in_this_process(task, jobs, run, command, results, progress)
    else:
        run_in_processes(task, jobs, run, command, workers, results, progress)


@contextlib.contextmanager
def _scratch(run: ResolvedRun, sources: list[Path]) -> Iterator[ResolvedRun]:
    """The run with a scratch folder for its passes, in the output folder (beside the first input
    without ``--odir``), removed however the run ends."""
    odir = getattr(run.output.values, "odir", None) if run.output is not None else None
    with scratch_folder(None, Path(odir) if odir else sources[0].parent) as folder:
        yield dataclasses.replace(run, scratch=str(folder))
