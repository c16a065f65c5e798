"""A grid filter over a whole file without holding its points: two streaming passes.

The morphological filters decide per *cell* (dissertation ch. 3 and §5.2.2): once every cell's
lowest height is known, the points themselves are needed again only to take their classes.
So the file is read twice, chunk by chunk -- once to keep the lowest height of every cell, once
to classify each point against the grid's decisions and write it -- and what stays in memory is
the grid alone, its heights kept as the file's own integers (:mod:`aldpat.core.height_codes`).
The classes are those :func:`aldpat.filters.driver.ground_filter` gives the same points held in
memory: the same cells, the same grid stage (:func:`aldpat.filters.grid_stage.cell_classes`), the same
per-point tests.

Which runs can go this way (:func:`streamable`): a grid filter without rotations (each needs every
point at once) that needs no parameter derived from every point (``FilterSpec.needs_every_point``),
on heights given as scaled integers. The low-outlier test decides from the grid
(:mod:`aldpat.core.low_points`), so it streams too. So does the noise of a filter that finds noise
(``outlier``, dissertation §4.1.1): a point's noise class depends only on its own height, its cell's
mark and the final ground surface at its cell (:class:`ChunkNoise`), all known after pass one --
unless the final surface test decides the points' classes, which can give the lowest point of a cell
another mark than its cell's.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from aldpat.core import units
from aldpat.core.compiled import PREFETCH_BLOCK, compiled, load_compiler_in_background, prefetch_cells
from aldpat.core.height_codes import Decode, LinearDecode, ScaledHeights
from aldpat.core.low_points import point_spacing
from aldpat.core.lowest_grid import Extent, fill_nearest, flat_cell_indices, grid_spec
from aldpat.errors import DataError
from aldpat.filters.classify import CellClasses, CellHeights
from aldpat.filters.grid_stage import cell_classes
from aldpat.filters.marks import MARK_GROUND
from aldpat.filters.options import GroundParams
from aldpat.filters.registry import get_filter
from aldpat.io.bounds import scanned_bounds
from aldpat.io.table import PointTable

if TYPE_CHECKING:
    from aldpat.io.las import LasReader

log = logging.getLogger(__name__)

#: One chunk: x, y and the height codes of its points.
CodedChunk = tuple[np.ndarray, np.ndarray, np.ndarray]


class Unstreamable(Exception):
    """The file cannot be filtered in two passes (the message says why); read it whole instead."""


def streamable(algorithm: str, params: Any) -> bool:
    """Whether ``algorithm`` with ``params`` gives the same classes in two streaming passes."""
    spec = get_filter(algorithm)
    if spec.on_points:
        return False
    if spec.noise is not None and getattr(params, "surface_threshold", None) is not None:
        return False  # the surface test may give a cell's lowest point another mark than the cell's
    if spec.rotations is not None and any(float(a) % 360.0 for a in spec.rotations(params)):
        return False
    return spec.needs_every_point(params) is None


def grid_bounds(reader: LasReader, params: GroundParams, chunk: int) -> Extent:
    """The extent the first pass lays its grid over: the header's bounds, unless their grid cannot
    be held or is far larger than the file's points need (:data:`STALE_CELLS_PER_POINT`): then
    the points' own, from a pass reading x and y alone. A tile carrying its project's header made
    every grid filter refuse it ("grid too large") or hold gigabytes for a few thousand points."""
    bounds = reader.bounds
    try:
        outer = grid_spec(np.zeros(0), np.zeros(0), params.cell, origin=params.origin, extent=bounds)
        if outer.size <= max(STALE_GRID_CELLS, STALE_CELLS_PER_POINT * reader.count):
            return bounds
    except DataError:
        pass
    own = scanned_bounds(reader.chunks(chunk, only=(), ahead=True))
    if own is None:
        return bounds
    log.info("%s: the header's bounds %s ask for a grid far larger than the points' own %s: gridding those",
             reader.path.name, bounds, own)
    return (own.minx, own.miny, own.maxx, own.maxy)


def lowest_codes(chunks: Iterable[CodedChunk], bounds: Extent, heights: ScaledHeights, cell: float,
                 origin: tuple[float, float] | None) -> CellHeights:
    """The lowest height code of every cell, over the cells of the points' own extent, and the
    points' spacing over it.

    The grid is laid over ``bounds`` (a file header's), then cut to the cells the points reach:
    the grid a whole-file run makes from the points' minima and maxima. A point outside
    ``bounds``, or a height whose code is the empty cells' own, raises :class:`Unstreamable`.
    """
    outer = grid_spec(np.zeros(0), np.zeros(0), cell, origin=origin, extent=bounds)
    ox, oy = origin if origin is not None else (0.0, 0.0)
    c_first = round((outer.x0 - ox) / cell)
    r_first = round((outer.y0 - oy) / cell)
    codes = np.full(outer.size, heights.empty, heights.dtype)
    lo = [np.inf, np.inf]
    hi = [-np.inf, -np.inf]
    count = 0
    for x, y, z in chunks:
        if not len(x):
            continue
        x, y = (np.ascontiguousarray(v, dtype=np.float64) for v in (x, y))
        bad, reach = _lowest_of_chunk(x, y, np.ascontiguousarray(z), float(ox), float(oy), float(cell), c_first, r_first,
                                      outer.rows, outer.cols, codes, heights.empty)
        if bad == _OUTSIDE:
            raise Unstreamable("a point lies outside the bounds in the file's header")
        if bad == _EMPTY_CODE:
            raise Unstreamable("a height is stored as the largest integer, the code of an empty cell")
        count += len(x)
        lo = [min(lo[0], reach[0]), min(lo[1], reach[1])]
        hi = [max(hi[0], reach[2]), max(hi[1], reach[3])]
    own = grid_spec(np.zeros(0), np.zeros(0), cell, origin=origin, extent=(lo[0], lo[1], hi[0], hi[1])
                    ) if np.isfinite(lo[0]) else outer
    grid = codes.reshape(outer.shape)
    if own != outer:
        r0 = round((own.y0 - outer.y0) / cell)
        c0 = round((own.x0 - outer.x0) / cell)
        grid = grid[r0:r0 + own.rows, c0:c0 + own.cols].copy()
    del codes
    extent = (lo[0], lo[1], hi[0], hi[1]) if np.isfinite(lo[0]) else None
    return CellHeights(own, grid, heights, owned=True, spacing=point_spacing(count, extent))


#: What :func:`_lowest_of_chunk` found wrong with a chunk: a point outside the grid, a height
#: coded as an empty cell.
_OUTSIDE, _EMPTY_CODE = 1, 2


@compiled(nogil=True)
def _lowest_of_chunk(x: np.ndarray, y: np.ndarray, z: np.ndarray, ox: float, oy: float, cell: float, c_first: int,
                     r_first: int, rows: int, cols: int, codes: np.ndarray,
                     empty: int) -> tuple[int, tuple[float, float, float, float]]:  # pragma: no cover - compiled
    """A chunk's points into the running minimum ``codes`` (flat, ``rows`` x ``cols``), in one
    pass: each point's cell ``floor((v - origin) / cell)`` less the grid's first column or row
    (:func:`aldpat.core.lowest_grid.floor_index`'s operations), and the points' lowest and highest
    x and y. ``(_OUTSIDE, ...)`` when a point's cell is off the grid, ``(_EMPTY_CODE, ...)`` when a
    height is stored as ``empty`` (and no point is off the grid): the caller then grids the file
    another way, so what the chunk wrote is never read. The cells of each block of points are
    asked for while the block before is gridded (:func:`aldpat.core.compiled.prefetch_cells`)."""
    lo_x, lo_y, hi_x, hi_y = np.inf, np.inf, -np.inf, -np.inf
    coded_empty = False
    n = len(z)
    grid = (codes.reshape(rows, cols),)
    x0, y0 = ox + c_first * cell, oy + r_first * cell  # about the grid's corner: the hint's cells
    prefetch_cells(grid, x, y, 0, min(n, PREFETCH_BLOCK), x0, y0, cell)
    for first in range(0, n, PREFETCH_BLOCK):
        stop = min(n, first + PREFETCH_BLOCK)
        prefetch_cells(grid, x, y, stop, min(n, stop + PREFETCH_BLOCK), x0, y0, cell)
        for k in range(first, stop):
            col = np.int64(math.floor((x[k] - ox) / cell)) - c_first
            row = np.int64(math.floor((y[k] - oy) / cell)) - r_first
            if col < 0 or row < 0 or col >= cols or row >= rows:
                return _OUTSIDE, (lo_x, lo_y, hi_x, hi_y)
            if z[k] >= empty:
                coded_empty = True
                continue
            flat = row * cols + col
            codes[flat] = min(codes[flat], z[k])
            lo_x, hi_x = min(lo_x, x[k]), max(hi_x, x[k])
            lo_y, hi_y = min(lo_y, y[k]), max(hi_y, y[k])
    return _EMPTY_CODE if coded_empty else 0, (lo_x, lo_y, hi_x, hi_y)


#: A header's bounds are taken for a stale one (a tile carrying its project's header) when its grid
#: has more than this many cells a point and more than :data:`STALE_GRID_CELLS`: the points' own
#: extent is read first. Sparse data at fine cells has tens of cells a point; a stale header,
#: thousands.
STALE_CELLS_PER_POINT = 256
STALE_GRID_CELLS = 1 << 24


def stream_classes(read: Callable[[], Iterator[CodedChunk]], bounds: Extent, heights: ScaledHeights,
                   algorithm: str, params: GroundParams) -> CellClasses:
    """Pass one: the grid of ``read()``'s points, through the filter's grid stage. The returned
    :class:`CellClasses` classifies the points of pass two, chunk by chunk."""
    spec = get_filter(algorithm)
    load_compiler_in_background()  # while the points are read and gridded
    cells = lowest_codes(read(), bounds, heights, params.cell, params.origin)
    log.debug("%s: %d x %d cells of %g m from two passes", algorithm, cells.spec.rows, cells.spec.cols,
              params.cell)
    units.stage("filter")
    return cell_classes(spec, cells, params, origin=params.origin, spacing=cells.spacing)


@dataclass
class _CodesAsHeights:
    """A grid of height codes read as heights: ``grid.ravel()[cells]`` decodes only those cells."""

    codes: np.ndarray
    decode: Decode

    def ravel(self) -> _CodesAsHeights:
        return self

    def __getitem__(self, cells: np.ndarray) -> np.ndarray:
        return self.decode(self.codes.ravel()[cells])


@dataclass
class _ChunkResult:
    """What a noise test reads of a filter's result (:class:`aldpat.filters.classify.FilterResult`:
    ``marks``, ``cell_index``, ``is_ground``, ``surface``), for one chunk of points."""

    marks: np.ndarray
    cell_index: np.ndarray
    is_ground: np.ndarray
    surface: _CodesAsHeights


class ChunkNoise:
    """The noise test of a filter that finds noise (``FilterSpec.noise``: ``outlier``'s classes 7
    and 18, dissertation §4.1.1) on points classified a chunk at a time.

    The whole-file test reads three things per point: its height, its cell's mark -- the mark of
    the cell's lowest point, which is the grid stage's mark of the cell when no final surface test
    runs (:func:`streamable`; a low outlier's cell and an empty one are neither removed nor ground
    either way) -- and the final ground surface at its cell: the ground cells' lowest heights, every
    other cell filled from its nearest ground cell (:func:`aldpat.filters.classify.ground_surface`),
    kept here as height codes (the same values, half the memory of float64 heights).
    """

    def __init__(self, classes: CellClasses, noise: Callable[..., np.ndarray], params: GroundParams) -> None:
        self.classes, self.noise, self.params = classes, noise, params
        ground = classes.marks == MARK_GROUND
        # no ground cell: the whole-file surface is all NaN, which makes no point noise
        self.surface = fill_nearest(classes.cells.codes, ~ground) if ground.any() else None

    def classify(self, x: np.ndarray, y: np.ndarray, z: np.ndarray, *, marks: bool = True
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(point marks, is ground, noise: -1 low, +1 high, 0 neither) of points x, y, z."""
        classes = self.classes
        cells = flat_cell_indices(x, y, classes.cells.spec, origin=classes.origin)
        point_marks, is_ground = classes.classify(x, y, z, cells, marks=marks)
        if self.surface is None:
            return point_marks, is_ground, np.zeros(len(z), np.int8)
        result = _ChunkResult(classes.marks, cells, is_ground, _CodesAsHeights(self.surface, classes.cells.heights.decode))
        return point_marks, is_ground, self.noise(result, np.asarray(z, np.float64), self.params)


def stream_ground(reader: LasReader, algorithm: str, params: GroundParams, chunk: int, *,
                  used: Callable[[PointTable], np.ndarray] | None = None,
                  seen: Callable[[PointTable], object] | None = None,
                  reads: tuple[str, ...] | None = None, bounds: Extent | None = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, Extent] | None:
    """The ground points of a LAS/LAZ file in two passes (what ``aldpat dtm`` triangulates): x, y
    and z of the ground points, the file's point count and its points' extent; the points
    themselves are never held, only the grid and the ground points' coordinates.

    ``None`` when the file cannot go this way (:func:`stream_classes`; the reason is logged): the
    caller reads it whole. The classes are those of :func:`aldpat.filters.driver.ground_filter`.
    ``used(table) -> mask`` selects the points taking part (withheld and ignored classes do not);
    the extent is every point's. ``seen(table)`` is shown every chunk of the first pass, every
    point of the file (a DTM's occupancy grid: :mod:`aldpat.core.data_gaps`). ``reads``: the LAS
    dimensions ``used`` and ``seen`` read besides x, y and z, when known: both passes then decode
    no other (:meth:`aldpat.io.las.LasReader.chunks`' ``only``). Both passes read the next chunk
    while this one is gridded or classified. ``bounds``: the extent to grid, when the caller has
    it from :func:`grid_bounds` already.
    """
    from aldpat.io.las import z_codes

    heights = reader.height_codes()
    if heights is None:
        log.info("%s: z scale not positive; reading the file whole", reader.path)
        return None

    def coded_chunks() -> Iterator[CodedChunk]:
        for table in units.counted(reader.chunks(chunk, only=reads, ahead=True), "read + grid", reader.count):
            if seen is not None:
                seen(table)
            if used is None:
                yield table.x, table.y, z_codes(table)
            else:
                part = used(table)
                yield table.x[part], table.y[part], z_codes(table)[part]

    try:
        classes = stream_classes(coded_chunks, bounds if bounds is not None else grid_bounds(reader, params, chunk),
                                 heights, algorithm, params)
    except Unstreamable as exc:
        log.info("%s: %s; reading the file whole", reader.path, exc)
        return None
    # the ground points are kept as the file's own integers while the grid is held (12 bytes a
    # point, not 24), and turned into coordinates once it is let go
    kept: tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray]] = ([], [], [])
    lo, hi = [np.inf, np.inf], [-np.inf, -np.inf]
    count = 0
    for table in units.counted(reader.chunks(chunk, only=reads, ahead=True), "classify", reader.count):
        x, y, z = (np.asarray(a, np.float64) for a in (table.x, table.y, table.z))
        ground = classes.classify(x, y, z, marks=False)[1]
        if used is not None:
            ground = ground & used(table)
        assert table.record is not None  # read from LAS/LAZ
        for parts, name in zip(kept, "XYZ", strict=True):
            parts.append(np.asarray(table.record[name])[ground])
        count += len(x)
        lo = [min(lo[0], float(x.min())), min(lo[1], float(y.min()))]
        hi = [max(hi[0], float(x.max())), max(hi[1], float(y.max()))]
    del classes
    xs, ys, zs = (_decoded(parts, float(scale), float(offset))
                  for parts, scale, offset in zip(kept, reader.header.scales, reader.header.offsets, strict=True))
    return xs, ys, zs, count, (lo[0], lo[1], hi[0], hi[1])


def _decoded(parts: list[np.ndarray], scale: float, offset: float) -> np.ndarray:
    """The chunks' integers as one array of coordinates (``integer * scale + offset``, the
    float64 laspy reads: :class:`aldpat.core.height_codes.LinearDecode`), each chunk let go once
    joined."""
    codes = np.concatenate(parts) if parts else np.zeros(0, np.int32)
    parts.clear()
    return LinearDecode(scale, offset)(codes)
