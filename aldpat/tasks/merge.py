"""``aldpat merge``: point files into one, every point once -- the tiles of a project back into a
site, their buffer points left out.

As lasmerge and PDAL's merge do, the inputs are appended in the order given, each point with
every attribute; the output's format is its extension's. Tiles from ``aldpat tile`` (and the files
made from them: classified tiles of ``aldpat filter``) hold copies of their neighbours' points in
their buffers (ALDPAT 1.0 user manual (2007), task 7, Fig. 5); each copy is left out, so that the
merged file holds every point of the site exactly once, with the class its own tile gave it. A
point is a copy when the LAS extra-byte dimension ``tile_buffer`` says so, or -- in a file without
the mark (text) -- when it lies outside its tile's core in ``tile_parameter.txt`` (``--tile-params``,
or the one beside the input listing it). A file that is neither is taken whole.

Streamed chunk by chunk: memory does not depend on the inputs' size. A LAS/LAZ output takes the
first LAS input's header (point format, offsets, VLRs) with the finest scales that keep every
input's coordinates exact (a tile at 0.001 m after one at 0.01 m: 0.001 m) and, where the inputs'
point formats differ, the format of fewest bytes holding the attributes of each (LAS 1.2's 3 and
LAS 1.4's 6 give LAS 1.4's 7; PDAL and las2las write whatever format they are told); inputs stored at
other scales or offsets are stored again at its (with a warning when that may round a
coordinate: offsets apart by less than a step, or integers that cannot hold the finer scale over
the merged extent), and the merged
file has no ``tile_buffer`` dimension: it holds no buffer point. Inputs must share one CRS and
their columns, whatever their order: LAS into LAS the same extra dimensions (and no waveform
packets in a merge of formats apart: they point into each file's own waveform data);
otherwise intensity in every input or in none (``--fields xyz`` merges x, y and z alone).
"""

from __future__ import annotations

import copy
import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aldpat.core.crs import output_crs
from aldpat.errors import DataError, UsageError
from aldpat.io.las import (
    BUFFER_DIMENSION,
    buffer_marks,
    common_columns,
    exact_at,
    finest_scales,
    holding_formats_of,
    same_extra_dimensions,
    say_mixed_gps_times,
)
from aldpat.io.registry import EXTENSIONS, detect_format, holding_points, one_crs
from aldpat.io.tile_project import find_tile_job, in_core
from aldpat.jobs.context import JobContext
from aldpat.jobs.registry import register_task
from aldpat.jobs.task import Planned, Task
from aldpat.options import CrsOption, FieldsOption, point_names
from aldpat.params import param

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class MergeParams(FieldsOption, CrsOption):
    output: str | None = param(None, "the merged point file (.las .laz .txt .csv ...)", path=True, metavar="FILE",
                               required=True)
    tile_params: str | None = param(None, "tile_parameter.txt of the tiles (default: the one beside each input, when "
                                    "it lists it): points outside a tile's core are buffer copies, left out",
                                    path=True, metavar="FILE", level="advanced")


def _las_template(readers, crs, note):
    """The output's LAS header: the first LAS input's, without the buffer mark, its scales made as
    fine as the finest input's where that keeps every input exact (:func:`finest_scales`), of the
    point format that holds every input's attributes (:func:`holding_formats_of`); None for text
    inputs. ``crs``: the inputs' one CRS, written as WKT when the format becomes one of LAS 1.4's;
    ``note`` is told the format where the inputs' differ."""
    first = next((r for r in readers if r.format == "las"), None)
    if first is None:
        return None
    header = copy.deepcopy(first.header)
    if BUFFER_DIMENSION in header.point_format.extra_dimension_names:
        header.remove_extra_dim(BUFFER_DIMENSION)  # its Extra Bytes record too, else it describes bytes no point has
    header.scales = finest_scales(header, [r.header for r in readers if r.format == "las"])
    header = holding_formats_of(header, [r for r in readers if r.format == "las"], crs, note, "written")
    return header


def _merged_names(readers, fields: str, *, las_out: bool) -> tuple[str, ...]:
    """The columns of the merged file, the same whatever the order of the inputs: every LAS input's
    (LAS inputs into a LAS file, whose whole records are copied: their extra dimensions must
    agree, but for the buffer mark, text inputs beside them or not), else x, y, z and, with ``--fields xyzi``, intensity when every input has it.
    Where some inputs hold a column the others lack, a :class:`DataError` names both: the first
    input's columns once decided, silently leaving out what later inputs held."""
    first = readers[0]
    las_inputs = [r for r in readers if r.format == "las"]
    if las_out and las_inputs:  # each LAS point's whole record is written, text points beside them or not
        same_extra_dimensions(las_inputs, "merged into one LAS file")
        if len(las_inputs) == len(readers):
            return common_columns(readers)
    if fields == "xyzi":
        having = [r for r in readers if "intensity" in r.names]
        lacking = [r for r in readers if "intensity" not in r.names]
        if having and lacking:
            raise DataError(f"has no intensity column and {having[0].path.name} has one; use --fields xyz to "
                            "merge x, y and z alone", path=lacking[0].path)
    return point_names(first, fields)


def merge_outputs(sources: list[Path], params: MergeParams, ctx: JobContext) -> list[Planned]:
    """``-o FILE``: like every path, from where the command runs (a worksheet's folder). Its
    extension is its format, so one that names no point format is refused here, with the plan --
    before a worksheet's first job runs, and by ``--dry-run`` -- not when the points are written."""
    assert params.output is not None  # required
    out = Path(params.output)
    if out.suffix.lower() not in EXTENSIONS:
        raise UsageError(f"output {out}: a merged point file's extension is its format: "
                         f"{', '.join(sorted(set(EXTENSIONS)))}")
    return [Planned(out, named_by="output", rename="give -o another name")]


def merge_all(sources: list[Path], params: MergeParams, ctx: JobContext) -> None:
    out = merge_outputs(sources, params, ctx)[0].path
    readers = holding_points([ctx.open_input(s) for s in sources], ctx.warn, "merged")
    shared = one_crs(readers, "merge")
    template = _las_template(readers, shared, ctx.note) if detect_format(out) == "las" else None
    names = _merged_names(readers, params.fields, las_out=template is not None)
    if template is not None:
        say_mixed_gps_times(readers, template, ctx.warn, "merged")
    kept = copies = 0
    rescaled = []
    with ctx.write_points(out, names, like=readers[0], crs=output_crs(params.crs, shared, out, ctx.warn),
                          template=template) as writer:
        for reader in readers:
            marked = reader.format == "las" and BUFFER_DIMENSION in reader.header.point_format.dimension_names
            tile = None if marked else find_tile_job(reader.path, params.tile_params)
            if template is not None and reader.format == "las" and not exact_at(reader.header, template):
                rescaled.append(reader.path.name)
            for chunk in reader.chunks():
                marks = buffer_marks(chunk)
                if marks is None and tile is not None:
                    marks = ~in_core(tile.row, np.asarray(chunk.x), np.asarray(chunk.y))
                if marks is not None and marks.any():
                    copies += int(marks.sum())
                    chunk = chunk.take(~marks)
                writer.write(chunk.select(names))
                kept += len(chunk)
    if rescaled:
        ctx.warn(f"{', '.join(rescaled)}: stored at scales or offsets that {out.name}'s, from the first LAS "
                 "input, cannot hold exactly; their coordinates are rounded to its scales")
    ctx.wrote(out, kept)
    if copies:
        ctx.note(f"{copies} buffer points of tiles left out (copies of points their own tiles hold)")
    log.info("%s: %d points of %d inputs, %d buffer copies left out", out, kept, len(sources), copies)


register_task(Task(
    name="merge",
    summary="Merge point files into one, every point once: the buffer points of tiles left out (lasmerge, "
            "PDAL's merge).",
    params=MergeParams,
    run_all=merge_all,
    outputs=merge_outputs,
    examples=(
        ("aldpat merge ground/ -o site_gapm.laz",
         "a project's classified tiles back into one file: every point once, with its own tile's class"),
        ("aldpat merge a.laz b.laz -o ab.laz", "two files into one, every point with every attribute"),
        ("aldpat merge ground/ -o site.txt --tile-params tiles/tile_parameter.txt",
         "text tiles, whose buffer copies lie outside their tile's core"),
    ),
))
