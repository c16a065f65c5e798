"""``aldpat grid``: interpolate points to a Surfer grid or a GeoTIFF (Surfer's job in ALDPAT).

ALDPAT 1.0 user manual (2007), task 9 "Gridding Tiles": each tile is gridded over its row in
``tile_parameter.txt`` (task 7, Fig. 8), so that "the last row and column of a grid tile overlaps
with the first row and column of the adjacent tiles" (Fig. 7). Over tiles (``--tile-params``, or
the ``tile_parameter.txt`` beside the inputs listing them) a grid holds the nodes of one lattice
for the whole project inside its tile's core, interpolated from the points the tile owns and
those its neighbours own within ``buffer`` (:mod:`aldpat.io.tile_project`), with the nodes on
shared edges computed alike in every tile (:mod:`aldpat.core.tile_edges`). Otherwise the range is
``--bounds``, or the points' extent on whole multiples of the cell. Methods and blanking:
:mod:`aldpat.core.interpolate`, :mod:`aldpat.core.kriging`; files: :mod:`aldpat.io.surfer`.
Output names say the method (``<stem>_<method>.grd``), so grids of one input by two methods sit
side by side.

Which points are gridded (``classes``, :func:`class_selection`): a list of LAS classes, or all;
by default a LAS holding ground points (class 2) is gridded from them alone -- a classified file
from a vendor or from ``aldpat filter`` gives a terrain grid, not one raised by its noise and
roofs -- and any other LAS from every point but noise (7, 18) and withheld points.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aldpat.core import units
from aldpat.core.compiled import load_compiler_in_background
from aldpat.core.crs import crs_label, output_crs, parse_crs, say_cell_in_degrees
from aldpat.core.grid_extent import (
    GridSpec,
    from_bounds,
    from_data,
)
from aldpat.core.interpolate import BINNING, BYTES_PER_NODE, METHODS, Binner, interpolate
from aldpat.core.kriging import DRIFTS, MODELS
from aldpat.core.resources import check_disk
from aldpat.core.tile_edges import core_nodes, grid_tile
from aldpat.errors import DataError, ParamError
from aldpat.io.bounds import Bounds, scanned_bounds
from aldpat.io.chunks import (
    MOST_CHUNKS,
    ChunkLattice,
    check_spill,
    map_chunks,
    scratch_folder,
    spill_chunks,
    too_many_chunks,
)
from aldpat.io.classified import (
    GROUND,
    HIGH_NOISE,
    LOW_NOISE,
    held_classes,
    in_classes,
    parse_classes,
    product_points,
    withheld,
)
from aldpat.io.geotiff import DEFAULT_NODATA, FLOAT32_MAX, geotiff_header, write_geotiff
from aldpat.io.geotiff import FORMATS as GEOTIFF_FORMATS
from aldpat.io.surfer import BLANK as SURFER_BLANK
from aldpat.io.surfer import FORMATS as SURFER_FORMATS
from aldpat.io.surfer import check_holds, read_surfer, write_surfer
from aldpat.io.table import PointTable
from aldpat.io.tile_project import Keep, TileJob, find_tile_job, refuse_far_buffers, tile_points
from aldpat.io.vrt import TileGrid, write_mosaic
from aldpat.jobs.context import JobContext, JobResult
from aldpat.jobs.registry import register_task
from aldpat.jobs.task import Planned, Task
from aldpat.options import ChunkOption, CrsOption, OriginOption
from aldpat.params import param

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class GridParams(OriginOption, CrsOption, ChunkOption):
    cell: float = param(1.0, "grid cell size: spacing of the nodes", unit="m", gt=0)
    method: str = param("linear", "interpolation: nearest point, Delaunay TIN, inverse distance, ordinary "
                        "kriging, or the min/max/mean of the points in each node's cell (the square of one cell centred on "
                        "the node: nodes lie on whole multiples of the cell, Surfer's grid)", choices=METHODS)
    tile_params: str | None = param(None, "tile_parameter.txt written by 'aldpat tile' (default: the one beside "
                                    "the inputs, when it lists them): each grid covers its tile's core on one "
                                    "lattice, and adjacent tile grids share their edge nodes", path=True,
                                    metavar="FILE")
    buffer: float = param(30.0, "over tiles: the points of neighbouring tiles within this distance of a tile's "
                          "core are gridded with it", unit="m", ge=0, level="advanced")
    bounds: tuple[float, float, float, float] | None = param(
        None, "grid range MINX MINY MAXX MAXY: the outer nodes lie on it", unit="m", metavar="MINX MINY MAXX MAXY",
        level="advanced")
    grid_format: str = param("surfer7", "grid written: Surfer 7 binary (DSRB), 6 binary (DSBB), 6 ASCII (DSAA), "
                             "GeoTIFF or Cloud Optimized GeoTIFF (float32, deflate; needs aldpat[geotiff])",
                             choices=SURFER_FORMATS + tuple(GEOTIFF_FORMATS))
    nodata: float | None = param(None, "blank value of a surfer7 or GeoTIFF grid; none: Surfer's 1.70141e38, "
                                 "GeoTIFF's -9999", ge=-FLOAT32_MAX, le=FLOAT32_MAX, level="advanced")
    max_distance: float | None = param(None, "leave nodes blank farther than this from any point (linear: "
                                       "in triangles with a longer edge)", unit="m", gt=0, level="advanced")
    power: float = param(2.0, "inverse distance weighting power (idw)", gt=0, level="internal")
    radius: float | None = param(None, "search radius for neighbours (idw, kriging); none: unlimited",
                                 unit="m", gt=0, level="internal")
    max_points: int = param(16, "neighbours used per node (idw, kriging)", ge=1, le=1024, level="internal")
    variogram: str = param("linear", "variogram model fitted to the data (kriging)", choices=MODELS, level="internal")
    nugget: float = param(0.0, "variogram nugget (kriging)", unit="m^2", ge=0, level="internal")
    drift: str = param("none", "kriging drift: none (ordinary kriging) or linear (universal)", choices=DRIFTS,
                       level="internal")
    mosaic: str | None = param(None, "also write a GDAL virtual raster (.vrt) over every grid written, so tile "
                               "grids open as one raster (a path like any other: not inside --odir)", path=True,
                               metavar="FILE.vrt")
    classes: str | None = param(None, "the LAS classes gridded (2, or 2,9) or all; default: class 2 when a LAS "
                                "holds ground points (the log says so), else every point but noise (7, 18) and "
                                "withheld points", metavar="LIST|all")

    def check(self) -> None:
        super().check()
        check_classes(self.classes)
        if self.tile_params and self.bounds:
            raise ParamError("bounds: give either --tile-params or --bounds, not both")
        if self.bounds:
            minx, miny, maxx, maxy = self.bounds
            if maxx <= minx or maxy <= miny:
                raise ParamError(f"bounds: maximum must exceed minimum (got {minx:g} {miny:g} {maxx:g} {maxy:g})")
        if self.nodata is not None and self.grid_format in ("surfer6", "surfer6-ascii"):
            raise ParamError("nodata: applies to surfer7 and GeoTIFF grids; Surfer 6 grids always use 1.70141e38")
        if self.chunk is not None:
            ChunkLattice(self.chunk_cells(self.cell) * self.cell, chunk_buffer_for(self)).check_copies()


def grid_spec_for(params, xy: tuple[np.ndarray, np.ndarray] | None = None) -> GridSpec | None:
    """The grid range from ``--bounds`` (``grid``'s), else from the points ``xy`` on whole
    multiples of the cell; None when it must come from points not read yet."""
    bounds = getattr(params, "bounds", None)
    if bounds:
        minx, miny, maxx, maxy = bounds
        return from_bounds(minx, miny, maxx, maxy, params.cell)  # it says which range is extended, once
    if xy is not None:
        return from_data(*xy, params.cell, origin=params.origin or (0.0, 0.0))
    return None


#: Bytes a node takes on disk, by grid format (a COG's overviews add a third to a GeoTIFF's).
DISK_PER_NODE = {"surfer7": 8, "surfer6": 4, "surfer6-ascii": 14, "geotiff": 4, "cog": 6}


def check_grid_fits(spec: GridSpec, method: str, grid_format: str, folder: Path, source: Path) -> None:
    """Refuse, naming ``source``, a grid that needs more memory than there is now or more disk
    than ``folder`` has free -- before it is made, not after minutes of swapping."""
    if grid_format in SURFER_FORMATS:
        check_holds(spec, grid_format, source)
    spec.check_fits(BYTES_PER_NODE.get(method, 64), path=source)
    nodes = spec.nx * spec.ny
    check_disk(nodes * DISK_PER_NODE.get(grid_format, 8), folder,
               f"a {spec.nx} x {spec.ny} grid of {spec.dx:g} m cells", "use a larger --cell, or another --odir",
               path=source)


def check_classes(value: str | None) -> None:
    """``--classes``: all, or a list of LAS classes."""
    if value is not None:
        try:
            parse_classes(value)
        except ValueError as exc:
            raise ParamError(f"classes: {exc}") from None


def _holds_ground(reader) -> bool:
    """Whether a LAS file holds a point of class 2 (read until the first is found)."""
    for chunk in reader.chunks():
        if (chunk["classification"] == GROUND).any():
            return True
    return False


def _default_points(table: PointTable) -> np.ndarray:
    """Every point but noise (7, 18) and withheld points."""
    keep = ~in_classes(table, (LOW_NOISE, HIGH_NOISE))
    held = withheld(table)
    return keep if held is None else keep & ~held


def class_selection(params: GridParams, reader, ctx: JobContext) -> Keep:
    """Which points of each chunk are gridded (None: all), said in the job's log."""
    if params.classes is not None:
        classes = parse_classes(params.classes)
        if classes is None:
            return None
        ctx.note(f"gridded: the points of class {','.join(map(str, classes))} (--classes)")
        return lambda table: product_points(table, classes)
    if reader.format != "las":
        return None
    if _holds_ground(reader):
        ctx.note(f"{reader.path.name} holds ground points (class 2): only they are gridded (--classes all for "
                 f"every point)")
        return lambda table: product_points(table, (GROUND,))
    ctx.note(f"{reader.path.name} holds no ground points (class 2): every point but noise (7, 18) and withheld "
             f"points is gridded")
    return _default_points


def _none_chosen(params: GridParams, reader) -> str:
    """Why no point was gridded when ``--classes`` chose them: the classes the file holds."""
    if params.classes is None or parse_classes(params.classes) is None:
        return ""
    return f": none of class {params.classes} (--classes); {held_classes(reader)}"


def _gridded_extent(reader, keep: Keep) -> tuple[Bounds | None, int]:
    """The x/y extent of the points ``keep`` grids (None: none) and their count, read through once."""
    count = 0

    def counted():
        nonlocal count
        for chunk in selected(reader.chunks(), keep):
            count += len(chunk)
            yield chunk

    extent = scanned_bounds(counted())
    return extent, count


def selected(chunks, keep: Keep):
    """The chunks with only the points ``keep`` selects."""
    for chunk in chunks:
        yield chunk if keep is None else chunk.take(keep(chunk))


#: Methods that fit a surface through the points: they need three points not on one line.
SURFACE_METHODS = ("linear", "kriging")


def check_spread(x: np.ndarray, y: np.ndarray, method: str, source: Path | None, *,
                 needs: str | None = None, advice: str = "use --method nearest, idw or mean") -> None:
    """Refuse, with a message saying why, points a TIN or a variogram cannot be built on.
    ``needs``: what needs them (default ``--method METHOD``); ``advice``: what to do instead."""
    if np.ptp(x) == 0 and np.ptp(y) == 0:
        distinct = x[:1]
    elif len(x) > 4096:
        return  # the usual case; qhull reports large collinear data itself, as blank nodes
    else:
        distinct = np.unique(np.c_[x, y], axis=0)
        if len(distinct) >= 3 and np.linalg.matrix_rank(distinct - distinct.mean(axis=0), tol=1e-9) == 2:
            return
    raise DataError(f"{needs or f'--method {method}'} needs at least 3 distinct points not all on one line; "
                    f"this file has {len(distinct)} distinct ({advice})", path=source)


def grid_one(source: Path, params: GridParams, ctx: JobContext) -> None:
    load_compiler_in_background()  # while the points are read: the gridders are compiled loops
    tile = find_tile_job(source, params.tile_params) if not params.bounds else None  # --bounds: that range
    if tile is not None:
        grid_over_tiles(tile, params, ctx)
        return
    reader = ctx.open_input(source)
    say_cell_in_degrees(params.crs, reader.crs, params.cell, source.name, ctx.warn)
    out = ctx.outputs_for(source)[0].path
    spec = grid_spec_for(params)
    keep = class_selection(params, reader, ctx)
    if params.chunk is not None and params.method not in BINNING:
        if spec is None or keep is not None or reader.count is None:
            # the points gridded, read through once: their extent is the whole grid's, and their
            # count (not the file's, when --classes leaves some out) sets the buffer
            extent, gridded = _gridded_extent(reader, keep)
            if spec is None:
                if extent is None:
                    raise DataError(f"no points to grid{_none_chosen(params, reader)}", path=source)
                spec = from_data(np.array([extent.minx, extent.maxx]), np.array([extent.miny, extent.maxy]),
                                 params.cell, origin=params.origin or (0.0, 0.0))
        else:  # every point of a LAS, within --bounds: the header's count
            gridded = reader.count
        check_grid_fits(spec, "mean", params.grid_format, out.parent, source)  # the whole grid, filled by chunks
        values, count = grid_chunked(reader, spec, params, ctx, out.parent, keep, gridded)
    elif spec is not None and params.method in BINNING:
        check_grid_fits(spec, params.method, params.grid_format, out.parent, source)
        binner = Binner(spec, params.method)  # streams: memory is the grid's, not the points'
        count = 0
        for chunk in selected(reader.chunks(), keep):
            binner.add(chunk.x, chunk.y, chunk.z)
            count += len(chunk)
        values = binner.result()  # binning streams already: --chunk changes nothing
    else:
        xs, ys, zs = [], [], []
        for chunk in selected(units.counted(reader.chunks(), "read", reader.count), keep):
            xs.append(np.asarray(chunk.x, dtype=np.float64))
            ys.append(np.asarray(chunk.y, dtype=np.float64))
            zs.append(np.asarray(chunk.z, dtype=np.float64))
        x, y, z = (np.concatenate(a) if a else np.zeros(0) for a in (xs, ys, zs))
        count = len(x)
        if count == 0:
            raise DataError(f"no points to grid{_none_chosen(params, reader)}", path=source)
        if spec is None:
            spec = grid_spec_for(params, xy=(x, y))
        assert spec is not None  # from the points when no bounds give it
        check_grid_fits(spec, params.method, params.grid_format, out.parent, source)
        if params.method in SURFACE_METHODS:
            check_spread(x, y, params.method, source)
        units.stage("interpolate")
        values = interpolate(x, y, z, spec, method=params.method, **interpolation_options(params))
    if np.isnan(values).all():
        raise DataError(f"every node of the grid {spec.xmin:g}..{spec.xmax:g} x {spec.ymin:g}..{spec.ymax:g} is blank: "
                        f"no node lies where its {count} points reach ({_why_blank(params.method)})", path=source)
    write_grid(out, values, spec, params, reader.crs, ctx, count)
    log.info("%s: %d points -> %d x %d nodes", source, count, spec.nx, spec.ny)


def interpolation_options(params: GridParams) -> dict:
    return {"power": params.power, "radius": params.radius, "max_points": params.max_points,
            "max_distance": params.max_distance, "variogram": params.variogram, "nugget": params.nugget,
            "drift": params.drift}


def write_grid(out: Path, values: np.ndarray, spec: GridSpec, params, source_crs, ctx: JobContext,
               points: int) -> None:
    """Write a grid as ``params.grid_format`` says (a GeoTIFF takes ``--crs``, else the input's
    ``source_crs``), warn of blank nodes, record it and what made it (``points`` read)."""
    units.stage("write")
    crs = output_crs(params.crs, source_crs, out, ctx.warn)
    if params.grid_format in GEOTIFF_FORMATS:
        write_geotiff(out, values, spec, cog=params.grid_format == "cog", nodata=params.nodata, crs=crs,
                      overwrite=ctx.overwrite)
    else:
        write_surfer(out, values, spec, fmt=params.grid_format, blank=params.nodata, overwrite=ctx.overwrite)
    blank = int(np.isnan(values).sum())
    if blank:
        ctx.warn(f"{out.name}: {blank} of {values.size} nodes are blank (no data near them)")
    ctx.wrote(out)
    ctx.tally(points=points, nodes=values.size, blank=blank)


def tile_grid(tile: TileJob, x: np.ndarray, y: np.ndarray, z: np.ndarray, params, method: str, options: dict,
              ctx: JobContext) -> tuple[np.ndarray, GridSpec] | None:
    """A tile's nodes from the points it and its neighbours own within ``params.buffer``; None,
    with a warning, when the tile holds no node with a value (its grid is left out, and a mosaic
    is made of the others)."""
    name = tile.source.name
    spec = core_nodes(tile.core, params.cell, params.origin or (0.0, 0.0))
    if spec is None:
        ctx.warn(f"{name}: no node of the {params.cell:g} m lattice lies in its core; no grid written")
        return None
    check_grid_fits(spec, method, params.grid_format, ctx.output_dir(tile.source), tile.source)
    try:
        if method in SURFACE_METHODS:
            check_spread(x, y, method, tile.source)

        def grid(px, py, pz, part: GridSpec) -> np.ndarray:
            return interpolate(px, py, pz, part, method=method, **options)

        touching = [(o.minx, o.maxx, o.miny, o.maxy) for o in tile.near(0.0)]
        values = grid_tile(x, y, z, spec, tile.core, params.origin or (0.0, 0.0), params.buffer, grid, touching)
    except DataError as exc:
        ctx.warn(f"{name}: no grid written: {exc}")
        return None
    if np.isnan(values).all():
        ctx.warn(f"{name}: every node of its core is blank (none lies among the points); no grid written")
        return None
    return values, spec


def grid_over_tiles(tile: TileJob, params: GridParams, ctx: JobContext) -> None:
    """One tile's grid over its core (see the module docstring)."""
    fmt = ctx.input.format if ctx.input is not None else None
    keep = class_selection(params, ctx.open_input(tile.source), ctx)
    parts = tile_points(tile, params.buffer, fmt=fmt, keep=keep, warn=ctx.warn)
    x, y, z = (np.concatenate([getattr(p, a) for p in parts]) for a in "xyz")
    ctx.note(f"{len(parts[0].x)} points of {tile.source.name} and {len(x) - len(parts[0].x)} of "
             f"{len(parts) - 1} neighbouring tiles within {params.buffer:g} m of its core")
    if params.chunk is not None:
        ctx.note("--chunk: a tile is gridded whole")
    made = tile_grid(tile, x, y, z, params, params.method, interpolation_options(params), ctx) if len(x) else None
    if made is None:
        if not len(x):
            ctx.warn(f"{tile.source.name}: no points in or near its core; no grid written")
        return
    values, spec = made
    out = ctx.outputs_for(tile.source)[0].path
    write_grid(out, values, spec, params, ctx.open_input(tile.source).crs, ctx, len(parts[0].x))


#: ``grid --chunk``'s ``auto`` buffer reaches at least this many mean point spacings: twice the 8
#: the TIN grid's blocks take (:func:`aldpat.core.interpolate.linear`), room for a gap at a chunk's
#: edge. Ten cells alone (2.5 m at 0.25 m cells over points 2.6 m apart) gave nodes metres from the
#: whole grid's and blanked half of them.
CHUNK_BUFFER_SPACINGS = 16


def _why_blank(method: str) -> str:
    """What makes every node of a grid blank, by method, for the one line that refuses it."""
    if method == "linear":
        return "inside their triangles; with cells wider than the points' extent, a smaller --cell"
    if method in BINNING:
        return "in their cells; the points may lie off the --bounds"
    return "within --radius or --max-distance, or the points lie off the --bounds"


def chunk_buffer_for(params: GridParams, spacing: float | None = None) -> float:
    """``--chunk-buffer`` of a grid in metres; ``auto``: the search radius or blanking distance
    where one is given, ten cells, and :data:`CHUNK_BUFFER_SPACINGS` mean point ``spacing`` s
    (when known), whichever is widest: a TIN, nearest point or IDW of a chunk then sees the
    points the whole grid's would, but across gaps wider than that."""
    given = params.buffer_metres()
    if given is not None:
        return given
    return max(params.radius or 0.0, params.max_distance or 0.0, 10.0 * params.cell,
               CHUNK_BUFFER_SPACINGS * (spacing or 0.0))


def grid_chunked(reader, spec: GridSpec, params: GridParams, ctx: JobContext, place: Path, keep: Keep,
                 gridded: int) -> tuple[np.ndarray, int]:
    """``--chunk``: the nodes in squares of ``chunk`` (whole cells), each interpolated from the
    points of its square and its buffer only (:mod:`aldpat.io.chunks`); memory is a chunk's points
    and the grid. ``gridded``: how many points ``keep`` grids (their spacing sets the buffer).
    Returns the grid and the number of points."""
    assert params.chunk is not None  # grid_one calls this only with --chunk
    k = params.chunk_cells(params.cell)
    count = gridded
    area = max((spec.xmax - spec.xmin) * (spec.ymax - spec.ymin), params.cell * params.cell)
    buffer = chunk_buffer_for(params, math.sqrt(area / count) if count else None)
    # node i lies at xmin + i * cell: chunk c holds nodes c*k .. c*k + k - 1
    lattice = ChunkLattice(k * params.cell, buffer, (spec.xmin - params.cell / 2, spec.ymin - params.cell / 2))
    values = np.full(spec.shape, np.nan)
    options = {"method": params.method, "power": params.power, "radius": params.radius,
               "max_points": params.max_points, "max_distance": params.max_distance,
               "variogram": params.variogram, "nugget": params.nugget, "drift": params.drift}
    chunks = -(-spec.nx // k) * -(-spec.ny // k)
    if chunks > MOST_CHUNKS:
        raise too_many_chunks(lattice, chunks)
    check_spill(lattice, [reader], Path(params.tmpdir) if params.tmpdir else place, reader.path)
    with scratch_folder(params.tmpdir, place) as scratch, \
            spill_chunks(selected(reader.chunks(), keep), lattice, tmpdir=scratch) as spilled:
        jobs = []
        for r in range(0, spec.ny, k):
            for c in range(0, spec.nx, k):
                sub = GridSpec(spec.xmin + c * params.cell, spec.ymin + r * params.cell, params.cell,
                               params.cell, min(k, spec.nx - c), min(k, spec.ny - r))
                jobs.append((spilled, c // k, r // k, sub, options))
        for (_, c, r, sub, _), part in zip(jobs, map_chunks(_grid_one_chunk, jobs, ctx.workers), strict=False):
            values[r * k: r * k + sub.ny, c * k: c * k + sub.nx] = part
        count = spilled.points
    ctx.note(f"--chunk: {len(jobs)} chunks of {k * params.cell:g} m ({k} nodes a side) with {buffer:g} m "
             f"buffers, {count} points")
    if count == 0:
        raise DataError(f"no points to grid{_none_chosen(params, reader)}", path=reader.path)
    return values, count


def _grid_one_chunk(spilled, col: int, row: int, sub: GridSpec, options: dict) -> np.ndarray:
    """The nodes of one chunk from its points and buffer (blank where too few points reach it)."""
    points = spilled.read(col, row)
    if len(points) == 0:
        return np.full(sub.shape, np.nan)
    x, y, z = points["x"], points["y"], points["z"]
    if options["method"] in SURFACE_METHODS:
        try:
            check_spread(x, y, options["method"], Path(spilled.folder))
        except DataError:
            return np.full(sub.shape, np.nan)  # a chunk whose few points make no triangle
    opts = dict(options)
    method = opts.pop("method")
    return interpolate(x, y, z, sub, method=method, **opts)


def grid_outputs(source: Path, params: GridParams, ctx: JobContext) -> list[Planned]:
    """The grid of ``source``, and the run's mosaic (``--mosaic``)."""
    out = ctx.output_path(source, f"_{params.method}", GEOTIFF_FORMATS.get(params.grid_format, ".grd"))
    return [Planned(out, source), *mosaic_outputs(params, ctx)]


def mosaic_outputs(params, ctx: JobContext) -> list[Planned]:
    """``--mosaic FILE.vrt`` of ``grid`` and ``dtm``: made from every grid of the run."""
    if params.mosaic is None:
        return []
    # like every path, from where the command runs (a worksheet's folder), not from --odir
    return [Planned(Path(params.mosaic), named_by="mosaic", rename="give --mosaic another name")]


def grid_mosaic(results: list[JobResult], params: GridParams, ctx: JobContext) -> None:
    """``--mosaic``: a VRT over the grids every job wrote (all of them, or none is written)."""
    if params.mosaic is None:
        return
    failed = [r for r in results if not r.ok]
    if failed:
        existed = sum(r.existed for r in failed)
        why = f"{len(failed) - existed} of {len(results)} grids failed" if existed < len(failed) else ""
        if existed:  # a rerun that made the missing grids: those of the earlier run are not taken unasked
            why += f"{', and ' if why else ''}{existed} of {len(results)} grids exist from an earlier run " \
                   "(--overwrite makes every grid and the mosaic again)"
        raise DataError(f"mosaic not written: {why}", path=params.mosaic)
    out = mosaic_outputs(params, ctx)[0].path
    tiles = []
    crs = params.crs
    first: tuple[Path, Any] | None = None  # the first GeoTIFF naming a CRS, and its CRS
    for written in (w for r in results for w in r.outputs):
        path = Path(written.path)
        if path.suffix.lower() == ".tif":
            spec, nodata, wkt = geotiff_header(path)
            tiles.append(TileGrid(path, spec, float(DEFAULT_NODATA if nodata is None else nodata)))
            crs = crs or wkt
            if wkt:
                # a VRT places every grid in its one CRS: a grid of another would be drawn where it
                # is not (gdalbuildvrt leaves such a file out); all the grids or no mosaic, as above
                own = parse_crs(wkt)
                if first is None:
                    first = (path, own)
                elif own != first[1]:
                    raise DataError(f"mosaic not written: {path.name} is in {crs_label(own)}, {first[0].name} in "
                                    f"{crs_label(first[1])}; a mosaic holds grids of one CRS", path=params.mosaic)
        else:
            _, spec = read_surfer(path)
            tiles.append(TileGrid(path, spec, params.nodata if params.nodata is not None else SURFER_BLANK))
    nodata = tiles[0].nodata if tiles else -9999.0
    ctx.wrote(write_mosaic(out, tiles, nodata=nodata, crs=crs, overwrite=ctx.overwrite))
    log.info("%s: mosaic of %d grids", out, len(tiles))


def plan_grids(sources: list[Path], params: GridParams, _input_params) -> list[list[str]]:
    """One job an input; over tiles (without ``--bounds``) a ``--buffer`` reaching too far beyond
    them is refused first, once for the run."""
    if not params.bounds:
        refuse_far_buffers(sources, params.tile_params, params.buffer)
    return [[str(s)] for s in sources]


register_task(Task(
    name="grid",
    summary="Interpolate points to a Surfer grid or a GeoTIFF/COG: nearest, TIN, IDW, kriging or binning "
            "(manual task 9, Surfer's job).",
    params=GridParams,
    run_one=grid_one,
    plan=plan_grids,
    finish=grid_mosaic,
    writes_points=False,
    examples=(
        ("aldpat grid ground/*.txt --cell 1",
         "a Surfer 7 grid of each file, TIN interpolation"),
        ("aldpat grid ground/ --cell 1 --grid-format cog --crs 17N",
         "Cloud Optimized GeoTIFFs"),
        ("aldpat grid 'ground/tile_*.txt' --tile-params tiles/tile_parameter.txt --mosaic dtm.vrt",
         "tile grids sharing their edge nodes, and one raster over them"),
    ),
    outputs=grid_outputs,
))
