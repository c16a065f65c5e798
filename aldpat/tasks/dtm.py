"""``aldpat dtm``: points to a bare-earth terrain model in one command.

The chain of ALDPAT 1.0 user manual (2007) tasks 8 and 9 -- filter the ground points, grid them
with a TIN -- run tile by tile and written as a GeoTIFF or Cloud Optimized GeoTIFF:

1. each input (one file, or one tile of many) is read with the points of the other inputs that
   lie within ``buffer`` of it, so that the filter sees the objects and slopes crossing its edge
   (the neighbours are found once, from the LAS headers or one pass over each text file, before
   any job runs);
2. the ground filter ``algorithm`` (any registered one; ``gapm`` by default, dissertation ch. 6)
   classifies them, with the parameters of ``filter_params`` -- the same file ``aldpat filter
   ALGO --params`` takes -- or ``--auto``;
3. the ground points are triangulated (Delaunay TIN, linear inside each triangle: Surfer's
   "Triangulation with Linear Interpolation" of task 9) onto nodes ``cell`` apart over the
   input's own extent, on whole multiples of the cell from ``origin``;
4. the grid is written as ``<stem>_dtm.tif``, float32, with the CRS (``--crs`` or the LAS's).

Over tiles from ``aldpat tile`` (``tile_params``, or the ``tile_parameter.txt`` beside the inputs
listing them) every point is one tile's own (:mod:`aldpat.io.tile_project`), and a node on a
shared edge must come out the same in both tiles: a first pass filters each tile -- its own
points with its neighbours' within ``buffer`` as context -- and keeps the classes of its own
points; then each tile's DTM covers its core only, on one lattice for the project, from the
ground points it and its neighbours own, each as its own tile classed it, with the nodes on its
edges computed alike in every tile holding them (:mod:`aldpat.core.tile_edges`). A tile whose
core holds no node with a value is a warning, and the mosaic is made of the others.

Points a survey file sets aside (withheld, ``ignore_classes``: noise 7 and 18 by default) take no
part in finding ground (:mod:`aldpat.filters.survey`). ``classes`` makes the DTM from a classified
file's own classes (``2``, ``2,9``) without filtering it again.

``--mosaic dtm.vrt`` adds a GDAL virtual raster over every tile's DTM.
"""

from __future__ import annotations

import functools
import hashlib
import logging
import math
import os
from collections.abc import Callable
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from aldpat.core import units
from aldpat.core.crs import crs_label, output_crs, say_cell_in_degrees
from aldpat.core.data_gaps import GAP_CELLS, GAP_SPACINGS, Occupancy, blank_gaps, default_gap, mean_spacing
from aldpat.core.grid_extent import GridSpec
from aldpat.core.interpolate import linear
from aldpat.errors import AldpatError, DataError, ParamError
from aldpat.filters import FILTERS, ground_filter
from aldpat.filters.options import LowOutlierOption
from aldpat.filters.streamed import grid_bounds, stream_ground, streamable
from aldpat.filters.survey import TAKING_PART_FIELDS, ExistingClassesOption, taking_part
from aldpat.io.bounds import Bounds, point_bounds
from aldpat.io.classified import held_classes, parse_classes, product_points
from aldpat.io.geotiff import FLOAT32_MAX, Raster, write_geotiff
from aldpat.io.geotiff import FORMATS as GEOTIFF_FORMATS
from aldpat.io.registry import open_points
from aldpat.io.table import PointTable
from aldpat.io.tile_project import OwnedPoints, TileJob, find_tile_job, refuse_far_buffers, tile_points
from aldpat.io.toml import load_toml
from aldpat.jobs.context import JobContext
from aldpat.jobs.registry import register_task
from aldpat.jobs.task import Planned, Task
from aldpat.options import CrsOption, OriginOption
from aldpat.params import Checked, param, resolve
from aldpat.tasks.filter import STREAM_CHUNK
from aldpat.tasks.grid import (
    check_classes,
    check_grid_fits,
    check_spread,
    grid_mosaic,
    grid_spec_for,
    mosaic_outputs,
    tile_grid,
)

log = logging.getLogger(__name__)

#: The low-outlier test's and the existing classes' options, which ``dtm`` takes itself and hands
#: to its filter (:meth:`DtmParams.ground_params`).
LOW_OUTLIER_KEYS = tuple(f.name for f in (*fields(LowOutlierOption), *fields(ExistingClassesOption)))


#: Filters that find ground (``outlier`` finds noise only: a DTM from it would keep the roofs).
GROUND_FILTERS = tuple(sorted(name for name in FILTERS if name != "outlier"))


@dataclass(frozen=True)
class DtmParams(LowOutlierOption, ExistingClassesOption, OriginOption, CrsOption, Checked):
    cell: float = param(1.0, "DTM node spacing", unit="m", gt=0)
    algorithm: str = param("gapm", "ground filter", choices=GROUND_FILTERS)
    classes: str | None = param(None, "make the DTM from the file's own classes (2, or 2,9; all: every point) "
                                "without filtering; default: find the ground with --algorithm", metavar="LIST|all")
    filter_params: str | None = param(None, "the filter's parameters: a TOML file of the keys 'aldpat filter "
                                      "ALGO --params' takes (default: the filter's own defaults)",
                                      path=True, metavar="FILE.toml")
    auto: bool = param(False, "gapm: derive the cell and windows from the data (as 'aldpat filter gapm --auto')")
    buffer: float = param(30.0, "points of the other inputs within this distance of an input's extent are "
                          "filtered and triangulated with it (at least the largest object's half width)",
                          unit="m", ge=0, level="advanced")
    tile_params: str | None = param(None, "tile_parameter.txt written by 'aldpat tile' (default: the one beside "
                                    "the inputs, when it lists them): each DTM covers its tile's core on one "
                                    "lattice, and adjacent DTMs share their edge nodes", path=True,
                                    metavar="FILE")
    grid_format: str = param("cog", "GeoTIFF or Cloud Optimized GeoTIFF (float32, deflate; needs aldpat[geotiff])",
                             choices=tuple(GEOTIFF_FORMATS), level="advanced")
    nodata: float | None = param(None, "value of nodes outside the ground points' triangles; none: -9999",
                                 ge=-FLOAT32_MAX, le=FLOAT32_MAX, level="advanced")
    max_distance: float | None = param(None, "leave nodes blank inside triangles with an edge longer than this "
                                       "(building footprints too: --max-gap is the DTM's test)",
                                       unit="m", gt=0, level="advanced")
    max_gap: str = param("auto", "leave nodes blank with no input point of any class within M metres "
                         "(water, gaps between strips; roofs keep building footprints bridged); auto: "
                         f"{GAP_SPACINGS:g} x the mean point spacing (point count over the area the points "
                         f"cover), at least {GAP_CELLS:g} cells; none or 0: never", metavar="M|auto|none")
    mosaic: str | None = param(None, "also write a GDAL virtual raster (.vrt) over every DTM written (a path "
                               "like any other: not inside --odir)", path=True, metavar="FILE.vrt")

    def check(self) -> None:
        super().check()
        if self.auto and self.algorithm != "gapm":
            raise ParamError(f"auto: derives gapm's parameters; --algorithm is {self.algorithm}")
        check_classes(self.classes)
        self.gap_setting()
        self.ground_params()  # a bad filter parameter file fails before any point is read

    def gap_setting(self) -> float | str | None:
        """``max_gap`` as metres, ``"auto"``, or None (no gap test)."""
        text = str(self.max_gap).strip().lower()
        if text == "auto":
            return "auto"
        if text == "none":
            return None
        try:
            metres = float(text)
        except ValueError:
            raise ParamError(f"max_gap: expected metres, auto or none, got {self.max_gap!r}") from None
        if not (math.isfinite(metres) and metres >= 0):
            raise ParamError(f"max_gap: expected metres >= 0, auto or none, got {self.max_gap!r}")
        return metres or None

    def ground_params(self) -> Any:
        """The filter's parameters: its defaults, then ``dtm``'s low-outlier and class options as
        defaults, then ``filter_params``, then those options set on ``dtm`` (:meth:`set_options`),
        then ``auto``: what a parameter file sets stands unless the command sets another value, as
        a command line ranks above a file everywhere."""
        layers: list[tuple[str, dict]] = [("dtm", {name: getattr(self, name) for name in LOW_OUTLIER_KEYS})]
        if self.filter_params:
            layers.append((self.filter_params, load_toml(self.filter_params)))
            layers.append(("dtm", self.set_options()))
        if self.auto:
            layers.append(("--auto", {"auto": True}))
        # a bad key or value is the file's, named as it is: the option alone sent users to dtm's flags
        where = f"filter_params: {self.filter_params}: " if self.filter_params else "filter_params: "
        return resolve(FILTERS[self.algorithm].params, layers, where=where).values

    def set_options(self) -> dict[str, Any]:
        """The low-outlier and existing-class options set on ``dtm`` to other than its defaults
        (one set to its default is not told from one left alone: the file's value stands)."""
        defaults = {f.name: f.default for f in fields(self)}
        return {name: getattr(self, name) for name in LOW_OUTLIER_KEYS if getattr(self, name) != defaults[name]}


def plan_neighbours(sources: list[Path], params: DtmParams, input_params) -> list[list[str]]:
    """Each job's inputs: its own file, then every other input whose extent comes within
    ``buffer`` of it. An input whose extent cannot be read gets a job of its own, which reports
    why. Over tiles, a ``--buffer`` reaching too far beyond them is refused first."""
    refuse_far_buffers(sources, params.tile_params, params.buffer)
    if params.buffer == 0 or len(sources) < 2:
        return [[str(s)] for s in sources]
    tiles = {s for s in sources if _tile_or_none(s, params) is not None}  # their jobs find their neighbours
    bounds: dict[Path, Bounds | None] = {}
    for s in sources:
        if s in tiles:
            continue
        try:
            bounds[s] = point_bounds(s, format=input_params.format)
        except AldpatError:
            bounds[s] = None
    jobs = []
    for s in sources:
        own = bounds.get(s)
        if own is None:
            jobs.append([str(s)])
            continue
        region = own.grown(params.buffer)
        near = [o for o in sources if o != s and (b := bounds.get(o)) is not None and region.meets(b)]
        jobs.append([str(s)] + [str(o) for o in near])
    return jobs


def points_used(params: DtmParams, fparams: Any = None):
    """``used(table) -> mask``: the points a DTM is made from -- with ``classes``, those of the
    classes (the file's own ground), else those taking part in finding ground with the filter's
    parameters ``fparams`` (default :meth:`DtmParams.ground_params`; :func:`aldpat.dtm` has its
    call's). Either reads no LAS dimension but x, y, z and
    :data:`~aldpat.filters.survey.TAKING_PART_FIELDS`."""
    if params.classes is not None:
        classes = parse_classes(params.classes)
        return lambda table: product_points(table, classes)
    if fparams is None:
        fparams = params.ground_params()

    def used(table: PointTable) -> np.ndarray:
        part = taking_part(table, fparams)
        return np.ones(len(table), bool) if part is None else part

    return used


def _buffer_points(ctx: JobContext, source: Path, region: Bounds, used, occupancy: Occupancy, own_crs: Any = None
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x, y, z of the neighbours' points inside ``region`` that ``used`` selects, read chunk by
    chunk; every point inside ``region`` marks ``occupancy``.

    A neighbour whose file names another CRS than ``own_crs`` (the input's own) takes no part
    either, with a warning: its coordinates are of another system, and mixed with this input's
    they would put its points where they are not (``merge`` refuses such inputs).

    A neighbour that cannot be read whole (truncated, a bad line) takes no part, with a warning
    naming it: its own job reports why, once, and this input's DTM is still made, as every
    input of a batch runs whatever the others hold. Nothing of it is kept, not even the chunks
    read before the fault, so the DTM is the one made without that neighbour."""
    xs, ys, zs = [np.zeros(0)], [np.zeros(0)], [np.zeros(0)]
    for path in ctx.neighbours:
        near_x: list[np.ndarray] = []
        near_y: list[np.ndarray] = []
        taken: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        try:
            neighbour = ctx.open_input(path)
            other_crs = getattr(neighbour, "crs", None)
            if own_crs is not None and other_crs is not None and other_crs != own_crs:
                ctx.warn(f"{source.name}: the buffer leaves out the neighbouring input {path.name}, whose CRS "
                         f"({crs_label(other_crs)}) is not this input's ({crs_label(own_crs)}); this DTM's edge "
                         "towards it has only its own points")
                continue
            for chunk in units.counted(neighbour.chunks(), f"read {path.name} (buffer)"):
                near = region.holds(chunk.x, chunk.y)
                near_x.append(np.asarray(chunk.x[near], np.float64))
                near_y.append(np.asarray(chunk.y[near], np.float64))
                inside = near & used(chunk)
                taken.append((np.asarray(chunk.x[inside], np.float64), np.asarray(chunk.y[inside], np.float64),
                              np.asarray(chunk.z[inside], np.float64)))
        except AldpatError:
            ctx.warn(f"{source.name}: the buffer leaves out the neighbouring input {path.name}, which cannot be "
                     "read (its own line says why); this DTM's edge towards it has only its own points")
            continue
        for x, y in zip(near_x, near_y, strict=True):
            occupancy.add(x, y)
        for x, y, z in taken:
            xs.append(x)
            ys.append(y)
            zs.append(z)
    return np.concatenate(xs), np.concatenate(ys), np.concatenate(zs)


def dtm_one(source: Path, params: DtmParams, ctx: JobContext) -> None:
    tile = find_tile_job(source, params.tile_params)
    if tile is not None:
        dtm_over_tiles(tile, params, ctx)
        return
    reader = ctx.open_input(source)
    say_cell_in_degrees(params.crs, reader.crs, params.cell, source.name, ctx.warn)
    made = _streamed_ground(reader, params, ctx)
    if made is None:
        made = _ground_in_memory(source, reader, params, ctx)
    x, y, z, spec, count, own_ground, occupancy = made
    del made  # the points go with x, y, z below, before the raster is written
    if len(x) == 0 and params.classes is not None:
        raise DataError(f"no ground point found by {_how(params)}: no terrain to grid; {held_classes(reader)}",
                        path=source)
    ctx.note(f"{own_ground} ground ({_how(params)})")
    if params.classes is None:
        ctx.note(_low_outlier_test(params.ground_params()))
    out = ctx.outputs_for(source)[0].path
    crs_lines: list[str] = []  # said once the DTM is made: a run that fails writes no DTM to speak of
    raster, blank = terrain_raster(x, y, z, spec, params, crs=output_crs(params.crs, reader.crs, out, crs_lines.append),
                                   where=source, occupancy=occupancy, note=ctx.note)
    for line in crs_lines:
        ctx.warn(line)
    del x, y, z, occupancy
    units.stage("write")
    raster.write(out, format=params.grid_format, overwrite=ctx.overwrite)
    log.info("%s: %d x %d nodes at %g m (%d blank)", out, spec.nx, spec.ny, params.cell, blank)
    ctx.wrote(out)
    ctx.tally(points=count, ground=own_ground, nodes=spec.nx * spec.ny, blank=blank)


#: A DTM's ground points: x, y, z (the buffer's included), the nodes, the input's point count,
#: its own ground points' count and the occupancy of every point read (its data gaps).
GroundPoints = tuple[np.ndarray, np.ndarray, np.ndarray, GridSpec, int, int, Occupancy]


def _streamed_ground(reader, params: DtmParams, ctx: JobContext) -> GroundPoints | None:
    """A LAS/LAZ without neighbours filtered in two passes (:func:`stream_ground`): the points
    are never held, only the grid and the ground points. ``None`` when it cannot go this way."""
    if params.classes is not None:
        return None  # the file's own classes: read whole, nothing to filter
    fparams = params.ground_params()
    if ctx.neighbours or reader.format != "las" or reader.count == 0 or not streamable(params.algorithm, fparams):
        return None
    # the header's extent holds every point (a point outside it ends the streaming), so the
    # DTM's nodes, from the points' own extent, are a window of this lattice (the points' own
    # extent where the header's is stale)
    extent = grid_bounds(reader, fparams, STREAM_CHUNK)
    hx0, hy0, hx1, hy1 = extent
    outer = grid_spec_for(params, xy=(np.array([hx0, hx1]), np.array([hy0, hy1])))
    assert outer is not None  # from the points
    try:
        outer.check_fits(1, path=reader.path)
    except AldpatError:
        return None  # a header far wider than its points: read whole, on the points' own extent
    occupancy = Occupancy(outer)
    made = stream_ground(reader, params.algorithm, fparams, STREAM_CHUNK, used=points_used(params),
                         seen=lambda table: occupancy.add(table.x, table.y), reads=TAKING_PART_FIELDS,
                         bounds=extent)
    if made is None:
        return None
    x, y, z, count, (xmin, ymin, xmax, ymax) = made
    spec = grid_spec_for(params, xy=(np.array([xmin, xmax]), np.array([ymin, ymax])))
    assert spec is not None  # from the points
    check_grid_fits(spec, "linear", params.grid_format, ctx.output_dir(reader.path), reader.path)
    ctx.note(f"{count} points of {reader.path.name}, filtered in two passes")
    return x, y, z, spec, count, len(x), occupancy


def _ground_in_memory(source: Path, reader, params: DtmParams, ctx: JobContext) -> GroundPoints:
    """The ground points of ``source`` read whole, with the neighbours' points within ``buffer``."""
    table = reader.read()
    if len(table) == 0:
        raise DataError("no points", path=source)
    spec = grid_spec_for(params, xy=(table.x, table.y))
    assert spec is not None  # from the points
    check_grid_fits(spec, "linear", params.grid_format, ctx.output_dir(source), source)
    region = Bounds(spec.xmin, spec.ymin, spec.xmax, spec.ymax).grown(params.buffer)
    occupancy = occupancy_over(spec, params.buffer if ctx.neighbours else 0.0)
    occupancy.add(table.x, table.y)
    used = points_used(params)
    own = table.take(used(table))
    bx, by, bz = _buffer_points(ctx, source, region, used, occupancy, getattr(reader, "crs", None))
    x = np.concatenate([np.asarray(own.x, np.float64), bx])
    y = np.concatenate([np.asarray(own.y, np.float64), by])
    z = np.concatenate([np.asarray(own.z, np.float64), bz])
    if params.classes is not None:
        ground = np.ones(len(x), bool)
    else:
        ground = filtered_ground(x, y, z, params, params.ground_params(), ctx.note)
    ctx.note(f"{len(own)} points of {source.name} and {len(bx)} of {len(ctx.neighbours)} neighbouring "
             f"inputs within {params.buffer:g} m")
    if len(own) < len(table):
        ctx.note(f"{len(table) - len(own)} points of {source.name} took no part ({_set_aside(params)})")
    return x[ground], y[ground], z[ground], spec, len(table), int(ground[:len(own)].sum()), occupancy


def occupancy_over(spec: GridSpec, reach: float) -> Occupancy:
    """An empty occupancy grid on the lattice of ``spec``, ``reach`` wider on every side."""
    k = math.ceil(reach / spec.dx) if reach > 0 else 0
    outer = GridSpec(spec.xmin - k * spec.dx, spec.ymin - k * spec.dy, spec.dx, spec.dy, spec.nx + 2 * k,
                     spec.ny + 2 * k)
    outer.check_fits(1, change="use a larger --cell or a smaller --buffer")
    return Occupancy(outer)


def _how(params: DtmParams) -> str:
    """How the DTM's ground points were found, for its log."""
    return f"class {params.classes}" if params.classes is not None else params.algorithm


def _low_outlier_test(fparams: Any) -> str:
    """The low-outlier test the filter ran, for the log: its options may come from the filter's
    defaults, a ``filter_params`` file or ``dtm``'s own (:meth:`DtmParams.ground_params`)."""
    if fparams.low_outliers is None:
        return "low-outlier test off"
    return (f"low-outlier test: {fparams.low_outliers:g} m, window {fparams.low_outlier_window} cells, reach "
            f"{fparams.low_outlier_reach:g} m")


def _set_aside(params: DtmParams) -> str:
    """Which points took no part, for the log."""
    if params.classes is not None:
        return f"withheld, not of class {params.classes}"
    fparams = params.ground_params()  # the filter's, which a filter_params file may have set
    ignored = ",".join(map(str, fparams.ignore_classes or ())) or "none"
    return f"withheld, classes {ignored}, returns {fparams.returns}"


def filtered_ground(x: np.ndarray, y: np.ndarray, z: np.ndarray, params: DtmParams, ground_params,
                    note: Callable[[str], None] | None = None) -> np.ndarray:
    """The ground flags of points held in memory: ``params.algorithm`` with ``ground_params``
    (``--auto`` applied). What ``aldpat dtm`` finds for an input read whole, and :func:`aldpat.dtm`."""
    return ground_filter(x, y, z, params.algorithm, ground_params, note=note).is_ground


def terrain_raster(x: np.ndarray, y: np.ndarray, z: np.ndarray, spec: GridSpec, params: DtmParams, *, crs=None,
                   where: Path | None = None, occupancy: Occupancy | None = None,
                   note: Callable[[str], None] | None = None) -> tuple[Raster, int]:
    """The DTM of ground points on the nodes of ``spec``, triangulated, linear inside each
    triangle (manual task 9's TIN), and its count of blank nodes. What ``aldpat dtm`` writes and
    :func:`aldpat.dtm` returns; errors name ``where``. Nodes with no point of ``occupancy`` (every
    point read, of any class) within ``max_gap`` are blank (:mod:`aldpat.core.data_gaps`)."""
    if len(x) == 0:
        raise DataError(f"no ground point found by {_how(params)}: no terrain to grid", path=where)
    check_spread(x, y, "linear", where, needs="a DTM's TIN of the ground points",
                 advice="'aldpat grid --method nearest' grids fewer")
    units.stage("triangulate")
    # float32 nodes: the values the GeoTIFF holds (each rounded once, from the TIN's float64
    # arithmetic), in half the memory of float64 ones
    values = linear(x, y, z, spec, max_distance=params.max_distance, dtype=np.float32)
    if occupancy is not None:
        gap, how = gap_distance(params, lambda: mean_spacing(occupancy))
        if gap is not None:
            blanked = blank_gaps(values, spec, occupancy, gap)
            if note is not None:
                note(f"data gaps: {blanked} nodes with no point within {gap:.3g} m ({how}) left blank")
    blank = int(np.isnan(values).sum())
    if blank == values.size:
        raise DataError("every node is blank: the ground points lie outside the DTM's extent", path=where)
    return Raster.from_nodes(values, spec, crs=crs, nodata=params.nodata, path=where), blank


def gap_distance(params: DtmParams, spacing: Callable[[], float | None]) -> tuple[float | None, str]:
    """The gap distance of ``max_gap`` (None: no test) and how it was chosen, for the log;
    ``spacing()`` gives the mean point spacing for ``auto``."""
    setting = params.gap_setting()
    if setting is None:
        return None, "--max-gap none"
    if setting != "auto":
        return float(setting), "--max-gap"
    mean = spacing()
    gap = default_gap(mean, params.cell)
    where = f"mean point spacing {mean:.3g} m" if mean else "no spacing"
    return gap, f"auto: {GAP_SPACINGS:g} x {where}, at least {GAP_CELLS:g} cells"


def _tile_or_none(source: Path, params: DtmParams) -> TileJob | None:
    try:
        return find_tile_job(source, params.tile_params)
    except AldpatError:
        return None  # the job says why


def first_jobs(sources: list[Path], params: DtmParams, input_params) -> list[list[str]]:
    """Over tiles: a first-pass job for every input tile and every neighbour within ``buffer``
    (an input or not: a DTM does not depend on which tiles were asked for at once). None with
    ``classes``: the files' own classes are the ground."""
    jobs: list[list[str]] = []
    if params.classes is not None:
        return jobs
    tiles = [(s, tile) for s in sources if (tile := _tile_or_none(s, params)) is not None]
    seen: set[Path] = set()
    # the inputs first, named as they were given (their lines say so), then the other neighbours
    for path in [s for s, _ in tiles] + [tile.file_of(row) for _, tile in tiles for row in tile.near(params.buffer)]:
        if path.resolve() not in seen and path.is_file():
            seen.add(path.resolve())
            jobs.append([str(path)])
    return jobs


def _classes_file(scratch: Path | None, path: Path, ext: str = ".npy") -> Path:
    if scratch is None:
        raise DataError("no first pass ran for the tiles (their ground classes are missing)", path=path)
    return scratch / (hashlib.sha1(str(Path(path).resolve()).encode()).hexdigest()[:20] + ext)


def classify_tile(source: Path, params: DtmParams, ctx: JobContext) -> None:
    """First pass over tiles: the ground classes of the points ``source`` owns (and of its buffer
    points standing in for a neighbour without a file), filtered with the neighbours' points within
    ``buffer`` as context; kept in the run's scratch folder for every DTM that needs them."""
    tile = find_tile_job(source, params.tile_params)
    if tile is None:
        raise DataError("not a tile of the tile parameter file", path=source)
    fmt = ctx.input.format if ctx.input is not None else None
    parts = tile_points(tile, params.buffer, fmt=fmt, keep=points_used(params))  # the others are no ground
    own = parts[0]
    flags = np.zeros(own.count, np.uint8)
    if len(own.x):
        x, y, z = (np.concatenate([getattr(p, a) for p in parts]) for a in "xyz")
        ground = ground_filter(x, y, z, params.algorithm, params.ground_params(), note=ctx.note).is_ground
        flags[own.index] = ground[:len(own.x)]
        ctx.note(f"{len(own.x)} points of {source.name} and {len(x) - len(own.x)} of {len(parts) - 1} "
                 f"neighbouring tiles within {params.buffer:g} m; {int(ground[:len(own.x)].sum())} of its own "
                 f"ground ({params.algorithm})")
    out = _classes_file(ctx.scratch, source)
    tmp = out.with_name(f"{out.stem}.{os.getpid()}.tmp.npy")
    np.save(tmp, flags)
    tmp.replace(out)
    _classes_file(ctx.scratch, source, ".txt").write_text("\n".join(ctx.result.notes), encoding="utf-8")


def _ground_of(part: OwnedPoints, scratch: Path | None, tile: TileJob) -> np.ndarray:
    """The first pass's ground flags of ``part``'s points; ``tile``: the DTM's own tile."""
    path = _classes_file(scratch, part.path)
    if not path.is_file():
        if Path(part.path).resolve() == Path(tile.source).resolve():
            raise DataError("its ground classes are missing: the ground filter failed on it", path=tile.source)
        raise DataError(f"needs the ground classes of its neighbouring tile {part.path.name}, which the ground "
                        "filter could not make (its line says why)", path=tile.source)
    return np.load(path, mmap_mode="r")[part.index] == 1


def dtm_over_tiles(tile: TileJob, params: DtmParams, ctx: JobContext) -> None:
    """A tile's DTM from the ground points it and its neighbours own, each classed by its own tile
    in the first pass (see the module docstring)."""
    fmt = ctx.input.format if ctx.input is not None else None
    if params.classes is not None:  # the files' own classes: no first pass
        parts = tile_points(tile, params.buffer, fmt=fmt, keep=points_used(params), warn=ctx.warn)
        ground = np.ones(sum(len(p.x) for p in parts), bool)
    else:
        parts = tile_points(tile, params.buffer, fmt=fmt, warn=ctx.warn)
        for line in _classes_file(ctx.scratch, tile.source, ".txt").read_text(encoding="utf-8").splitlines():
            ctx.note(line)  # what the first pass found (--auto's parameters)
        ground = np.concatenate([_ground_of(p, ctx.scratch, tile) for p in parts])
    x, y, z = (np.concatenate([getattr(p, a) for p in parts])[ground] for a in "xyz")
    own, own_ground = len(parts[0].x), int(ground[:len(parts[0].x)].sum())
    ctx.note(f"{int(ground.sum())} ground points within {params.buffer:g} m of the core of {tile.source.name}, "
             f"{own_ground} of them its own")
    units.stage("triangulate")
    made = tile_grid(tile, x, y, z, params, "linear", {"max_distance": params.max_distance}, ctx) \
        if len(x) else None
    if made is None:
        if not len(x):
            ctx.warn(f"{tile.source.name}: no ground point in or near its core; no DTM written")
        ctx.tally(points=own, ground=own_ground)
        return
    values, spec = made
    if params.gap_setting() is not None:
        every = parts if params.classes is None else tile_points(tile, params.buffer, fmt=fmt)
        _blank_tile_gaps(values, spec, every, tile, params, ctx, fmt)
    out = ctx.outputs_for(tile.source)[0].path
    units.stage("write")
    write_geotiff(out, values, spec, cog=params.grid_format == "cog", nodata=params.nodata,
                  crs=output_crs(params.crs, ctx.open_input(tile.source).crs, out, ctx.warn), overwrite=ctx.overwrite)
    ctx.wrote(out)
    ctx.tally(points=own, ground=own_ground, nodes=values.size, blank=int(np.isnan(values).sum()))


def _blank_tile_gaps(values: np.ndarray, spec: GridSpec, parts: list[OwnedPoints], tile: TileJob,
                     params: DtmParams, ctx: JobContext, fmt: str | None) -> None:
    """A tile's data gaps, decided alike in every tile holding a node: from every point within
    ``buffer`` of its core, at one gap for the whole project (the mean spacing of all its tiles'
    files, :func:`project_spacing`), at most ``buffer`` less a cell -- what each of two tiles
    sees around a node on their shared edge."""
    gap, how = gap_distance(params, lambda: project_spacing(tile, fmt))
    assert gap is not None  # the caller checked
    reach = max(params.buffer - params.cell, 0.0)
    if gap > reach:
        ctx.warn(f"{tile.source.name}: a data gap of {gap:.3g} m ({how}) is judged within --buffer "
                 f"{params.buffer:g} m less a cell: gaps are {reach:.3g} m")
        gap, how = reach, "--buffer less a cell"
    occupancy = occupancy_over(spec, params.buffer)
    for part in parts:
        occupancy.add(part.x, part.y)
    blanked = blank_gaps(values, spec, occupancy, gap)
    ctx.note(f"data gaps: {blanked} nodes with no point within {gap:.3g} m ({how}) left blank")


def project_spacing(tile: TileJob, fmt: str | None) -> float | None:
    """The mean point spacing of a project in tiles: sqrt(the area of every tile file's extent
    over its point count), the same in every job of the project."""
    area = count = 0.0
    for row in tile.rows:
        path = tile.file_of(row)
        if path.is_file():
            stat = path.stat()
            n, a = _file_density(str(path.resolve()), stat.st_mtime_ns, stat.st_size, fmt)
            count, area = count + n, area + a
    return math.sqrt(area / count) if count else None


@functools.lru_cache(maxsize=4096)
def _file_density(path: str, mtime: int, size: int, fmt: str | None) -> tuple[int, float]:
    """A point file's point count and the area of its extent (a LAS header's; a text file read once)."""
    try:
        reader = open_points(Path(path), format=fmt)
        if reader.count is not None:
            box = point_bounds(path, format=fmt)
            count = int(reader.count)
        else:
            lo, hi, count = np.array([np.inf, np.inf]), np.array([-np.inf, -np.inf]), 0
            for chunk in reader.chunks():
                if len(chunk):
                    lo = np.minimum(lo, [chunk.x.min(), chunk.y.min()])
                    hi = np.maximum(hi, [chunk.x.max(), chunk.y.max()])
                    count += len(chunk)
            box = Bounds(float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))
    except AldpatError:
        return 0, 0.0  # its own job says why
    if count == 0:
        return 0, 0.0
    return count, max(box.maxx - box.minx, 0.0) * max(box.maxy - box.miny, 0.0)


def dtm_outputs(source: Path, params: DtmParams, ctx: JobContext) -> list[Planned]:
    """``<stem>_dtm.tif``, and the run's mosaic (``--mosaic``)."""
    return [Planned(ctx.output_path(source, "_dtm", ".tif"), source), *mosaic_outputs(params, ctx)]


register_task(Task(
    name="dtm",
    summary="Points to a bare-earth DTM GeoTIFF/COG in one step: ground filter, TIN grid, tile by tile with "
            "buffers (manual tasks 8 and 9).",
    params=DtmParams,
    run_one=dtm_one,
    plan=plan_neighbours,
    finish=grid_mosaic,
    writes_points=False,
    examples=(
        ("aldpat dtm site.laz --cell 1",
         "site_dtm.tif beside it: gapm's ground points, a TIN, nodes 1 m apart, a Cloud Optimized GeoTIFF"),
        ("aldpat dtm tiles/ --odir dtm/ --mosaic dtm/dtm.vrt -j 0",
         "every tile with its neighbours' points within --buffer, and one virtual raster over them all"),
        ("aldpat dtm site.laz --algorithm atin --filter-params atin.toml",
         "another ground filter, with its parameters from a TOML file"),
    ),
    first=first_jobs,
    first_pass=classify_tile,
    outputs=dtm_outputs,
))
