"""``aldpat convert``: copy points between ASCII and LAS/LAZ (txt2las / las2txt), streamed.

LAS to LAS keeps the header (point format, scale, offset, VLRs); text to LAS derives the scale
from the decimals of the text; LAS to text writes as many decimals as the LAS scale holds.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from aldpat.errors import UsageError
from aldpat.params import param
from aldpat.tasks.base import JobContext, Task, register_task


@dataclass(frozen=True)
class ConvertParams:
    fields: str = param("xyzi", "columns written to text outputs: x y z and intensity, or x y z only",
                        choices=("xyzi", "xyz"), manual="Fields")
    crs: str | None = param(None, "CRS written into LAS/LAZ outputs from text (e.g. EPSG:32617)")


def output_names(reader, fields: str) -> tuple[str, ...]:
    """Columns a point output carries: x y z, plus intensity when asked for and present."""
    names = ("x", "y", "z")
    if fields == "xyzi" and "intensity" in reader.names:
        names += ("intensity",)
    return names


def convert_one(source: Path, params: ConvertParams, ctx: JobContext) -> None:
    reader = ctx.open_input(source)
    out = ctx.output_path(source, "", reader=reader)
    if out.resolve() == source.resolve():
        raise UsageError("output would replace the input: give --out-format, --odir or --suffix", path=source)
    crs = None
    if params.crs:
        import pyproj

        try:
            crs = pyproj.CRS.from_user_input(params.crs)
        except pyproj.exceptions.CRSError as exc:
            raise UsageError(f"--crs {params.crs!r}: {exc}") from None
    names = reader.names if reader.format == "las" and out.suffix in (".las", ".laz") else output_names(reader, params.fields)
    with ctx.write_points(out, names, like=reader, crs=crs) as writer:
        for chunk in reader.chunks():
            writer.write(chunk)
    ctx.wrote(out, writer.count)


register_task(Task(
    name="convert",
    summary="Copy points between ASCII and LAS/LAZ (txt2las, las2txt), keeping attributes and precision.",
    params=ConvertParams,
    run_one=convert_one,
))
