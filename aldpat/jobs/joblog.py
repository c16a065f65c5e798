"""The log every job writes beside its first output: version, command, every resolved parameter
with its source, inputs with sizes, outputs with point counts, warnings and wall time.

Every line reads back as itself (file names and messages holding newlines are escaped). The log
is appended to only when it is aldpat's (its first line says so, :data:`MARK`) and never through
a link; when ``<stem>.log`` is the user's own file the log goes to ``<stem>.aldpat.log`` with a
warning (:mod:`aldpat.io.sidefiles`).
"""

from __future__ import annotations

import os
import re
import time
from pathlib import Path

import aldpat
from aldpat.errors import one_line
from aldpat.io.sidefiles import append
from aldpat.jobs.context import JobResult
from aldpat.jobs.resolve import ResolvedRun


def log_path_for(result: JobResult) -> Path:
    """``<output-stem>.log`` beside the (first) output; records are appended to it."""
    first = Path(result.outputs[0].path)
    return first.with_name(first.stem + ".log")


#: the first line of a job log aldpat wrote
MARK = re.compile(rb"\A# aldpat \S+ log, written ")


def write_job_log(run: ResolvedRun, result: JobResult, command: str) -> tuple[Path, str | None]:
    """The per-job log: version, command, every resolved parameter and its source, inputs with
    sizes, outputs with point counts, warnings, wall time. Returns where it went, and a warning
    when that is not ``<stem>.log`` (which is someone else's file)."""
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
    text = "\n".join([lines[0]] + [one_line(line) for line in lines[1:]]) + "\n"
    return append(path, text, MARK)
