"""``aldpat split-tape``: cut an aggregated 9-column ALTM tape into flight strips.

ALDPAT manual (003_*), Task 1 "Split Tape Files into Strips": "Since the laser is turned off
between two adjacent strips, the time interval computed based on t for current and previous
records ... is used to determine the separation of strips. If the time interval is greater than
a given threshold value (i.e., 60 seconds), a new strip file is generated. The output format of
the strip file is the same as the input file."

Streamed chunk by chunk (memory does not grow with the tape); strips are consecutive in time,
so each chunk splits at the positions where t jumps by more than Interval, the last time of a
chunk carrying over to the next. Every strip file is renamed into place only when the whole tape
has been read, so a bad line leaves no partial set of strips.
"""

from __future__ import annotations

import contextlib
import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aldpat.errors import UsageError
from aldpat.params import param
from aldpat.tasks._prep_options import OrderOption
from aldpat.tasks.base import JobContext, Task, register_task

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SplitTapeParams(OrderOption):
    interval: float = param(60.0, "a new strip starts where GPS time jumps by more than this", unit="s", gt=0,
                            manual="Interval")


def strip_starts(t: np.ndarray, previous: float | None, interval: float) -> np.ndarray:
    """Row indices of ``t`` where a new strip starts (0 when the jump from ``previous`` does)."""
    t = np.asarray(t, dtype=np.float64)
    starts = np.flatnonzero(np.diff(t) > interval) + 1
    if len(t) and previous is not None and t[0] - previous > interval:
        starts = np.concatenate([[0], starts])
    return starts


def split_tape_one(source: Path, params: SplitTapeParams, ctx: JobContext) -> None:
    reader = ctx.open_input(source, layout="altm9", order=params.order)
    suffix = ctx.output.suffix if ctx.output is not None and ctx.output.suffix is not None else "_strip"
    probe = ctx.output_path(source, "", reader=reader, use_suffix_option=False)
    if probe.suffix in (".las", ".laz"):
        raise UsageError("strips keep the tape's 9-column text layout; --out-format las/laz does not apply",
                         path=source)

    with contextlib.ExitStack() as stack:
        written: list[tuple[Path, object]] = []
        writer = None
        previous = None

        def open_strip():
            number = len(written) + 1
            out = ctx.output_path(source, f"{suffix}{number:02d}", reader=reader, use_suffix_option=False)
            w = stack.enter_context(ctx.write_points(out, reader.names, like=reader))
            written.append((out, w))
            return w

        for chunk in reader.chunks():
            t = chunk["t"]
            cuts = strip_starts(t, previous, params.interval)
            if writer is None:
                writer = open_strip()
            pos = 0
            for cut in cuts.tolist():
                if cut > pos:
                    writer.write(chunk.take(slice(pos, cut)))
                writer = open_strip()
                pos = cut
            writer.write(chunk.take(slice(pos, len(chunk))))
            previous = float(t[-1])
        # leaving the stack renames every strip into place; only then are they recorded
    for out, w in written:
        ctx.wrote(out, w.count)
    log.info("%s: %d strips", source, len(written))


register_task(Task(
    name="split-tape",
    summary="Split an aggregated 9-column ALTM tape into flight strips where GPS time jumps by more than "
            "the interval (manual task 1).",
    params=SplitTapeParams,
    run_one=split_tape_one,
))
