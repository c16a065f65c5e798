"""``aldpat thin``: reduce point density, one point per cell.

ALDPAT 1.0 user manual (2007), Miscellaneous Tasks, "Reduce Point Density": Width and Height of the
window (cell), Method (Lowest, Median, Center) and XY Type ("If 'xy Type' is the 'Integer', the
x and y coordinates of an output point is derived by rounding the coordinates of a selected point
to nearest integers"); selection rules in :mod:`aldpat.core.cells`. Cells are aligned to whole
multiples of the cell size unless ``--origin``. Rounding is half away from zero
(12.5 -> 13), as a C++ ``floor(x + 0.5)`` did for positive coordinates, not numpy's half-to-even.

Memory: the points of one cell may be anywhere in the file, so large inputs are partitioned by
cell block into temporary bucket files first (:mod:`aldpat.io.spill`) and each bucket is
thinned in memory; the output lists bucket after bucket, each in input order. Inputs of up to
one chunk (2 million points) are thinned in memory and keep their input order.

Points a survey file sets aside take no part and are not written, as the filters and ``dtm`` leave
them out of the ground (:mod:`aldpat.filters.survey`): withheld points, those of
``ignore_classes`` (noise, 7 and 18) and, with ``returns``, the other returns -- a cell's lowest
point is then never a vendor's low noise point, as ``lasthin -drop_class 7`` keeps it out.
"""

from __future__ import annotations

import logging
from collections import ChainMap
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aldpat.core.cells import METHODS, cell_of, select_per_cell
from aldpat.core.crs import output_crs, say_cell_in_degrees
from aldpat.filters.survey import ExistingClassesOption, taking_part
from aldpat.io.spill import Spill, bucket_count, bucket_of, estimate_points
from aldpat.jobs.context import JobContext
from aldpat.jobs.registry import register_task
from aldpat.jobs.task import Planned, Task
from aldpat.options import CellHeightOption, CrsOption, OriginOption, kept_names
from aldpat.params import param

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ThinParams(ExistingClassesOption, CellHeightOption, OriginOption, CrsOption):
    cell: float = param(1.0, "cell (window) width, and height unless cell_height is given", unit="m", gt=0,
                        manual="Width", renamed_from=("cell_width",))
    method: str = param("lowest", "which point a cell keeps: the lowest, the one of median elevation, or the one "
                        "nearest the cell centre", choices=METHODS, manual="Method")
    xy: str = param("float", "output x and y as read (float) or rounded to the nearest integer",
                    choices=("float", "integer"), manual="XY Type", level="advanced")



def round_half_away(v: np.ndarray) -> np.ndarray:
    return np.where(v >= 0, np.floor(v + 0.5), np.ceil(v - 0.5))


def taking_part_only(table, params: ThinParams):
    """The points of ``table`` taking part (:func:`aldpat.filters.survey.taking_part`): a point's
    own flags and class decide, so each chunk is cut as it is read, before it is held or spilled."""
    part = taking_part(table, params)
    return table if part is None else table.take(np.flatnonzero(part))


def thin_table(table, params: ThinParams):
    """The points ``table`` keeps (one per occupied cell), x and y rounded if asked."""
    keep = select_per_cell(table.x, table.y, table.z, *params.cell_shape(),
                           method=params.method, origin=params.origin)
    out = table.take(keep)
    if params.xy == "integer":
        out = out.with_columns(x=round_half_away(out.x), y=round_half_away(out.y))
    return out


def thin_outputs(source: Path, params: ThinParams, ctx: JobContext) -> list[Planned]:
    return [Planned(ctx.output_path(source, "_thin"), source)]


def thin_one(source: Path, params: ThinParams, ctx: JobContext) -> None:
    reader = ctx.open_input(source)
    say_cell_in_degrees(params.crs, reader.crs, params.cell, source.name, ctx.warn)
    out = ctx.outputs_for(source)[0].path
    # the reader's own decimals, which it widens as it reads (a live view, not a copy)
    decimals = ChainMap({"x": 0, "y": 0} if params.xy == "integer" else {}, reader.decimals)
    k = bucket_count(estimate_points(reader))
    total = 0
    crs = output_crs(params.crs, reader.crs, out, ctx.warn)
    with ctx.write_points(out, kept_names(reader, out), like=reader, decimals=decimals, crs=crs) as writer:
        if k == 1:
            from aldpat.io.table import PointTable

            chunks = list(reader.chunks())
            total = sum(len(chunk) for chunk in chunks)
            writer.write(thin_table(PointTable.concat([taking_part_only(c, params) for c in chunks]), params))
        else:
            spill = Spill(out.parent, k)
            try:
                for chunk in reader.chunks():
                    total += len(chunk)
                    chunk = taking_part_only(chunk, params)
                    i, j = cell_of(chunk.x, chunk.y, *params.cell_shape(), params.origin)
                    spill.add(chunk, bucket_of(i, j, k))
                for bucket in spill.buckets():
                    writer.write(thin_table(bucket, params))
            finally:
                spill.close()
    ctx.wrote(out, writer.count)
    log.info("%s: %d of %d points kept (%d buckets; withheld points and classes %s take no part)", source,
             writer.count, total, k, ",".join(map(str, params.ignore_classes or ())) or "none")


register_task(Task(
    name="thin",
    summary="Reduce point density: one point per cell, the lowest, the median or the one nearest the centre "
            "(manual: Reduce Point Density).",
    params=ThinParams,
    run_one=thin_one,
    examples=(
        ("aldpat thin site.laz --cell 5",
         "the lowest point of each 5 m cell"),
        ("aldpat thin tiles/ --cell 2 --method median --odir thin/",
         "the median point of each 2 m cell, every tile"),
    ),
    outputs=thin_outputs,
))
