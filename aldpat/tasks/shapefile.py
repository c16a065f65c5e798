"""``aldpat shapefile``: a merged boundary file -> an ESRI polygon shapefile.

ALDPAT 1.0 user manual (2007), Task 6 "Create Shape File": one polygon per strip of the merged boundary
file (Task 5), for display in a GIS. Attributes: ``strip`` (the strip index) and ``file`` (the
boundary file's name). ``--crs`` writes the ``.prj`` that ALDPAT left to ArcCatalog. Rings are
written clockwise and closed, as the shapefile specification requires
(:mod:`aldpat.io.shapefile`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

from aldpat.core.crs import output_crs
from aldpat.errors import DataError, UsageError
from aldpat.io.merged_boundary import read_merged
from aldpat.io.shapefile import PARTS as SHAPEFILE_PARTS
from aldpat.io.shapefile import Polygon, shapefile_rings, write_polygons
from aldpat.jobs.context import JobContext
from aldpat.jobs.registry import register_task
from aldpat.jobs.task import Planned, Task
from aldpat.options import CrsOption
from aldpat.params import param

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ShapefileParams(CrsOption):
    output: str | None = param(None, "shapefile to write (default: the input's name with .shp)", path=True,
                               metavar="FILE.shp")


FIELDS = [("strip", "N", 10, 0), ("file", "C", 254, 0)]


def shapefile_outputs(sources: list[Path], params: ShapefileParams, ctx: JobContext) -> list[Planned]:
    """The shapefile's .shp, .shx, .dbf and .cpg (and .prj with ``--crs``)."""
    if params.output:
        out = Path(params.output)
        if ctx.output is not None and ctx.output.odir and not out.is_absolute():
            out = Path(ctx.output.odir) / out
    elif len(sources) == 1:
        out = ctx.output_path(sources[0], "", ".shp")
    else:
        raise UsageError("several merged files go into one shapefile: name it with -o FILE.shp")
    if out.suffix.lower() != ".shp":
        if out.suffix and params.output:
            # another extension is a slip (m.txt): writing m.shp beside it was not what was asked
            raise UsageError(f"output: a shapefile is named FILE.shp, not {out.suffix!r} ({out.name})")
        out = out.with_name(out.name + ".shp")  # -o strips: strips.shp, as pyshp and ogr2ogr name it
    named_by, rename = ("output", "give -o another name") if params.output else (None, "give --odir or -o")
    return [Planned(out.with_suffix(ext), named_by=named_by, rename=rename)
            for ext in SHAPEFILE_PARTS + ((".prj",) if params.crs else ())]


def shapefile_all(sources: list[Path], params: ShapefileParams, ctx: JobContext) -> None:
    out = shapefile_outputs(sources, params, ctx)[0].path
    polygons = []
    for source in sources:
        for strip in read_merged(source):
            if len({(x, y) for x, y in strip.xyz[:, :2].tolist()}) < 3:
                ctx.warn(f"{source}: strip {strip.index} ({strip.name}) has fewer than 3 distinct points; skipped")
                continue
            if not shapefile_rings([strip.xyz[:, :2]]):
                ctx.warn(f"{source}: strip {strip.index} ({strip.name}): its boundary encloses no area (it crosses "
                         "itself to nothing, or its points lie on a line); skipped")
                continue
            polygons.append(Polygon([strip.xyz[:, :2]], (strip.index, strip.name)))
    if not polygons:
        # the data's fault, not the command's: exit 1, as any input refused for what it holds
        raise DataError("no strip with a usable boundary", path=sources[0])
    crs = output_crs(params.crs, None, out, ctx.warn)  # a merged boundary file names no CRS
    files = write_polygons(out, polygons, FIELDS, crs=crs, overwrite=ctx.overwrite)
    for f in files:
        ctx.wrote(f)
    log.info("%s: %d polygons", files[0], len(polygons))


register_task(Task(
    name="shapefile",
    summary="Merged boundary file -> ESRI polygon shapefile, one polygon per strip with its index and file "
            "name, .prj from --crs (manual task 6).",
    params=ShapefileParams,
    run_all=shapefile_all,
    reads_points=False,
    writes_points=False,
    examples=(
        ("aldpat shapefile merged_bound.txt --output strips.shp --crs EPSG:32617",
         "one polygon per strip, with a .prj"),
        ("aldpat shapefile merged_bound.txt --crs 17N --odir gis/",
         "gis/merged_bound.shp, named after its input"),
    ),
    outputs=shapefile_outputs,
))
