"""Running a validated worksheet: ALDPAT's Work Sheet, from a shell.

Jobs run in order; each goes Ready -> Running -> Done or Failed (message kept). A failed job
stops the later jobs that read its outputs (they are Blocked), not the others.

Resume: after each job the runner records a fingerprint of what it ran (task, every resolved
parameter, each input's path, size and modification time) and of what it wrote (each output's
size and modification time) in ``<worksheet-stem>.state.json``, written atomically. ``--resume``
skips a job whose fingerprint and outputs are unchanged. A job that was started but never
recorded as finished (the run was killed) runs again and may replace the outputs it had already
renamed into place -- they are its own, as long as the job is the one that was killed (the same
fingerprint) and none of its outputs was there before that run started; temporary files and
scratch folders of writers no longer running are removed before every job. Because every output
is renamed into place only when complete, a run killed at any instant and resumed ends with the
same outputs as an uninterrupted one. A job that changed (an input made anew upstream) runs
again and replaces the outputs the last runs recorded for the worksheet, unchanged since, as
``make`` does -- and so does every job of a run without ``--resume``, which runs them all; never
another file without ``--overwrite``. A failed job records the outputs it did write (its inputs
that went through), which are its own to replace when it runs again, and a run keeps the records
of the jobs it does not run. Jobs are found in the state by
number, and by fingerprint when a job inserted or removed has renumbered them.

One run per worksheet at a time (:mod:`aldpat.worksheet.lock`). The state, the log and the
report are aldpat's own files beside the worksheet: one of the user's under such a name is
never replaced (:mod:`aldpat.io.sidefiles`), and the log of the previous run is kept as
``<worksheet-stem>.log.1`` (up to ``.log.5``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import logging
import os
import re
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import aldpat
from aldpat import interrupt
from aldpat.errors import one_line
from aldpat.io.atomic import atomic_output, remove_stale_temporaries_in
from aldpat.io.sidefiles import own_place, rotate
from aldpat.jobs.context import JobResult
from aldpat.jobs.execute import Progress
from aldpat.jobs.inputs import expand_inputs
from aldpat.jobs.resolve import ResolvedRun, resolve_run
from aldpat.jobs.run import run_task
from aldpat.worksheet.lock import WorksheetLock
from aldpat.worksheet.model import Job, Worksheet

READY, RUNNING, DONE, FAILED, SKIPPED, BLOCKED = "Ready", "Running", "Done", "Failed", "Skipped", "Blocked"

log = logging.getLogger(__name__)

#: what the run state (job number -> its entry) and the worksheet log aldpat wrote begin with
STATE_MARK = re.compile(rb'\A\{\s*(\}\s*\Z|"\d+": \{\s*"status": ")')
LOG_MARK = re.compile(rb"\A# aldpat \S+ worksheet log, written ")


@dataclass
class JobStatus:
    job: Job
    state: str = READY
    message: str = ""
    seconds: float = 0.0
    results: list[JobResult] = dataclasses.field(default_factory=list)
    outputs: list[str] = dataclasses.field(default_factory=list)


def state_path(ws: Worksheet) -> Path:
    """``<worksheet-stem>.state.json``, or aldpat's other name for it when that is the user's."""
    return own_place(ws.path.with_name(ws.path.stem + ".state.json"), STATE_MARK)[0]


def log_path(ws: Worksheet) -> Path:
    """``<worksheet-stem>.log``, or aldpat's other name for it when that is the user's."""
    return own_place(ws.path.with_name(ws.path.stem + ".log"), LOG_MARK)[0]


def _say_where_side_files_go(ws: Worksheet) -> None:
    for name, mark in ((".state.json", STATE_MARK), (".log", LOG_MARK)):
        _, warning = own_place(ws.path.with_name(ws.path.stem + name), mark)
        if warning:
            log.warning(warning)


def _file_sig(path: str | Path) -> list:
    st = os.stat(path)
    return [str(Path(path).resolve()), st.st_size, st.st_mtime_ns]


def fingerprint(job: Job) -> str:
    """What the job would run: task, resolved parameters and the current inputs."""
    sources, _ = expand_inputs(job.inputs)
    payload = {
        "task": job.task.key,
        "params": [(n, v) for n, v, _ in job.run.record() if n not in ("overwrite",)],
        "inputs": [_file_sig(p) for p in sources],
    }
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()


def _load_state(ws: Worksheet) -> dict:
    try:
        state = json.loads(state_path(ws).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return state if isinstance(state, dict) else {}


def _save_state(ws: Worksheet, state: dict) -> None:
    with atomic_output(state_path(ws), overwrite=True) as tmp:
        tmp.write_text(json.dumps(state, indent=1), encoding="utf-8")


def _unchanged(entry: dict | None, job: Job) -> bool:
    if not entry or entry.get("status") != DONE or entry.get("fingerprint") != fingerprint(job):
        return False
    for sig in entry.get("outputs", []):
        try:
            if _file_sig(sig[0]) != sig:
                return False
        except OSError:
            return False
    return True


def _existing_outputs(job: Job, run: ResolvedRun) -> list[str]:
    """The outputs of ``job`` known by name that exist as it starts, when it may not replace them:
    should the run be killed, they are not its own to replace when it is resumed."""
    parts = (run.params, run.output)
    if any(getattr(part.values, "overwrite", False) for part in parts if part is not None):
        return []
    return [str(out.path) for out in job.planned if not out.family and os.path.lexists(out.path)]


def _outputs_are_its_own(entry: dict, job: Job) -> bool:
    """Whether a job recorded as Running (its run was killed) may replace the outputs it finds when
    it runs again: only when it is the job that was killed -- the worksheet edited meanwhile may
    point it at a folder of someone else's files -- and none of its outputs existed before that
    run started (those were refused then, and are not its own)."""
    if entry.get("fingerprint") != fingerprint(job):
        return False
    existed = entry.get("existed", [])
    return not (isinstance(existed, list) and any(os.path.lexists(str(p)) for p in existed))


def _finished_as(job: Job, entry: dict | None, done_before: dict[str, dict]) -> dict | None:
    """The state entry of the last run saying ``job`` finished, unchanged since: the one under its
    number, or else one under another number with its fingerprint -- a job inserted before it, or
    one removed, renumbers the jobs after it, which are not changed by that and are not run again
    (they would find their own outputs and fail, and block what reads them)."""
    if entry is not None and _unchanged(entry, job):
        return entry
    other = done_before.get(fingerprint(job))
    return other if other is not None and _unchanged(other, job) else None


def _written(entries: Iterable[dict]) -> dict[str, list]:
    """The outputs the jobs of the last runs wrote, as recorded when each finished: path -> its
    signature then (path, size, modification time)."""
    out: dict[str, list] = {}
    for entry in entries:
        for sig in entry.get("outputs", []):
            if isinstance(sig, list) and len(sig) == 3 and isinstance(sig[0], str):
                out[sig[0]] = sig
    return out


def _replaces_only_its_last_outputs(job: Job, written: dict[str, list]) -> bool:
    """Whether every output of ``job`` that exists is one the worksheet's last runs wrote and that
    nothing changed since (its size and time as recorded): a job run again by ``--resume``
    because its inputs or parameters changed -- an upstream job made its inputs anew -- then
    replaces what it made itself, as ``make`` does, instead of failing on it ("output exists")
    and blocking what reads it. A file of anyone else's, or one changed since, is never replaced
    without ``--overwrite``. True only when there is something to replace."""
    found = False
    for out in job.planned:
        paths = ([p for p in out.path.parent.glob(out.path.name) if out.matches(p)]
                 if out.family and out.path.parent.is_dir() else [out.path])
        for path in paths:
            if not os.path.lexists(path):
                continue
            sig = written.get(str(Path(path).resolve()))
            try:
                if sig is None or os.path.islink(path) or _file_sig(path) != sig:
                    return False
            except OSError:
                return False
            found = True
    return found


def _still_its_own(job: Job, written: dict[str, list], rewritten: set[str]) -> list[list]:
    """The records of the outputs of ``job`` the last runs wrote that are as they were then and
    that this run did not write again: a run of the job that failed before writing them (one of
    its outputs changed by hand) leaves them the worksheet's own."""
    kept = []
    for path, sig in written.items():
        if path in rewritten or not any(out.matches(path) or (not out.family and str(out.path.resolve()) == path)
                                        for out in job.planned):
            continue
        try:
            if _file_sig(path) == sig:
                kept.append(sig)
        except OSError:
            continue
    return kept


def _remove_stray_temporaries(job: Job) -> None:
    """Temporaries and scratch folders of writers no longer running, where the job writes and
    where its chunks spill (``tmpdir``)."""
    tmpdir = getattr(job.run.params.values, "tmpdir", None)
    for place in [*job.output_places(), *([Path(tmpdir)] if tmpdir else [])]:
        if place.is_dir():
            remove_stale_temporaries_in(place)


def run_worksheet(ws: Worksheet, *, only: set[int] | None = None, resume: bool = False, jobs: int | None = None,
                  on_status: Callable[[JobStatus], None] | None = None,
                  command: str = "aldpat run",
                  progress: Callable[[Job], contextlib.AbstractContextManager[Progress | None]] | None = None) -> list[JobStatus]:
    """Run the jobs of ``ws`` in order; return their final statuses (and write state and log).
    ``progress(job)`` opens what shows each job's progress while it runs (its inputs and chunks).
    Holds the worksheet's lock meanwhile: a second run of it is refused
    (:class:`~aldpat.worksheet.lock.WorksheetBusy`)."""
    with WorksheetLock(ws.path, command):
        return _run_jobs(ws, only=only, resume=resume, jobs=jobs, on_status=on_status, command=command,
                         progress=progress)


def _run_jobs(ws: Worksheet, *, only: set[int] | None, resume: bool, jobs: int | None,
              on_status: Callable[[JobStatus], None] | None, command: str,
              progress: Callable[[Job], contextlib.AbstractContextManager[Progress | None]] | None) -> list[JobStatus]:
    statuses = [JobStatus(job) for job in ws.jobs]
    _say_where_side_files_go(ws)
    rotate(log_path(ws), LOG_MARK)  # the last run's log is kept as .log.1
    # the last runs' records are read whether or not this run resumes: what they wrote is the
    # worksheet's own to replace, and the records of the jobs this run does not run are kept (a
    # plain run that failed had deleted them, and with them every later --resume)
    state = _load_state(ws)
    done_before = {e["fingerprint"]: e for e in state.values()
                   if isinstance(e, dict) and e.get("status") == DONE and isinstance(e.get("fingerprint"), str)}
    written_before = _written(e for e in state.values() if isinstance(e, dict))
    killed_before = {e["fingerprint"]: e for e in state.values()
                     if isinstance(e, dict) and e.get("status") == RUNNING and isinstance(e.get("fingerprint"), str)}
    by_number = {s.job.number: s for s in statuses}
    for status in statuses:
        job = status.job
        if only and job.number not in only:
            status.state, status.message = SKIPPED, "not selected (--only)"
            _notify(on_status, status)
            continue
        blockers = [n for n in sorted(job.depends_on) if by_number[n].state in (FAILED, BLOCKED)]
        if blockers:
            status.state = BLOCKED
            status.message = "reads the outputs of failed job " + ", ".join(map(str, blockers))
            _notify(on_status, status)
            continue
        entry = state.get(str(job.number))
        finished = _finished_as(job, entry, done_before) if resume else None
        if finished is not None:
            status.state, status.message = SKIPPED, "unchanged since it last finished (--resume)"
            status.outputs = [sig[0] for sig in finished.get("outputs", [])]
            state[str(job.number)] = finished
            _notify(on_status, status)
            continue
        if entry is None or entry.get("status") != RUNNING:  # killed under another number?
            entry = killed_before.get(fingerprint(job), entry)
        rerun_after_kill = entry is not None and entry.get("status") == RUNNING
        replaces_its_own = _replaces_only_its_last_outputs(job, written_before)
        if rerun_after_kill and entry is not None and not _outputs_are_its_own(entry, job):
            rerun_after_kill = False
            if not replaces_its_own:
                log.warning(f"{job.label}: the job killed in the last run was another (the worksheet, its parameters "
                            "or its inputs changed since) or found outputs already there; it runs again without "
                            f"replacing what exists (--set job.{job.number}.overwrite=true replaces it)")
        run = job.run
        layers_override: dict[str, object] = {}
        _remove_stray_temporaries(job)  # a killed run's temporaries and scratch, of this job or any
        if rerun_after_kill or replaces_its_own:
            layers_override["overwrite"] = True
        if jobs is not None:
            layers_override["jobs"] = jobs
        if layers_override:
            run = _with_overrides(job, layers_override)
        status.state = RUNNING
        _notify(on_status, status)
        state[str(job.number)] = {"status": RUNNING, "fingerprint": fingerprint(job),
                                  "existed": _existing_outputs(job, run)}
        _save_state(ws, state)
        start = time.perf_counter()
        try:
            with interrupt.doing(f"worksheet job {job.number} ({job.task.key})"), \
                    (progress(job) if progress is not None else contextlib.nullcontext()) as bar:
                report = run_task(job.task, job.inputs, [], resolved=run,
                                  command=f"{command}  # job {job.number}", progress=bar)
        except aldpat.errors.AldpatError as exc:
            status.state, status.message = FAILED, str(exc)
            report = None
        status.seconds = time.perf_counter() - start
        if report is not None:
            status.results = report.results
            status.outputs = [w.path for w in report.outputs]
            problems = report.input_errors + [str(r.error) for r in report.results if not r.ok]
            if problems:
                status.state = FAILED
                status.message = problems[0] + (f" (and {len(problems) - 1} more)" if len(problems) > 1 else "")
            else:
                status.state = DONE
                status.message = f"{len(status.outputs)} outputs" if job.task.writes_outputs else ""
        if status.state == DONE:
            state[str(job.number)] = {
                "status": DONE, "fingerprint": fingerprint(job),
                "outputs": [_file_sig(p) for p in status.outputs if os.path.exists(p)],
            }
        else:  # what it did write, and what it wrote before and is unchanged, is its own to replace
            made = [_file_sig(p) for p in status.outputs if os.path.exists(p)]
            state[str(job.number)] = {"status": FAILED, "message": status.message, "fingerprint": fingerprint(job),
                                      "outputs": made + _still_its_own(job, written_before, {sig[0] for sig in made})}
        _save_state(ws, state)
        write_worksheet_log(ws, statuses, command)
        _notify(on_status, status)
    _save_state(ws, state)  # the jobs skipped under other numbers than the last run's are found under theirs next time
    write_worksheet_log(ws, statuses, command)
    return statuses


def _with_overrides(job: Job, values: dict) -> ResolvedRun:
    base = [(src, {n: getattr(part.values, n)}) for part in (job.run.params, job.run.input, job.run.output, job.run.run)
            if part is not None for n, src in part.sources.items()]
    layers = [(src, m) for src, m in base] + [("runner", values)]
    return dataclasses.replace(resolve_run(job.task, layers), params_files=job.run.params_files)


def _notify(cb: Callable[[JobStatus], None] | None, status: JobStatus) -> None:
    if cb is not None:
        cb(status)


# ------------------------------------------------------------------------------ the run log


def _toml_value(value: object) -> str:
    if value is None:
        return '"none"'
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    return toml_string(str(value))


#: TOML basic-string escapes: the quote, the backslash and every control character
_TOML_ESCAPES = {c: f"\\u{c:04X}" for c in (*range(0x20), 0x7F)}
_TOML_ESCAPES.update({0x22: '\\"', 0x5C: "\\\\", 0x08: "\\b", 0x09: "\\t", 0x0A: "\\n", 0x0C: "\\f",
                      0x0D: "\\r"})


def toml_string(text: str) -> str:
    """``text`` as a TOML basic string that reads back as exactly ``text``: a file name holding a
    quote or a newline stays one value. A lone surrogate (a file name's byte that is not UTF-8)
    cannot be written in TOML at all; it becomes U+FFFD."""
    if _has_surrogate(text):
        try:
            text = text.encode("utf-8", "surrogateescape").decode("utf-8", "replace")
        except UnicodeEncodeError:
            text = text.encode("utf-8", "replace").decode("utf-8")
    return '"' + text.translate(_TOML_ESCAPES) + '"'


def _has_surrogate(text: str) -> bool:
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return True
    return False


def _comment(text: object) -> str:
    """A comment's text on one line: a message or a path holding a newline cannot start a
    ``[[job]]`` of its own in the replayable log."""
    return one_line(text)


def job_table(job: Job) -> list[str]:
    """A ``[[job]]`` table that replays exactly this job (every resolved parameter spelled out)."""
    lines = ["[[job]]", f"task = {_toml_value(job.task.name if job.task.group is None else job.task.group)}"]
    if job.task.group == "filter":
        lines.append(f"algorithm = {_toml_value(job.task.name)}")
    lines.append(f"inputs = {_toml_value(job.inputs)}")
    for part in (job.run.params, job.run.input, job.run.output):
        if part is None:
            continue
        for name, src in part.sources.items():
            value = getattr(part.values, name)
            if value is None:
                continue  # an unset optional: leaving it out replays the same way
            lines.append(f"{name} = {_toml_value(value)}    # {_comment(src)}")
    return lines


def write_worksheet_log(ws: Worksheet, statuses: list[JobStatus], command: str) -> Path:
    """``<worksheet-stem>.log``: a TOML worksheet that replays the run, with statuses as comments."""
    out: list[str] = [
        f"# aldpat {aldpat.__version__} worksheet log, written {time.strftime('%Y-%m-%d %H:%M:%S')}",
        f"# command: {_comment(command)}",
        f"# worksheet: {_comment(ws.path)}",
        "# Every job below is spelled out with every resolved parameter (its source in the comment);",
        "# run this file with `aldpat run` to replay the run.",
        "",
    ]
    for st in statuses:
        out.append(f"# job {st.job.number}: {st.state}" + (f" -- {_comment(st.message)}" if st.message else "")
                   + (f" ({st.seconds:.2f} s)" if st.state in (DONE, FAILED) else ""))
        for path in st.outputs:
            out.append(f"#   wrote {_comment(path)}")
        out += job_table(st.job)
        out.append("")
    log_file = log_path(ws)
    with atomic_output(log_file, overwrite=True) as tmp:
        tmp.write_text("\n".join(out), encoding="utf-8")
    return log_file


__all__ = [
    "BLOCKED",
    "DONE",
    "FAILED",
    "READY",
    "RUNNING",
    "SKIPPED",
    "JobStatus",
    "run_worksheet",
    "write_worksheet_log",
]
