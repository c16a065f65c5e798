"""``aldpat split-tape``: cut an aggregated 9-column ALTM tape into flight strips.

ALDPAT 1.0 user manual (2007), Task 1 "Split Tape Files into Strips": "Since the laser is turned off
between two adjacent strips, the time interval computed based on t for current and previous
records ... is used to determine the separation of strips. If the time interval is greater than
a given threshold value (i.e., 60 seconds), a new strip file is generated. The output format of
the strip file is the same as the input file."

Records are copied byte for byte (:mod:`aldpat.io.rawtext`) unless ``--delimiter`` asks for
another delimiter than the tape's, in which case they are written again with the tape's decimals.
Streamed chunk by chunk (memory does not grow with the tape); strips are consecutive in time,
so each chunk splits at the positions where t jumps by more than Interval, the last time of a
chunk carrying over to the next, and one strip file is open at a time. Every strip file is renamed into place only when the whole tape
has been read, so a bad line leaves no partial set of strips.
"""

from __future__ import annotations

import contextlib
import logging
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aldpat.core.precision import above
from aldpat.errors import DataError, UsageError
from aldpat.io.atomic import atomic_output, glob_escape
from aldpat.io.rawtext import RawLines, passthrough_ok
from aldpat.jobs.context import JobContext
from aldpat.jobs.registry import register_task
from aldpat.jobs.task import Planned, Task
from aldpat.options import OrderOption
from aldpat.params import param

log = logging.getLogger(__name__)

#: The most strips one tape is split into. A flight has tens of strips; an interval below the
#: pulse spacing (``--interval 1e-9``, seconds taken for milliseconds) made a strip of every
#: shot, millions of files held open as temporaries until the tape was read, until the disk's
#: inodes ran out.
MOST_STRIPS = 10_000


@dataclass(frozen=True)
class SplitTapeParams(OrderOption):
    interval: float = param(60.0, "a new strip starts where GPS time jumps by more than this", unit="s", gt=0,
                            manual="Interval")



def strip_starts(t: np.ndarray, previous: float | None, interval: float,
                 decimals: int | None = None) -> np.ndarray:
    """Row indices of ``t`` where a new strip starts (0 when the jump from ``previous`` does).

    With ``decimals`` (those of t in the file) a jump of exactly ``interval`` is decided at the
    data's precision, not by floating-point noise.
    """
    t = np.asarray(t, dtype=np.float64)
    starts = np.flatnonzero(above(t[1:], t[:-1], interval, decimals)) + 1
    if len(t) and previous is not None and above(t[:1], np.array([previous]), interval, decimals)[0]:
        starts = np.concatenate([[0], starts])
    return starts


class _RawStrip:
    """A strip written by copying the tape's lines byte for byte."""

    def __init__(self, fh):
        self.fh = fh
        self.count = 0

    def write_lines(self, lines, rows: slice) -> None:
        lines.write(self.fh, rows)
        self.count += rows.stop - rows.start

    def close(self) -> None:
        self.fh.close()


def _strip_suffix(ctx: JobContext) -> str:
    return ctx.output.suffix if ctx.output is not None and ctx.output.suffix is not None else "_strip"


def split_tape_outputs(source: Path, params: SplitTapeParams, ctx: JobContext) -> list[Planned]:
    """The strips ``<stem>_strip01``, ``_strip02``...: as many as the tape holds. Strips are
    text: LAS/LAZ strips are refused here, before anything runs (``--dry-run`` too)."""
    name = ctx.output_path(source, _strip_suffix(ctx), use_suffix_option=False)
    if name.suffix.lower() in (".las", ".laz"):
        if getattr(ctx.output, "out_format", "same") != "same":
            raise UsageError("strips keep the tape's 9-column text layout; --out-format las/laz does not apply")
        if getattr(ctx.input, "format", "auto") == "text":  # a LAS/LAZ file is no tape: its reader says so
            raise UsageError(f"strips keep the tape's 9-column text layout, so they cannot take the extension "
                             f"{name.suffix} of {source}; give --out-format text")
    pattern = glob_escape(name.stem) + "[0-9][0-9]*" + glob_escape(name.suffix)
    return [Planned(name.with_name(pattern), source, family=True)]


def split_tape_one(source: Path, params: SplitTapeParams, ctx: JobContext) -> None:
    reader = ctx.open_input(source, layout="altm9", order=params.order)
    suffix = _strip_suffix(ctx)
    probe = ctx.output_path(source, "", reader=reader, use_suffix_option=False)  # text: split_tape_outputs
    raw = passthrough_ok(reader, reader.names, ctx.delimiter, probe.suffix)

    with contextlib.ExitStack() as stack:
        written: list[tuple[Path, Any]] = []  # (output, its writer)
        lines_of = stack.enter_context(RawLines(source, reader.header_lines)) if raw else None

        def open_strip():
            if written:  # strips follow one another in time: the last one is done (renamed at the end)
                written[-1][1].close()
            number = len(written) + 1
            if number > MOST_STRIPS:
                raise DataError(f"more than {MOST_STRIPS:,} strips at --interval {params.interval:g} s (a flight has "
                                "tens): is the interval right, in seconds?", path=source)
            out = ctx.output_path(source, f"{suffix}{number:02d}", reader=reader, use_suffix_option=False)
            if raw:
                tmp = stack.enter_context(atomic_output(out, overwrite=ctx.overwrite))
                w = _RawStrip(stack.enter_context(open(tmp, "wb")))
            else:
                w = stack.enter_context(ctx.write_points(out, reader.names, like=reader))
            written.append((out, w))
            return w

        def put(w, chunk, lines, a: int, b: int) -> None:
            if b <= a:
                return
            if raw:
                w.write_lines(lines, slice(a, b))
            else:
                w.write(chunk.take(slice(a, b)))

        writer = None
        previous = None
        shots = 0
        back: tuple[int, float] | None = None  # the first shot whose time goes back, and by how much
        for chunk in reader.chunks():
            t = chunk["t"]
            if back is None:
                steps = np.diff(np.asarray(t, np.float64), prepend=t[0] if previous is None else previous)
                behind = np.flatnonzero(steps < -params.interval)
                if len(behind):
                    back = (shots + int(behind[0]) + 1, -float(steps[behind[0]]))
            shots += len(chunk)
            lines = None
            if lines_of is not None:
                lines = lines_of.take(len(chunk))
                if not lines.in_step_with(t):
                    raise RuntimeError(f"{source}: raw line copy out of step with the parser")
            cuts = strip_starts(t, previous, params.interval, reader.decimals.get("t"))
            if writer is None:
                writer = open_strip()
            pos = 0
            for cut in cuts.tolist():
                put(writer, chunk, lines, pos, cut)
                writer = open_strip()
                pos = cut
            put(writer, chunk, lines, pos, len(chunk))
            previous = float(t[-1])
        # leaving the stack renames every strip into place; only then are they recorded
    for out, w in written:
        ctx.wrote(out, w.count)
    if back is not None:
        # the manual splits where time jumps forward by more than the interval; a jump back is a
        # tape out of time order (blocks concatenated in another order), whose strips then mix
        ctx.warn(f"{source}: GPS time goes back by {back[1]:g} s at shot {back[0]:,} (more than the interval): the "
                 "tape is not in time order, and strips may mix passes; sort it by time first")
    if ctx.overwrite and written:
        _remove_stale_strips(written[0][0], {out for out, _ in written}, ctx)
    log.info("%s: %d strips", source, len(written))


def _remove_stale_strips(first: Path, made: set[Path], ctx: JobContext) -> None:
    """With ``--overwrite``, the strips of an earlier run of the tape past those made now: the set
    ``<stem>_stripNN`` is replaced whole, or a tape split again into fewer strips would leave the
    old later strips beside the new ones, and the next tasks (``separate-returns
    tape_strip*.txt``) would take them in without a word. Only names of the set itself (two or
    more digits, nothing after them) are touched."""
    stem = first.stem[:-2]  # ``tape_strip`` of ``tape_strip01``
    own = re.compile(re.escape(stem) + r"\d{2,}" + re.escape(first.suffix) + r"\Z")
    stale = sorted(p for p in first.parent.iterdir() if own.match(p.name) and p not in made and p.is_file())
    for path in stale:
        path.unlink()
    if stale:
        ctx.warn(f"{first.parent / stem}NN: {len(stale)} {'strip' if len(stale) == 1 else 'strips'} of an earlier "
                 "run past those of this one removed "
                 f"({', '.join(p.name for p in stale[:3])}{', ...' if len(stale) > 3 else ''})")


register_task(Task(
    name="split-tape",
    summary="Split an aggregated 9-column ALTM tape into flight strips where GPS time jumps by more than "
            "the interval (manual task 1).",
    params=SplitTapeParams,
    run_one=split_tape_one,
    examples=(
        ("aldpat split-tape tape.txt --interval 60 --odir strips/",
         "a new strip wherever GPS time jumps by more than 60 s"),
        ("aldpat split-tape tapes/*.txt --order first-last --odir strips/",
         "tapes whose 9 columns hold the first return before the last"),
    ),
    outputs=split_tape_outputs,
))
