"""One job: run the task's function on its inputs, turn every failure into a one-line error
of that job (the other jobs go on), write the job's log."""

from __future__ import annotations

import logging
import os
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Protocol

from aldpat import interrupt
from aldpat.core.crs import WITHOUT_CRS
from aldpat.errors import AldpatError, OutputExistsError, UnstorableValue, UsageError
from aldpat.io.atomic import forget_temporaries
from aldpat.jobs.context import JobContext, JobResult
from aldpat.jobs.joblog import write_job_log
from aldpat.jobs.resolve import ResolvedRun
from aldpat.jobs.task import Planned, Task

log = logging.getLogger(__name__)


def execute(task: Task, sources: list[str], run: ResolvedRun, command: str) -> JobResult:
    """Run one job (in this process or a worker) and write its log; never raises. ``task``
    reaches a worker by its registry key (:meth:`Task.__reduce__`)."""
    def body(ctx: JobContext) -> None:
        forget_temporaries()
        planned = ctx.planned([Path(s) for s in sources])  # what the job may write (JobContext.wrote holds to it)
        run_one = task.first_pass if run.stage == "first" else task.run_one
        # a tile's job also reads its neighbours: their outputs are theirs. A first pass writes
        # only scratch files its neighbours read: it runs whether or not its tile's output exists
        # (a rerun of dtm over tiles, some made, found every missing one's neighbours "failed")
        if task.writes_outputs and not ctx.overwrite and run.stage != "first":
            refuse_existing([p for p in planned if run_one is None or p.source == Path(sources[0])])
        if run_one is not None:
            ctx.neighbours = [Path(s) for s in sources[1:]]  # a planned job's other inputs
            run_one(Path(sources[0]), run.params.values, ctx)
        else:
            assert task.run_all is not None  # a task has one of the two
            task.run_all([Path(s) for s in sources], run.params.values, ctx)

    return _guarded(task, sources, run, command, body)


def refuse_existing(planned: list[Planned]) -> None:
    """Refuse a job whose named outputs exist before it reads anything: without ``--overwrite``
    the writer would refuse them anyway, but only after the work (a ``dtm`` of a big file, a
    filter's passes) and after the job's warnings about an output it will not write. Families
    (split-tape's strips, tile's tiles) are checked by their writers; so is tile's parameter
    file, which ``--append`` extends. A mosaic, written once the jobs are done, is refused by the
    run before its jobs start (:func:`aldpat.jobs.run.run_task`)."""
    for p in planned:
        if (p.source is not None or p.named_by in ("output", "mosaic")) and not p.family and os.path.lexists(p.path):
            raise OutputExistsError("output exists (use --overwrite to replace it)", path=p.path)


def execute_finish(task: Task, results: list[JobResult], run: ResolvedRun, command: str) -> JobResult:
    """The task's ``finish`` step, once every job has run (``grid --mosaic``); never raises.
    Its inputs are the outputs of the jobs."""
    assert task.finish is not None
    finish = task.finish
    done = [w.path for r in results for w in r.outputs]
    return _guarded(task, done, run, command, lambda ctx: finish(results, run.params.values, ctx))


def _guarded(task: Task, sources: list[str], run: ResolvedRun, command: str,
             body: Callable[[JobContext], None]) -> JobResult:
    result = JobResult(inputs=list(sources))
    ctx = JobContext(task, run.output.values if run.output else None, run.input.values if run.input else None,
                     result, run.params.values)
    ctx.workers = run.chunk_workers
    ctx.scratch = Path(run.scratch) if run.scratch is not None else None
    start = time.perf_counter()
    try:
        with interrupt.doing(f"running: {job_names(sources)}"):
            try:
                body(ctx)
            except Exception:
                interrupt.reraise_if_stopping()  # an interrupt a library reported as its own error
                raise
    except OutputExistsError as exc:
        named = exc.path is not None and exc.path.startswith(tuple(ctx.named_after_inputs))
        result.error = str(exc.named_after_input() if named else exc)
        result.existed = True
    except AldpatError as exc:
        if isinstance(exc, UnstorableValue) and exc.path is None:
            _find_the_line(exc, sources)
        # a message names its file: the job's inputs when the step that refused did not know them
        result.error = str(exc) if exc.path is not None or not sources else f"{job_names(sources)}: {exc}"
        result.usage = isinstance(exc, UsageError)
    except MemoryError:
        result.error = f"{job_names(sources)}: out of memory (a larger cell, --chunk, or tiles need less)"
    except OSError as exc:  # the system refused a read or write: say which file and why
        where = exc.filename if exc.filename is not None else job_names(sources)
        result.error = f"{where}: {(exc.strerror or str(exc)).lower()}"
        result.detail = traceback.format_exc()
    except Exception as exc:  # noqa: BLE001  (an unexpected failure still may not end the other jobs)
        result.error = f"{job_names(sources)}: internal error: {type(exc).__name__}: {exc}"
        result.detail = traceback.format_exc()
    result.seconds = time.perf_counter() - start
    if not result.ok:  # said before the job wrote its outputs, which it now does not write
        result.warnings = [w for w in result.warnings if not w.endswith(WITHOUT_CRS)]
    if result.ok and result.outputs and task.writes_outputs:
        try:
            where, warning = write_job_log(run, result, command)
            result.log_path = str(where)
            if warning:
                result.warnings.append(warning)
        except OSError as exc:
            result.warnings.append(f"could not write the log: {exc}")
    return result


def _find_the_line(exc: UnstorableValue, sources: list[str]) -> None:
    """Name in ``exc`` the first text input line holding its value, where one of ``sources`` does:
    the bad line of a 50 GB file is told, not only the file."""
    from aldpat.io.registry import detect_format
    from aldpat.io.text import TextReader

    for source in sources:
        try:
            if detect_format(Path(source)) != "text":
                continue
            line = TextReader(source).line_holding(exc.column, exc.value)
        except (AldpatError, OSError):
            continue  # the message stands as it is
        if line is not None:
            exc.path, exc.line = source, line
            return


def doing(task: Task, run: ResolvedRun, done: int, total: int, more: str = "") -> str:
    """What a run is doing, for the line an interruption prints: its jobs done (``more`` after
    them), or -- in a first pass (``dtm`` over tiles: every tile's ground classes, which write no
    output) -- that pass's. An interrupted first pass said "4 of 16 inputs done" of a folder
    still empty."""
    if run.stage == "first":
        return f"{task.key}, first pass ({done} of {total} inputs' ground classes found, no output written yet{more})"
    return f"{task.key} ({done} of {total} inputs done{more})"


def job_names(job: list[str]) -> str:
    text = ", ".join(job)
    return text if len(text) <= 200 else text[:197] + "..."


def job_name(task: Task, job: list[str]) -> str:
    """What a message calls a job: the input it makes its output of. A ``run_one`` task's job
    lists the other inputs it reads after its own (``dtm``'s neighbours within its buffer: over
    overlapping strips every other input), which are not what it makes; a ``run_all`` job is
    all of its inputs."""
    return job[0] if task.run_one is not None and job else job_names(job)


class Progress(Protocol):
    """What shows a run's progress: the jobs planned, each job's result, and the units of work
    inside the jobs (their chunks, :mod:`aldpat.core.units`)."""

    def started(self, jobs: int) -> None: ...

    def job_done(self, result: JobResult) -> None: ...

    def units(self, kind: str, n: int, name: str = "") -> None: ...


def report_result(result: JobResult, progress: Progress | None) -> None:
    for w in result.warnings:
        log.warning(w)
    if not result.ok:
        log.error(result.error)
        if result.detail:
            log.debug(result.detail)
    if progress is not None:
        progress.job_done(result)
