"""The log every job writes beside its first output: version, command, every resolved parameter
with its source, inputs with sizes, outputs with point counts, warnings and wall time."""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import TYPE_CHECKING

import aldpat
from aldpat.jobs.context import JobResult

if TYPE_CHECKING:
    from aldpat.jobs.resolve import ResolvedRun


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
