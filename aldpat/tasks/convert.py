"""``aldpat convert``: copy points between ASCII and LAS/LAZ (txt2las / las2txt), streamed.

LAS to LAS keeps the header (point format, scale, offset, VLRs); text to LAS derives the scale
from the decimals of the text; LAS to text writes as many decimals as the LAS scale holds.

``--tape`` reads a 9-column ALTM tape or strip (ALDPAT 1.0 user manual (2007), task 1: "t, x2,
y2, z2, i2, x1, y1, z1, i1") and writes both returns of every pulse to LAS/LAZ, first then last,
with the GPS time: the first return 1 of 2, the last 2 of 2. A pulse whose last return is its
first (the same x, y, z: the tape's record of a single return) is one point, return 1 of 1, so
the file holds no duplicate points.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aldpat.core.crs import output_crs
from aldpat.errors import UsageError
from aldpat.io.las import RETURN_DIMENSIONS
from aldpat.io.table import PointTable
from aldpat.io.text import PulseDecimals
from aldpat.jobs.context import JobContext
from aldpat.jobs.registry import register_task
from aldpat.jobs.task import Planned, Task
from aldpat.options import CrsOption, FieldsOption, OrderOption, point_names
from aldpat.params import param


@dataclass(frozen=True)
class ConvertParams(FieldsOption, OrderOption, CrsOption):
    tape: bool = param(False, "the inputs are 9-column ALTM tapes or strips (see --order): write both returns "
                       "of each pulse to LAS/LAZ, first 1 of 2, last 2 of 2 (a single return 1 of 1)")

#: the columns a tape's LAS points get
TAPE_NAMES = ("x", "y", "z", "intensity", "t", *RETURN_DIMENSIONS)


def convert_outputs(source: Path, params: ConvertParams, ctx: JobContext) -> list[Planned]:
    """The copy of ``source``; with ``--tape`` it must be LAS/LAZ, refused here otherwise, before
    anything runs (``--dry-run`` too)."""
    out = ctx.output_path(source, "")
    if params.tape and out.suffix.lower() not in (".las", ".laz"):
        raise UsageError("--tape writes LAS/LAZ (--out-format las or laz); separate-returns makes text files of "
                         "the first and last returns")
    return [Planned(out, source)]


def convert_one(source: Path, params: ConvertParams, ctx: JobContext) -> None:
    if params.tape:
        convert_tape(source, params, ctx)
        return
    reader = ctx.open_input(source)
    out = ctx.outputs_for(source)[0].path
    crs = output_crs(params.crs, reader.crs, out, ctx.warn)
    names = reader.names if reader.format == "las" and out.suffix in (".las", ".laz") else point_names(reader, params.fields)
    with ctx.write_points(out, names, like=reader, crs=crs) as writer:
        for chunk in reader.chunks():
            writer.write(chunk)
    ctx.wrote(out, writer.count)


def convert_tape(source: Path, params: ConvertParams, ctx: JobContext) -> None:
    """A 9-column tape to LAS/LAZ: both returns of every pulse (see the module docstring)."""
    reader = ctx.open_input(source, layout="altm9", order=params.order)
    out = ctx.outputs_for(source)[0].path  # LAS/LAZ: convert_outputs refuses text
    crs = output_crs(params.crs, None, out, ctx.warn)  # a tape names no CRS
    decimals = PulseDecimals(reader.decimals)
    names = TAPE_NAMES if params.fields == "xyzi" else tuple(n for n in TAPE_NAMES if n != "intensity")
    with ctx.write_points(out, names, decimals=decimals, crs=crs) as writer:
        for chunk in reader.chunks():
            writer.write(pulse_points(chunk, decimals).select(names))
    ctx.wrote(out, writer.count)


def pulse_points(chunk: PointTable, decimals: Mapping[str, int]) -> PointTable:
    """The points of a chunk of tape pulses, each pulse's first return then its last (left out
    when it is the first: same x, y, z), numbered as the module docstring says."""
    single = (chunk["x1"] == chunk["x2"]) & (chunk["y1"] == chunk["y2"]) & (chunk["z1"] == chunk["z2"])
    keep = np.ones(2 * len(chunk), bool)
    keep[1::2] = ~single

    def pair(first: np.ndarray, last: np.ndarray) -> np.ndarray:
        return np.column_stack([first, last]).ravel()[keep]

    columns = {name: pair(chunk[f"{name}1"], chunk[f"{name}2"]) for name in ("x", "y", "z")}
    columns["intensity"] = pair(chunk["i1"], chunk["i2"])
    columns["t"] = pair(chunk["t"], chunk["t"])
    columns["return_number"] = np.tile(np.array([1, 2], np.uint8), len(chunk))[keep]
    columns["number_of_returns"] = np.repeat(np.where(single, 1, 2).astype(np.uint8), 2)[keep]
    return PointTable(columns, meta={"decimals": decimals})


register_task(Task(
    name="convert",
    summary="Copy points between ASCII and LAS/LAZ (txt2las, las2txt), keeping attributes and precision.",
    params=ConvertParams,
    run_one=convert_one,
    examples=(
        ("aldpat convert strips/*.txt --out-format laz --crs EPSG:32617 --odir laz/",
         "text strips to LAZ, their CRS in the headers"),
        ("aldpat convert site.laz --out-format text --fields xyz",
         "a LAZ file to x y z text beside it"),
        ("aldpat convert strip01.txt --tape --out-format laz --crs 17N",
         "a 9-column ALTM strip to LAZ: first returns 1 of 2, last returns 2 of 2"),
    ),
    outputs=convert_outputs,
))
