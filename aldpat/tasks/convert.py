"""``aldpat convert``: copy points between ASCII and LAS/LAZ (txt2las / las2txt), streamed.

LAS to LAS keeps the header (point format, scale, offset, VLRs); text to LAS derives the scale
from the decimals of the text; LAS to text writes as many decimals as the LAS scale holds.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from aldpat.core.crs import output_crs
from aldpat.jobs.context import JobContext, Planned
from aldpat.jobs.registry import Task, register_task
from aldpat.options import CrsOption, FieldsOption, point_names


@dataclass(frozen=True)
class ConvertParams(FieldsOption, CrsOption):
    """Only the shared options: ``fields`` and ``crs``."""


def convert_outputs(source: Path, params: ConvertParams, ctx: JobContext) -> list[Planned]:
    return [Planned(ctx.output_path(source, ""), source)]


def convert_one(source: Path, params: ConvertParams, ctx: JobContext) -> None:
    reader = ctx.open_input(source)
    out = ctx.outputs_for(source)[0].path
    crs = output_crs(params.crs, reader.crs, out, ctx.warn)
    names = reader.names if reader.format == "las" and out.suffix in (".las", ".laz") else point_names(reader, params.fields)
    with ctx.write_points(out, names, like=reader, crs=crs) as writer:
        for chunk in reader.chunks():
            writer.write(chunk)
    ctx.wrote(out, writer.count)


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
    ),
    outputs=convert_outputs,
))
