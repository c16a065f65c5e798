"""``aldpat polygon-extract``: the points inside (or outside) a polygon.

ALDPAT 1.0 user manual (2007), Miscellaneous Tasks, "Extract Points by Polygon": the polygon's vertices
come from a text file "with the following format of x, y", in clockwise or anticlockwise order,
with no repeated vertex (a repeated closing vertex is tolerated here). Cui (2013)
§3.1.2: the crossing-number (Jordan curve) test, in :mod:`aldpat.core.polygon`. A polygon
shapefile may be given instead: every polygon in it, holes included. Streamed chunk by chunk;
text records are copied byte for byte when the output keeps the input's columns and delimiter.
"""

from __future__ import annotations

import logging
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aldpat.core.crs import output_crs
from aldpat.core.polygon import clean_ring, points_in_polygons
from aldpat.errors import InputFormatError, InputMissingError, shown
from aldpat.io.atomic import atomic_output
from aldpat.io.rawtext import RawLines, passthrough_ok
from aldpat.io.text import MAX_COORDINATE
from aldpat.io.toml import MAX_SIDE_FILE_BYTES, read_limited
from aldpat.jobs.context import JobContext
from aldpat.jobs.registry import register_task
from aldpat.jobs.task import Planned, Task
from aldpat.options import CrsOption, kept_names
from aldpat.params import param

log = logging.getLogger(__name__)

_SPLIT = re.compile(r"[,\s;]+")


@dataclass(frozen=True)
class PolygonExtractParams(CrsOption):
    polygon: str | None = param(None, "polygon: a text file of x,y vertices (one a line) or a polygon shapefile",
                                path=True, metavar="FILE", required=True)
    outside: bool = param(False, "keep the points outside the polygon instead")


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def read_polygon_text(path: Path) -> list[list[np.ndarray]]:
    """One polygon from an ``x,y`` a line text file (comma, space or tab; header lines allowed)."""
    try:
        lines = read_limited(path, MAX_SIDE_FILE_BYTES, what="polygon file", errors="replace").splitlines()
    except OSError as exc:
        raise InputMissingError(f"cannot read: {exc.strerror or exc}", path=path) from None
    vertices: list[tuple[float, float]] = []
    for number, line in enumerate(lines, start=1):
        tokens = [t for t in _SPLIT.split(line.strip()) if t]
        if not tokens:
            continue
        try:
            values = [float(t) for t in tokens]
        except ValueError:
            # a header line comes before the vertices and starts with a word: a first vertex
            # with a typo ("513830,540312O") was taken for one, and the polygon lost a corner
            if vertices or _is_number(tokens[0]):
                raise InputFormatError(f"expected x,y numbers, got {shown(line.strip())}", path=path,
                                       line=number) from None
            continue
        if len(values) < 2:
            raise InputFormatError("expected x,y", path=path, line=number)
        if not (abs(values[0]) <= MAX_COORDINATE and abs(values[1]) <= MAX_COORDINATE):
            raise InputFormatError(f"vertex {shown(line.strip(), quoted=False)} is not a plausible coordinate "
                                   f"(larger than {MAX_COORDINATE:g} in magnitude, or not finite)",
                                   path=path, line=number)
        vertices.append((values[0], values[1]))
    ring = clean_ring(np.asarray(vertices, dtype=np.float64).reshape(-1, 2))
    if len(ring) < 3:
        raise InputFormatError(f"a polygon needs at least 3 distinct vertices, found {len(ring)}", path=path)
    return [[ring]]


def read_polygon(path: str | Path) -> list[list[np.ndarray]]:
    path = Path(path)
    if path.suffix.lower() == ".shp":
        from aldpat.io.shapefile import read_polygons

        return read_polygons(path)
    if not path.exists():
        raise InputMissingError("no such file", path=path)
    return read_polygon_text(path)


def polygon_extract_outputs(source: Path, params: PolygonExtractParams, ctx: JobContext) -> list[Planned]:
    return [Planned(ctx.output_path(source, "_poly"), source)]


def polygon_extract_one(source: Path, params: PolygonExtractParams, ctx: JobContext) -> None:
    assert params.polygon is not None  # required
    polygons = read_polygon(params.polygon)
    reader = ctx.open_input(source)
    out = ctx.outputs_for(source)[0].path
    total = 0
    if passthrough_ok(reader, reader.names, ctx.delimiter, out.suffix):
        # the kept records are copied byte for byte
        count = 0
        with atomic_output(out, overwrite=ctx.overwrite) as tmp, open(tmp, "wb") as fh, \
                RawLines(source, reader.header_lines) as raw:
            for chunk in reader.chunks():
                lines = raw.take(len(chunk))
                if not lines.in_step_with(chunk.x):
                    raise RuntimeError(f"{source}: raw line copy out of step with the parser")
                keep = points_in_polygons(chunk.x, chunk.y, polygons) != params.outside
                lines.write(fh, keep)
                count += int(keep.sum())
                total += len(chunk)
        ctx.wrote(out, count)
        log.info("%s: %d of %d points %s the polygon", source, count, total,
                 "outside" if params.outside else "inside")
        return
    crs = output_crs(params.crs, reader.crs, out, ctx.warn)
    with ctx.write_points(out, kept_names(reader, out), like=reader, crs=crs) as writer:
        for chunk in reader.chunks():
            inside = points_in_polygons(chunk.x, chunk.y, polygons)
            writer.write(chunk.take(~inside if params.outside else inside))
            total += len(chunk)
    ctx.wrote(out, writer.count)
    log.info("%s: %d of %d points %s the polygon", source, writer.count, total,
             "outside" if params.outside else "inside")


register_task(Task(
    name="polygon-extract",
    summary="Extract the points inside a polygon (even-odd rule; text x,y vertices or a polygon shapefile), or "
            "outside with --outside (manual: Extract Points by Polygon).",
    params=PolygonExtractParams,
    run_one=polygon_extract_one,
    examples=(
        ("aldpat polygon-extract site.laz --polygon area.txt",
         "the points inside the polygon of x,y vertices"),
        ("aldpat polygon-extract strips/*.txt --polygon lakes.shp --outside",
         "the points outside a shapefile's polygons"),
    ),
    outputs=polygon_extract_outputs,
))
