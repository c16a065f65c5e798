"""``aldpat grd2bin``: Surfer grid -> ArcGIS binary float grid (or ESRI ASCII grid).

ALDPAT 1.0 user manual (2007), task 10 "Convert Surfer Grids to ArcGIS Grids" (Grd2Bin). ALDPAT's
binary grids were "not georeferenced" and needed ArcGIS's import tool; these carry their corner
and cell size in the ``.hdr`` (with ``BYTEORDER LSBFIRST``) and, with ``--crs``, a ``.prj``.
Formats: :mod:`aldpat.io.surfer`, :mod:`aldpat.io.esri_grid`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from aldpat.core.crs import output_crs
from aldpat.io.esri_grid import write_ascii_grid, write_float_grid
from aldpat.io.geotiff import FLOAT32_MAX, write_geotiff
from aldpat.io.surfer import read_surfer
from aldpat.jobs.context import JobContext
from aldpat.jobs.registry import register_task
from aldpat.jobs.task import Planned, Task
from aldpat.options import CrsOption
from aldpat.params import param


@dataclass(frozen=True)
class Grd2BinParams(CrsOption):
    to: str = param("flt", "output: ArcGIS binary float grid (.flt + .hdr), ESRI ASCII grid (.asc), GeoTIFF "
                    "(tif) or Cloud Optimized GeoTIFF (cog; both need aldpat[geotiff])", choices=("flt", "asc", "tif", "cog"))
    nodata: float = param(-9999.0, "value written for blank nodes", ge=-FLOAT32_MAX, le=FLOAT32_MAX)


def grd2bin_outputs(source: Path, params: Grd2BinParams, ctx: JobContext) -> list[Planned]:
    """The grid, with its .hdr (``flt``) and .prj (``--crs``) beside it."""
    out = ctx.output_path(source, "", ".tif" if params.to in ("tif", "cog") else "." + params.to)
    sides = [".hdr"] if params.to == "flt" else []
    if params.crs is not None and params.to in ("flt", "asc"):
        sides.append(".prj")
    return [Planned(out, source)] + [Planned(out.with_suffix(ext), source, role="side") for ext in sides]


def grd2bin_one(source: Path, params: Grd2BinParams, ctx: JobContext) -> None:
    values, spec = read_surfer(source)
    out = ctx.outputs_for(source)[0].path
    crs = output_crs(params.crs, None, out, ctx.warn)  # a Surfer grid names no CRS
    if params.to in ("tif", "cog"):
        ctx.wrote(write_geotiff(out, values, spec, cog=params.to == "cog", nodata=params.nodata, crs=crs,
                                overwrite=ctx.overwrite))
        return
    writer = write_float_grid if params.to == "flt" else write_ascii_grid
    for path in writer(out, values, spec, nodata=params.nodata, crs=crs, overwrite=ctx.overwrite):
        ctx.wrote(path)


register_task(Task(
    name="grd2bin",
    summary="Convert Surfer grids to georeferenced ArcGIS float grids (.flt/.hdr/.prj) or ESRI ASCII "
            "grids (manual task 10).",
    params=Grd2BinParams,
    run_one=grd2bin_one,
    reads_points=False,
    writes_points=False,
    examples=(
        ("aldpat grd2bin grids/*.grd --crs EPSG:32617",
         "ArcGIS float grids (.flt/.hdr/.prj) beside the Surfer grids"),
        ("aldpat grd2bin dtm.grd --to cog --crs 17N",
         "a Cloud Optimized GeoTIFF"),
    ),
    outputs=grd2bin_outputs,
))
