"""``aldpat strip-boundary``: the boundary polygon of a flight strip.

ALDPAT 1.0 user manual (2007), Task 4 "Estimate strip boundary" (algorithm in
:mod:`aldpat.core.boundary`). Output: ``x y z i`` of the boundary points, real data points, in
ring order and closed (the first point repeated last), suffix ``_Bound``. The strip is read
chunk by chunk; only the extreme cells of each row and column are kept.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aldpat.core.boundary import BoundaryScan
from aldpat.core.crs import coordinate_unit, output_crs, say_cell_in_degrees
from aldpat.errors import DataError
from aldpat.io.table import PointTable
from aldpat.jobs.context import JobContext
from aldpat.jobs.registry import register_task
from aldpat.jobs.task import Planned, Task
from aldpat.options import CellHeightOption, CrsOption, OriginOption
from aldpat.params import param

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class StripBoundaryParams(CellHeightOption, OriginOption, CrsOption):
    cell: float = param(5.0, "cell width of the min-z mesh, and height unless cell_height is given", unit="m",
                        gt=0, manual="Width", renamed_from=("cell_width",))
    scan: str = param("auto", "scan rows for min and max x (x), columns for min and max y (y), or rows when the "
                      "x extent is the longer (auto)", choices=("auto", "x", "y"), manual="Scan Direction")



def boundary_of(reader, params: StripBoundaryParams, unit: str = "m") -> tuple[dict, str]:
    """The closed boundary ring of a strip (columns x y z intensity) and the scan used.

    Raises :class:`DataError` where the occupied cells make no polygon (fewer than three
    boundary points): saying whether the strip is narrower than a cell -- its points on one line,
    a profile, which no cell size gives an area -- or only sparse for the cells; sizes in the
    coordinates' ``unit`` (:func:`aldpat.core.crs.coordinate_unit`)."""
    scan = BoundaryScan(*params.cell_shape(), params.origin)
    for chunk in reader.chunks():
        intensity = chunk["intensity"] if "intensity" in chunk else None  # noqa: SIM401  (a PointTable, no .get)
        scan.add(chunk.x, chunk.y, chunk.z, intensity)
    ring = scan.ring(params.scan)
    corners = len(ring["x"]) - 1
    if corners < 3:
        found = f"{corners} boundary point{'s' if corners != 1 else ''}"
        width, height = (float(hi - lo) for lo, hi in zip(scan.lo, scan.hi, strict=True))
        cell_w, cell_h = params.cell_shape()
        if max(width, height) == 0.0:
            why = "its points lie at one position"
        elif min(width, height) == 0.0:
            why = (f"its points lie on one line ({width:g} {unit} by {height:g} {unit}): a profile has no area, whatever the "
                   "cells")
        elif width < cell_w or height < cell_h:
            why = (f"the strip, {width:g} {unit} by {height:g} {unit}, is narrower than one {cell_w:g} x {cell_h:g} {unit} cell; use "
                   "smaller cells")
        else:
            why = "use smaller cells"
        raise DataError(f"too few occupied cells for a boundary polygon ({found}): {why}", path=reader.path)
    return ring, scan.direction(params.scan)


def strip_boundary_outputs(source: Path, params: StripBoundaryParams, ctx: JobContext) -> list[Planned]:
    return [Planned(ctx.output_path(source, "_Bound"), source)]


def strip_boundary_one(source: Path, params: StripBoundaryParams, ctx: JobContext) -> None:
    reader = ctx.open_input(source)
    say_cell_in_degrees(params.crs, reader.crs, params.cell, source.name, ctx.warn)
    ring, direction = boundary_of(reader, params, coordinate_unit(params.crs, reader.crs))
    names = ("x", "y", "z", "intensity")
    ring["intensity"] = np.rint(ring["intensity"]).astype(np.int64)
    out = ctx.outputs_for(source)[0].path
    crs = output_crs(params.crs, reader.crs, out, ctx.warn)
    with ctx.write_points(out, names, like=reader, crs=crs) as writer:
        writer.write(PointTable(ring, meta={"decimals": reader.decimals}))
    ctx.wrote(out, writer.count)
    log.info("%s: %d boundary points (scan %s)", source, writer.count - 1, direction)


register_task(Task(
    name="strip-boundary",
    summary="Boundary polygon of a strip from a min-z grid, scanning rows or columns (manual task 4).",
    params=StripBoundaryParams,
    run_one=strip_boundary_one,
    examples=(
        ("aldpat strip-boundary returns/*_1.txt --cell 2 --odir bounds/",
         "the boundary ring of each strip from a 2 m grid"),
        ("aldpat strip-boundary strip01_1.txt --cell 5 --scan y",
         "a north-south strip: scan the columns for their lowest and highest y"),
    ),
    outputs=strip_boundary_outputs,
))
