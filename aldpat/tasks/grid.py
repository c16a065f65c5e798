"""``aldpat grid``: interpolate a tile's points to a Surfer grid (Surfer's job in ALDPAT).

ALDPAT 1.0 user manual (2007), task 9 "Gridding Tiles": each tile is gridded with the range of its
row in ``tile_parameter.txt`` (task 7, Fig. 8) and the cell size, so that "the last row and
column of a grid tile overlaps with the first row and column of the adjacent tiles" (Fig. 7);
without the reference file the range comes from the tile's points. The range may also be given
as ``--bounds``. Methods and blanking: :mod:`aldpat.core.interpolate`, :mod:`aldpat.core.kriging`;
extents: :mod:`aldpat.core.grid_extent`; files: :mod:`aldpat.io.surfer`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aldpat.core import units
from aldpat.core.grid_extent import (
    GridSpec,
    from_bounds,
    from_data,
    whole_cells,
)
from aldpat.core.interpolate import BINNING, METHODS, Binner, interpolate
from aldpat.core.kriging import DRIFTS, MODELS
from aldpat.errors import DataError, ParamError
from aldpat.io.bounds import point_bounds
from aldpat.io.chunks import ChunkLattice, map_chunks, scratch_folder, spill_chunks
from aldpat.io.geotiff import DEFAULT_NODATA, geotiff_header, write_geotiff
from aldpat.io.geotiff import FORMATS as GEOTIFF_FORMATS
from aldpat.io.surfer import BLANK as SURFER_BLANK
from aldpat.io.surfer import FORMATS as SURFER_FORMATS
from aldpat.io.surfer import read_surfer, write_surfer
from aldpat.io.tile_parameters import tile_row_for
from aldpat.io.vrt import TileGrid, write_mosaic
from aldpat.jobs.context import JobContext, JobResult
from aldpat.jobs.registry import Task, register_task
from aldpat.options import ChunkOption, CrsOption, OriginOption
from aldpat.params import param

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class GridParams(OriginOption, CrsOption, ChunkOption):
    cell: float = param(1.0, "grid cell size: spacing of the nodes", unit="m", gt=0)
    method: str = param("linear", "interpolation: nearest point, Delaunay TIN, inverse distance, ordinary "
                        "kriging, or the min/max/mean of the points in each node's cell", choices=METHODS)
    tile_params: str | None = param(None, "tile_parameter.txt written by 'aldpat tile': the grid range is the "
                                    "input's tile row, so adjacent tile grids share their last/first row and "
                                    "column", path=True, metavar="FILE")
    bounds: tuple[float, float, float, float] | None = param(
        None, "grid range MINX MINY MAXX MAXY: the outer nodes lie on it", unit="m", metavar="MINX MINY MAXX MAXY",
        level="advanced")
    grid_format: str = param("surfer7", "grid written: Surfer 7 binary (DSRB), 6 binary (DSBB), 6 ASCII (DSAA), "
                             "GeoTIFF or Cloud Optimized GeoTIFF (float32, deflate; needs aldpat[geotiff])",
                             choices=SURFER_FORMATS + tuple(GEOTIFF_FORMATS))
    nodata: float | None = param(None, "blank value of a surfer7 or GeoTIFF grid; none: Surfer's 1.70141e38, "
                                 "GeoTIFF's -9999", level="advanced")
    max_distance: float | None = param(None, "leave nodes blank farther than this from any point (linear: "
                                       "in triangles with a longer edge)", unit="m", gt=0, level="advanced")
    power: float = param(2.0, "inverse distance weighting power (idw)", gt=0, level="internal")
    radius: float | None = param(None, "search radius for neighbours (idw, kriging); none: unlimited",
                                 unit="m", gt=0, level="internal")
    max_points: int = param(16, "neighbours used per node (idw, kriging)", ge=1, level="internal")
    variogram: str = param("linear", "variogram model fitted to the data (kriging)", choices=MODELS, level="internal")
    nugget: float = param(0.0, "variogram nugget (kriging)", unit="m^2", ge=0, level="internal")
    drift: str = param("none", "kriging drift: none (ordinary kriging) or linear (universal)", choices=DRIFTS,
                       level="internal")
    mosaic: str | None = param(None, "also write a GDAL virtual raster (.vrt) over every grid written, so tile "
                               "grids open as one raster", path=True, metavar="FILE.vrt")

    def check(self) -> None:
        super().check()
        if self.tile_params and self.bounds:
            raise ParamError("bounds: give either --tile-params or --bounds, not both")
        if self.bounds:
            minx, miny, maxx, maxy = self.bounds
            if maxx <= minx or maxy <= miny:
                raise ParamError(f"bounds: maximum must exceed minimum (got {minx:g} {miny:g} {maxx:g} {maxy:g})")
        if self.nodata is not None and self.grid_format in ("surfer6", "surfer6-ascii"):
            raise ParamError("nodata: applies to surfer7 and GeoTIFF grids; Surfer 6 grids always use 1.70141e38")


def grid_spec_for(source: Path, params, ctx: JobContext | None = None,
                  xy: tuple[np.ndarray, np.ndarray] | None = None) -> GridSpec | None:
    """The grid range from the tile row or the bounds; None when it must come from the data.
    ``params`` has ``cell``, ``origin`` and ``tile_params``, and may have ``bounds`` (``grid``'s,
    ``dtm``'s)."""
    bounds = getattr(params, "bounds", None)
    if params.tile_params:
        row = tile_row_for(params.tile_params, source)
        lo_hi = (row.minx, row.maxx, row.miny, row.maxy)
    elif bounds:
        minx, miny, maxx, maxy = bounds
        lo_hi = (minx, maxx, miny, maxy)
    elif xy is not None:
        return from_data(*xy, params.cell, origin=params.origin or (0.0, 0.0))
    else:
        return None
    minx, maxx, miny, maxy = lo_hi
    if ctx is not None and not (whole_cells(minx, maxx, params.cell) and whole_cells(miny, maxy, params.cell)):
        ctx.warn(f"{source.name}: range {minx:g}..{maxx:g} x {miny:g}..{maxy:g} is not a whole number of "
                 f"{params.cell:g} m cells; the grid is extended east/north to cover it")
    return from_bounds(minx, miny, maxx, maxy, params.cell)


#: Methods that fit a surface through the points: they need three points not on one line.
SURFACE_METHODS = ("linear", "kriging")


def check_spread(x: np.ndarray, y: np.ndarray, method: str, source: Path) -> None:
    """Refuse, with a message saying why, points a TIN or a variogram cannot be built on."""
    if np.ptp(x) == 0 and np.ptp(y) == 0:
        distinct = x[:1]
    elif len(x) > 4096:
        return  # the usual case; qhull reports large collinear data itself, as blank nodes
    else:
        distinct = np.unique(np.c_[x, y], axis=0)
        if len(distinct) >= 3 and np.linalg.matrix_rank(distinct - distinct.mean(axis=0), tol=1e-9) == 2:
            return
    raise DataError(f"--method {method} needs at least 3 distinct points not all on one line; this file has "
                    f"{len(distinct)} distinct (use --method nearest, idw or mean)", path=source)


def grid_one(source: Path, params: GridParams, ctx: JobContext) -> None:
    reader = ctx.open_input(source)
    out = ctx.output_path(source, "", GEOTIFF_FORMATS.get(params.grid_format, ".grd"))
    spec = grid_spec_for(source, params, ctx)
    if params.chunk is not None and params.method not in BINNING:
        if spec is None:
            b = point_bounds(source, format=ctx.input.format if ctx.input is not None else None)
            spec = from_data(np.array([b.minx, b.maxx]), np.array([b.miny, b.maxy]), params.cell,
                             origin=params.origin or (0.0, 0.0))
        values, count = grid_chunked(reader, spec, params, ctx, out.parent)
    elif spec is not None and params.method in BINNING:
        binner = Binner(spec, params.method)  # streams: memory is the grid's, not the points'
        count = 0
        for chunk in reader.chunks():
            binner.add(chunk.x, chunk.y, chunk.z)
            count += len(chunk)
        values = binner.result()  # binning streams already: --chunk changes nothing
    else:
        xs, ys, zs = [], [], []
        for chunk in units.counted(reader.chunks(), "read", reader.count):
            xs.append(np.asarray(chunk.x, dtype=np.float64))
            ys.append(np.asarray(chunk.y, dtype=np.float64))
            zs.append(np.asarray(chunk.z, dtype=np.float64))
        x, y, z = (np.concatenate(a) if a else np.zeros(0) for a in (xs, ys, zs))
        count = len(x)
        if count == 0:
            raise DataError("no points to grid", path=source)
        if spec is None:
            spec = grid_spec_for(source, params, ctx, xy=(x, y))
        assert spec is not None  # from the points when neither tile parameters nor bounds give it
        if params.method in SURFACE_METHODS:
            check_spread(x, y, params.method, source)
        units.stage("interpolate")
        values = interpolate(x, y, z, spec, method=params.method, power=params.power, radius=params.radius,
                             max_points=params.max_points, max_distance=params.max_distance,
                             variogram=params.variogram, nugget=params.nugget, drift=params.drift)
    blank = int(np.isnan(values).sum())
    if blank == values.size:
        raise DataError(f"every node is blank: none of the {count} points lies near the grid range "
                        f"{spec.xmin:g}..{spec.xmax:g} x {spec.ymin:g}..{spec.ymax:g}", path=source)
    units.stage("write")
    if params.grid_format in GEOTIFF_FORMATS:
        write_geotiff(out, values, spec, cog=params.grid_format == "cog", nodata=params.nodata,
                      crs=params.crs or reader.crs, overwrite=ctx.overwrite)
    else:
        write_surfer(out, values, spec, fmt=params.grid_format, blank=params.nodata, overwrite=ctx.overwrite)
    log.info("%s: %d points -> %d x %d nodes (%d blank)", source, count, spec.nx, spec.ny, blank)
    if blank:
        ctx.warn(f"{out.name}: {blank} of {values.size} nodes are blank (no data near them)")
    ctx.wrote(out)
    ctx.tally(points=count, nodes=values.size, blank=blank)


def chunk_buffer_for(params: GridParams) -> float:
    """``--chunk-buffer auto`` of a grid: the search radius or blanking distance where one is
    given, else ten cells (a TIN, nearest point or IDW over data spaced less than that apart)."""
    if params.chunk_buffer != "auto":
        return float(params.chunk_buffer)
    return max(params.radius or 0.0, params.max_distance or 0.0, 10.0 * params.cell)


def grid_chunked(reader, spec: GridSpec, params: GridParams, ctx: JobContext, place: Path
                 ) -> tuple[np.ndarray, int]:
    """``--chunk``: the nodes in squares of ``chunk`` (whole cells), each interpolated from the
    points of its square and its buffer only (:mod:`aldpat.io.chunks`); memory is a chunk's points
    and the grid. Returns the grid and the number of points."""
    assert params.chunk is not None  # grid_one calls this only with --chunk
    k = max(1, round(params.chunk / params.cell))
    buffer = chunk_buffer_for(params)
    # node i lies at xmin + i * cell: chunk c holds nodes c*k .. c*k + k - 1
    lattice = ChunkLattice(k * params.cell, buffer, (spec.xmin - params.cell / 2, spec.ymin - params.cell / 2))
    values = np.full(spec.shape, np.nan)
    options = {"method": params.method, "power": params.power, "radius": params.radius,
               "max_points": params.max_points, "max_distance": params.max_distance,
               "variogram": params.variogram, "nugget": params.nugget, "drift": params.drift}
    with scratch_folder(params.tmpdir, place) as scratch, \
            spill_chunks(reader.chunks(), lattice, tmpdir=scratch) as spilled:
        jobs = []
        for r in range(0, spec.ny, k):
            for c in range(0, spec.nx, k):
                sub = GridSpec(spec.xmin + c * params.cell, spec.ymin + r * params.cell, params.cell,
                               params.cell, min(k, spec.nx - c), min(k, spec.ny - r))
                jobs.append((spilled, c // k, r // k, sub, options))
        for (_, c, r, sub, _), part in zip(jobs, map_chunks(_grid_one_chunk, jobs, ctx.workers)):
            values[r * k: r * k + sub.ny, c * k: c * k + sub.nx] = part
        count = spilled.points
    ctx.note(f"--chunk: {len(jobs)} chunks of {k * params.cell:g} m ({k} nodes a side) with {buffer:g} m "
             f"buffers, {count} points")
    if count == 0:
        raise DataError("no points to grid", path=reader.path)
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


def grid_mosaic(results: list[JobResult], params: GridParams, ctx: JobContext) -> None:
    """``--mosaic``: a VRT over the grids every job wrote (all of them, or none is written)."""
    if params.mosaic is None:
        return
    failed = [r for r in results if not r.ok]
    if failed:
        raise DataError(f"mosaic not written: {len(failed)} of {len(results)} grids failed", path=params.mosaic)
    out = Path(params.mosaic)
    if ctx.output is not None and ctx.output.odir and not out.is_absolute():
        out = Path(ctx.output.odir) / out
    tiles = []
    crs = params.crs
    for written in (w for r in results for w in r.outputs):
        path = Path(written.path)
        if path.suffix.lower() == ".tif":
            spec, nodata, wkt = geotiff_header(path)
            tiles.append(TileGrid(path, spec, float(DEFAULT_NODATA if nodata is None else nodata)))
            crs = crs or wkt
        else:
            _, spec = read_surfer(path)
            tiles.append(TileGrid(path, spec, params.nodata if params.nodata is not None else SURFER_BLANK))
    nodata = tiles[0].nodata if tiles else -9999.0
    ctx.wrote(write_mosaic(out, tiles, nodata=nodata, crs=crs, overwrite=ctx.overwrite))
    log.info("%s: mosaic of %d grids", out, len(tiles))


register_task(Task(
    name="grid",
    summary="Interpolate points to a Surfer grid or a GeoTIFF/COG: nearest, TIN, IDW, kriging or binning "
            "(manual task 9, Surfer's job).",
    params=GridParams,
    run_one=grid_one,
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
))
