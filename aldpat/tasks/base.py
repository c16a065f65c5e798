"""The task registry and the machinery every task shares.

A task is one module in ``aldpat/tasks/`` that declares its parameters once (a frozen dataclass
of :func:`aldpat.params.param` fields) and registers a :class:`Task` with either

* ``run_one(source, params, ctx)`` -- one job per input file, run in parallel with ``-j``; or
* ``run_all(sources, params, ctx)`` -- one job for all inputs (merge, tile, shapefile...).

The job context ``ctx`` (:class:`JobContext`) gives output names, atomic writers and a place to
record outputs and warnings; this module turns that into per-job log files, the exit status and
the process pool. The CLI command and the worksheet job for a task are derived from the same
registration, so adding a task is one module plus its tests.
"""

from __future__ import annotations

import contextlib
import glob
import logging
import os
import sys
import time
import traceback
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import aldpat
from aldpat import interrupt
from aldpat.errors import AldpatError, InputMissingError, UsageError
from aldpat.io.registry import EXTENSIONS, output_extension, write_points
from aldpat.params import (
    Resolved,
    param,
    renamed_keys,
    resolve,
    specs,
    with_current_names,
)

log = logging.getLogger(__name__)


# ---------------------------------------------------------------------------- common options


@dataclass(frozen=True)
class OutputParams:
    """Options every file-writing task shares."""

    odir: str | None = param(None, "output folder, created if missing (default: beside each input)", path=True,
                             metavar="DIR")
    suffix: str | None = param(None, "output name suffix, replacing the task's default")
    delimiter: str = param("space", "delimiter of text outputs", choices=("space", "comma"), manual="Preference")
    out_format: str = param("same", "output format", choices=("same", "text", "csv", "las", "laz"))
    overwrite: bool = param(False, "replace existing outputs")


@dataclass(frozen=True)
class InputParams:
    """How inputs are read."""

    format: str = param("auto", "input format (auto: by extension)", choices=("auto", "text", "las"))


@dataclass(frozen=True)
class RunParams:
    """How the jobs are run (not recorded as task parameters)."""

    jobs: int = param(1, "worker processes (0 = all cores); results identical to -j 1", ge=0)


# ---------------------------------------------------------------------------- the registry


@dataclass(frozen=True)
class Task:
    name: str
    summary: str
    params: type
    run_one: Callable | None = None
    run_all: Callable | None = None
    group: str | None = None  # "filter" for `aldpat filter ALGO`
    inputs: str = "many"  # "many" (at least one) or "none"
    writes_outputs: bool = True
    epilog: str | None = None

    @property
    def key(self) -> str:
        return f"{self.group} {self.name}" if self.group else self.name

    @property
    def option_classes(self) -> tuple[type, ...]:
        """Every params class a command line / worksheet job of this task accepts."""
        common = (InputParams, OutputParams) if self.writes_outputs else (InputParams,)
        return (self.params,) + common + (RunParams,)

    def all_specs(self):
        seen = {}
        for cls in self.option_classes:
            for s in specs(cls):
                seen.setdefault(s.name, s)
        return list(seen.values())

    def __call__(self, inputs: Iterable[str | Path] = (), **kwargs) -> RunReport:
        """Run from Python with the same parameter names as the CLI and worksheets."""
        return run_task(self, list(inputs), [("python", kwargs)])

    def __reduce__(self):
        # A task travels to worker processes by its registry key: its functions may be closures
        # (one per filter algorithm) that pickle cannot carry.
        return (_registered_task, (self.key,))


TASKS: dict[str, Task] = {}


def _registered_task(key: str) -> Task:
    import aldpat.tasks  # noqa: F401  (a spawned worker registers the tasks again)

    return TASKS[key]


def register_task(task: Task) -> Task:
    if task.key in TASKS:
        raise ValueError(f"task {task.key!r} registered twice")
    TASKS[task.key] = task
    return task


def get_task(name: str, algorithm: str | None = None) -> Task:
    import aldpat.tasks  # noqa: F401  (registers every task module)

    key = f"{name} {algorithm}" if algorithm else name
    if key not in TASKS:
        import difflib

        options = sorted(TASKS)
        hint = difflib.get_close_matches(key, options, n=1)
        did = f"; did you mean {hint[0]!r}?" if hint else ""
        raise UsageError(f"unknown task {key!r}{did}")
    return TASKS[key]


# ---------------------------------------------------------------------------- inputs


def _is_point_file(path: Path) -> bool:
    return path.is_file() and path.suffix.lower() in EXTENSIONS


def expand_inputs(items: Iterable[str | Path], base: Path | None = None) -> tuple[list[Path], list[AldpatError]]:
    """Files, quoted globs, folders (their point files) and ``@list.txt`` -> paths, errors.

    Relative items are taken from ``base`` (the worksheet's folder) when given. A pattern that
    matches nothing is an error for that item only; the others are still returned.
    """
    out: list[Path] = []
    errors: list[AldpatError] = []
    for raw in items:
        item = str(raw)
        if item.startswith("@"):
            listfile = _rooted(item[1:], base)
            try:
                lines = listfile.read_text(encoding="utf-8").splitlines()
            except OSError:
                errors.append(InputMissingError("cannot read input list", path=listfile))
                continue
            sub = [ln.strip() for ln in lines if ln.strip() and not ln.lstrip().startswith("#")]
            got, errs = expand_inputs(sub, listfile.parent)
            out += got
            errors += errs
            continue
        path = _rooted(item, base)
        if any(ch in item for ch in "*?["):
            matches = sorted(Path(p) for p in glob.glob(str(path), recursive=True))
            matches = [m for m in matches if m.is_file()]
            if not matches:
                errors.append(InputMissingError("no file matches this pattern", path=item))
            out += matches
        elif path.is_dir():
            files = sorted(p for p in path.iterdir() if _is_point_file(p))
            if not files:
                errors.append(InputMissingError("folder holds no point files", path=path))
            out += files
        elif path.exists():
            out.append(path)
        else:
            errors.append(InputMissingError("no such file", path=path))
    seen: set[Path] = set()
    unique = []
    for p in out:
        key = p.resolve()
        if key not in seen:
            seen.add(key)
            unique.append(p)
    return unique, errors


def _rooted(item: str, base: Path | None) -> Path:
    p = Path(item).expanduser()
    return p if p.is_absolute() or base is None else base / p


# ---------------------------------------------------------------------------- job context


@dataclass
class Written:
    path: str
    count: int | None = None  # points (None for non-point outputs)


@dataclass
class JobResult:
    """What one job did; picklable so it can come back from a worker process."""

    inputs: list[str]
    outputs: list[Written] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)  # values the job derived (written to its log)
    records: list[dict] = field(default_factory=list)  # machine-readable results (info, evaluate)
    error: str | None = None
    usage: bool = False  # the error was a usage error (exit status 2)
    detail: str | None = None  # traceback of an unexpected failure (shown with -v)
    seconds: float = 0.0
    log_path: str | None = None

    @property
    def ok(self) -> bool:
        return self.error is None


class JobContext:
    """Output naming, atomic writing and bookkeeping for one job."""

    def __init__(self, task: Task, output: Any, input_opts: Any, result: JobResult):
        self.task = task
        self.output = output  # OutputParams instance (or None)
        self.input = input_opts
        self.result = result

    # names
    def output_path(self, source: Path, default_suffix: str, ext: str | None = None, *,
                    reader=None, use_suffix_option: bool = True) -> Path:
        """``<odir or source folder>/<stem><suffix><ext>`` (the output place and name of every task)."""
        source = Path(source)
        suffix = default_suffix
        if use_suffix_option and self.output is not None and self.output.suffix is not None:
            suffix = self.output.suffix
        if ext is None:
            ext = output_extension(reader, self.output.out_format if self.output else None) \
                if reader is not None else source.suffix
        folder = self.output_dir(source)
        return folder / f"{source.stem}{suffix}{ext}"

    def output_dir(self, source: Path | None = None) -> Path:
        if self.output is not None and self.output.odir:
            return Path(self.output.odir)
        return Path(source).parent if source is not None else Path.cwd()

    @property
    def overwrite(self) -> bool:
        return bool(self.output is not None and self.output.overwrite)

    @property
    def delimiter(self) -> str:
        return self.output.delimiter if self.output is not None else "space"

    def write_points(self, path: Path, names: tuple[str, ...], *, like=None, **kwargs):
        """An atomic point writer honouring ``--overwrite`` and ``--delimiter``."""
        return write_points(path, names, overwrite=self.overwrite, like=like, delimiter=self.delimiter, **kwargs)

    def open_input(self, path: Path, **kwargs):
        from aldpat.io.registry import open_points

        fmt = self.input.format if self.input is not None else None
        return open_points(path, format=fmt, **kwargs)

    # bookkeeping
    def wrote(self, path: Path, count: int | None = None) -> None:
        self.result.outputs.append(Written(str(path), count))

    def warn(self, message: str) -> None:
        """A warning for the log file and stderr (reported once the job ends, in input order)."""
        self.result.warnings.append(message)

    def note(self, message: str) -> None:
        """A value the job derived from its data (``--auto``), recorded in the job log."""
        self.result.notes.append(message)
        log.info(message)

    def emit(self, record: dict) -> None:
        self.result.records.append(record)


# ---------------------------------------------------------------------------- running


@dataclass
class ResolvedRun:
    task: Task
    params: Resolved  # the task's own parameters
    output: Resolved | None
    input: Resolved
    run: Resolved

    def record(self) -> list[tuple[str, str, str]]:
        rows = self.params.record()
        for part in (self.input, self.output):
            if part is not None:
                rows += part.record()
        return rows


def resolve_run(task: Task, layers: Sequence[tuple[str, Mapping[str, Any]]], where: str = "") -> ResolvedRun:
    """Split raw values among the task's params classes, validating each (unknown keys -> error)."""
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
    return ResolvedRun(task, parts[task.params], parts.get(OutputParams), parts[InputParams], parts[RunParams])


@dataclass
class RunReport:
    task: str
    results: list[JobResult]
    input_errors: list[str]

    @property
    def failed(self) -> int:
        return sum(not r.ok for r in self.results) + len(self.input_errors)

    @property
    def exit_code(self) -> int:
        if any(r.usage for r in self.results):
            return 2
        return 1 if self.failed else 0

    @property
    def outputs(self) -> list[Written]:
        return [w for r in self.results for w in r.outputs]


def _execute(task_key: str, sources: list[str], run: ResolvedRun, command: str) -> JobResult:
    """Run one job (in this process or a worker) and write its log; never raises."""
    import aldpat.tasks  # noqa: F401  (a spawned worker registers the tasks again)

    task = TASKS[task_key]
    result = JobResult(inputs=list(sources))
    ctx = JobContext(task, run.output.values if run.output else None, run.input.values, result)
    start = time.perf_counter()
    try:
        with interrupt.doing(f"running: {_names(sources)}"):
            if task.run_one is not None:
                task.run_one(Path(sources[0]), run.params.values, ctx)
            else:
                assert task.run_all is not None  # a task has one of the two
                task.run_all([Path(s) for s in sources], run.params.values, ctx)
    except AldpatError as exc:
        result.error = str(exc)
        result.usage = isinstance(exc, UsageError)
    except MemoryError:
        result.error = f"{_names(sources)}: out of memory"
    except OSError as exc:  # the system refused a read or write: say which file and why
        where = exc.filename if exc.filename is not None else _names(sources)
        result.error = f"{where}: {(exc.strerror or str(exc)).lower()}"
        result.detail = traceback.format_exc()
    except Exception as exc:  # noqa: BLE001  (an unexpected failure still may not end the other jobs)
        result.error = f"{_names(sources)}: internal error: {type(exc).__name__}: {exc}"
        result.detail = traceback.format_exc()
    result.seconds = time.perf_counter() - start
    if result.ok and result.outputs and task.writes_outputs:
        try:
            result.log_path = str(write_job_log(run, result, command))
        except OSError as exc:
            result.warnings.append(f"could not write the log: {exc}")
    return result


def _execute_in_worker(task_key: str, sources: list[str], run: ResolvedRun, command: str) -> JobResult:
    """:func:`_execute` in a pool worker. Interrupted (SIGTERM from the parent, or from the kernel
    when the parent died), the worker exits as soon as the job's writers have removed their
    temporary files, without sending anything back: the queues it shares with the other workers
    may be held by a worker that was ended the same way."""
    try:
        return _execute(task_key, sources, run, command)
    except interrupt.Interrupted as exc:
        os._exit(128 + exc.signum)


def log_path_for(result: JobResult) -> Path:
    """``<output-stem>.log`` beside the (first) output; records are appended to it."""
    first = Path(result.outputs[0].path)
    return first.with_name(first.stem + ".log")


def write_job_log(run: ResolvedRun, result: JobResult, command: str) -> Path:
    """The per-job log: version, command, every resolved parameter and its source, inputs with
    sizes, outputs with point counts, warnings, wall time."""
    path = log_path_for(result)
    lines = [
        f"# aldpat {aldpat.__version__} log, written {time.strftime('%Y-%m-%d %H:%M:%S')}",
        f"command: {command}",
        f"task: {run.task.key}",
        "parameters:",
    ]
    width = max((len(n) for n, _, _ in run.record()), default=0)
    lines += [f"  {n.ljust(width)} = {v}    ({src})" for n, v, src in run.record()]
    lines.append("inputs:")
    for src in result.inputs:
        try:
            size = os.path.getsize(src)
        except OSError:
            size = -1
        lines.append(f"  {src}  ({size} bytes)")
    lines.append("outputs:")
    for w in result.outputs:
        lines.append(f"  {w.path}" + (f"  ({w.count} points)" if w.count is not None else ""))
    if result.notes:
        lines.append("derived from the data:")
        lines += [f"  {n}" for n in result.notes]
    if result.warnings:
        lines.append("warnings:")
        lines += [f"  {w}" for w in result.warnings]
    lines.append(f"wall time: {result.seconds:.3f} s")
    # Appended, never replaced: another task may have written outputs with the same stem (grid
    # writes x.grd, grd2bin x.flt beside it), and a re-run's record belongs after the first.
    with open(path, "a", encoding="utf-8") as fh:
        fh.write(("\n" if fh.tell() else "") + "\n".join(lines) + "\n")
    return path


def plan_jobs(task: Task, sources: list[Path]) -> list[list[str]]:
    if task.run_one is not None:
        return [[str(s)] for s in sources]
    return [[str(s) for s in sources]]


def run_task(task: Task, inputs: Sequence[str | Path], layers: Sequence[tuple[str, Mapping[str, Any]]], *,
             command: str | None = None, base: Path | None = None, progress=None,
             resolved: ResolvedRun | None = None) -> RunReport:
    """Expand inputs, resolve parameters, run the jobs (in a pool with ``jobs`` > 1)."""
    run = resolved or resolve_run(task, layers)
    command = command or f"aldpat {task.key} " + " ".join(map(str, inputs))
    sources, errors = expand_inputs(inputs, base) if task.inputs != "none" else ([], [])
    input_errors = [str(e) for e in errors]
    for e in input_errors:
        log.error(e)
    if task.inputs == "many" and not sources:
        if not input_errors:
            raise UsageError("no inputs given")
        return RunReport(task.key, [], input_errors)
    jobs = plan_jobs(task, sources) if task.inputs != "none" else [[]]
    workers = run.run.values.jobs or (os.cpu_count() or 1)
    workers = max(1, min(workers, len(jobs)))
    results: list[JobResult] = []
    if workers == 1:
        for job in jobs:
            with interrupt.doing(f"{task.key} ({len(results)} of {len(jobs)} inputs done)"):
                results.append(_execute(task.key, job, run, command))
            _report(results[-1], progress)
    else:
        _run_in_pool(task, jobs, run, command, workers, results, progress)
    return RunReport(task.key, results, input_errors)


def _names(job: list[str]) -> str:
    text = ", ".join(job)
    return text if len(text) <= 200 else text[:197] + "..."


def _run_in_pool(task: Task, jobs: list[list[str]], run: ResolvedRun, command: str, workers: int,
                 results: list[JobResult], progress) -> None:
    """Run ``jobs`` in ``workers`` processes, collecting results in input order.

    On an interruption the queued jobs are cancelled and the running ones are ended with
    SIGTERM, which each worker turns into a clean exit that removes its temporary files.
    """
    import multiprocessing

    ctx = multiprocessing.get_context("spawn" if sys.platform == "darwin" else "fork")
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=interrupt.install_in_worker)
    try:
        futures = [pool.submit(_execute_in_worker, task.key, job, run, command) for job in jobs]
        for job, fut in zip(jobs, futures):  # in input order, so output and logs do not depend on -j
            def state(done: int = len(results)) -> str:
                running = [_names(j) for j, f in zip(jobs, futures) if f.running()]
                return f"{task.key} ({done} of {len(jobs)} inputs done; running: {'; '.join(running)})"

            with interrupt.doing(state):
                try:
                    results.append(fut.result())
                except Exception as exc:  # noqa: BLE001  (a worker died, killed or out of memory: that job failed)
                    results.append(JobResult(inputs=job, error=f"{_names(job)}: worker process "
                                                               f"failed: {type(exc).__name__}: {exc}"))
            _report(results[-1], progress)
    except BaseException:
        processes = list(getattr(pool, "_processes", {}).values())
        pool.shutdown(wait=False, cancel_futures=True)
        for p in processes:
            with contextlib.suppress(Exception):
                p.terminate()  # SIGTERM: the worker removes its temporary files and exits
        for p in processes:
            with contextlib.suppress(Exception):
                p.join(timeout=30)
        raise
    pool.shutdown(wait=True)


def _report(result: JobResult, progress) -> None:
    for w in result.warnings:
        log.warning(w)
    if not result.ok:
        log.error(result.error)
        if result.detail:
            log.debug(result.detail)
    if progress is not None:
        progress(result)


__all__ = [
    "TASKS",
    "InputParams",
    "JobContext",
    "JobResult",
    "OutputParams",
    "RunParams",
    "RunReport",
    "Task",
    "expand_inputs",
    "get_task",
    "register_task",
    "resolve_run",
    "run_task",
]
