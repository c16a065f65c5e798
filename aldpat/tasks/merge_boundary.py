"""``aldpat merge-boundary``: combine strip boundary files into the manual's 5-column file.

ALDPAT 1.0 user manual (2007), Task 5 "Merge Boundary Files": "The result is a 5-column text file
showing x, y and z coordinates, which strip contains the coordinates and the name of the input
file. Note that '-1111' separates the strips." The output is named explicitly (``-o``).

Each line is ``x y z strip_index file_name`` (strips numbered from 1 in input order, the file
name without its folder); a line holding ``-1111`` stands between two strips. Inputs are
streamed, so memory does not depend on their size. :func:`aldpat.io.merged_boundary.read_merged` reads
the file back (the shapefile task uses it).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aldpat.io.atomic import atomic_output
from aldpat.io.merged_boundary import SEPARATOR
from aldpat.io.text import format_rows
from aldpat.jobs.context import JobContext
from aldpat.jobs.registry import register_task
from aldpat.jobs.task import Planned, Task
from aldpat.params import param

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class MergeBoundaryParams:
    output: str | None = param(None, "merged boundary file to write", path=True, metavar="FILE", required=True)


def merge_boundary_outputs(sources: list[Path], params: MergeBoundaryParams, ctx: JobContext) -> list[Planned]:
    """``-o FILE`` (in ``--odir`` when relative)."""
    assert params.output is not None  # required
    out = Path(params.output)
    if ctx.output is not None and ctx.output.odir and not out.is_absolute():
        out = Path(ctx.output.odir) / out
    return [Planned(out, named_by="output", rename="give -o another name")]


def merge_boundary_all(sources: list[Path], params: MergeBoundaryParams, ctx: JobContext) -> None:
    out = merge_boundary_outputs(sources, params, ctx)[0].path
    delim = "," if ctx.delimiter == "comma" else " "
    count = 0
    with atomic_output(out, overwrite=ctx.overwrite) as tmp, open(tmp, "w", encoding="utf-8", newline="\n") as fh:
        for index, source in enumerate(sources, start=1):
            if index > 1:
                fh.write(SEPARATOR + "\n")
            reader = ctx.open_input(source)
            tail = f"{delim}{source.name}\n"
            for chunk in reader.chunks():
                table = chunk.select(("x", "y", "z")).with_columns(
                    strip_index=np.full(len(chunk), index, dtype=np.int64))
                text = format_rows(table, ("x", "y", "z", "strip_index"), delim)
                fh.write(text.replace("\n", tail))
                count += len(chunk)
    ctx.wrote(out, count)
    log.info("%s: %d boundary points of %d strips", out, count, len(sources))


register_task(Task(
    name="merge-boundary",
    summary="Combine strip boundary files into one 5-column file (x y z strip_index file_name, -1111 between "
            "strips) (manual task 5).",
    params=MergeBoundaryParams,
    run_all=merge_boundary_all,
    examples=(
        ("aldpat merge-boundary bounds/*_Bound.txt --output merged_bound.txt",
         "the strips' boundaries in one file, -1111 between strips"),
        ("aldpat merge-boundary @bounds.txt --output merged.txt --delimiter comma",
         "the files listed in bounds.txt, comma-delimited"),
    ),
    outputs=merge_boundary_outputs,
))
