"""A project in tiles as the job over one tile sees it: the tile's row of ``tile_parameter.txt``,
the tiles around it, and the points each tile owns.

ALDPAT 1.0 user manual (2007), task 7 "Tile Strips" (Fig. 8): every row holds a tile's core
(its range without the buffer); a point belongs to the tile whose core holds it,
``min x <= x < max x`` and ``min y <= y < max y``. A tile's buffer points are copies of its
neighbours' points, so a job over a tile takes its own points from its own file and the points
near its core from its neighbours' files, each from the tile that owns it: every point once, and
with the class its own tile gave it.

A job's input may be a tile (``tiles/tile_A.laz``) or a file made from one
(``ground/tile_A_gapm.laz``, found through the row whose stem it starts with, as
:func:`~aldpat.io.tile_parameters.tile_row_for` does); a neighbour's file is named the same way
(``ground/tile_B_gapm.laz``). A neighbour without such a file lends the points the job's own file
holds in its core (its buffer points), with a warning.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aldpat.core.crs import crs_label
from aldpat.core.tiles import MAX_BUFFER_TILES
from aldpat.errors import AldpatError, DataError, UsageError
from aldpat.io.registry import open_points
from aldpat.io.tile_parameters import PARAMETER_FILE, TileRow, read_tile_parameters, row_for

#: ``keep(chunk) -> mask``: which points of a chunk take part (all when None)
Keep = Callable[..., np.ndarray] | None


@dataclass(frozen=True)
class TileJob:
    """The tile of one job's input, among every tile of the project."""

    source: Path
    row: TileRow
    rows: tuple[TileRow, ...]

    @property
    def core(self) -> tuple[float, float, float, float]:
        return self.row.minx, self.row.maxx, self.row.miny, self.row.maxy

    def near(self, reach: float) -> list[TileRow]:
        """The other tiles whose core comes within ``reach`` of this one's (touching included)."""
        r = self.row
        return [o for o in self.rows if o is not r and o.minx <= r.maxx + reach and r.minx <= o.maxx + reach
                and o.miny <= r.maxy + reach and r.miny <= o.maxy + reach]

    def file_of(self, row: TileRow) -> Path:
        """The file of tile ``row`` made as this job's input was made from its tile."""
        if row is self.row:
            return self.source
        if self.source.resolve() == self.row.path.resolve():
            return row.path
        own = self.row.path.stem
        suffix = self.source.stem[len(own):] if self.source.stem.lower().startswith(own.lower()) else ""
        return self.source.parent / f"{row.path.stem}{suffix}{self.source.suffix}"


@functools.lru_cache(maxsize=4)
def _project(path: str, stamp: tuple[int, int]) -> tuple[tuple[TileRow, ...], dict[Path, TileRow]]:
    """The rows of a tile parameter file (as of ``stamp``: its size and time), and each by its
    tile's resolved path: a project of thousands of tiles plans each job without reading the file
    and resolving every path again."""
    rows = tuple(read_tile_parameters(path))
    return rows, {row.path.resolve(): row for row in rows}


def _tile_row(params_path: Path, source: Path) -> tuple[tuple[TileRow, ...], TileRow]:
    try:
        info = params_path.stat()
    except OSError:
        read_tile_parameters(params_path)  # says why it cannot be read
        raise
    rows, by_path = _project(str(params_path.resolve()), (info.st_size, info.st_mtime_ns))
    row = by_path.get(source.resolve())
    return rows, row if row is not None else row_for(list(rows), source, params_path)


def find_tile_job(source: Path, params_path: str | Path | None) -> TileJob | None:
    """The tile of ``source`` from ``params_path``, or from the ``tile_parameter.txt`` beside it
    when it lists it; None when the input is not a tile."""
    source = Path(source)
    if params_path is None:
        beside = source.parent / PARAMETER_FILE
        if not beside.is_file():
            return None
        try:
            rows, row = _tile_row(beside, source)
        except DataError:
            return None
    else:
        rows, row = _tile_row(Path(params_path), source)
    for other in rows:
        if other is not row and other.minx < row.maxx and row.minx < other.maxx and other.miny < row.maxy \
                and row.miny < other.maxy:
            raise DataError(f"the cores of {row.path.name} and {other.path.name} overlap (tile parameter "
                            f"lines {row.line} and {other.line}): a point must belong to one tile", path=source)
    return TileJob(source, row, tuple(rows))


def in_core(row: TileRow, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    return (x >= row.minx) & (x < row.maxx) & (y >= row.miny) & (y < row.maxy)


@dataclass
class OwnedPoints:
    """Points of one file: coordinates, and where each is in the file (its classes' index)."""

    path: Path
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    index: np.ndarray
    count: int  # points in the file


def owned_points(path: Path, cores: list[TileRow], region: tuple[float, float, float, float], *,
                 fmt: str | None = None, keep: Keep = None) -> OwnedPoints:
    """The points of ``path`` inside one of ``cores`` and inside ``region`` (min x, max x, min y,
    max y, closed), read chunk by chunk. A file holding no points (a LAS tile whose header says 0)
    owns none: it is a tile without data, not one that cannot be read, and its neighbours, which
    read it for their buffers, go on without points from it."""
    x0, x1, y0, y1 = region
    xs, ys, zs, idx = [np.zeros(0)], [np.zeros(0)], [np.zeros(0)], [np.zeros(0, np.int64)]
    start = 0
    reader = open_points(path, format=fmt)
    for chunk in (reader.chunks() if reader.count != 0 else ()):
        x, y = np.asarray(chunk.x, np.float64), np.asarray(chunk.y, np.float64)
        take = (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)
        owned = np.zeros(len(x), bool)
        for row in cores:
            owned |= in_core(row, x, y)
        take &= owned
        if keep is not None:
            take &= keep(chunk)
        rows = np.flatnonzero(take)
        xs.append(x[rows])
        ys.append(y[rows])
        zs.append(np.asarray(chunk.z, np.float64)[rows])
        idx.append(rows + start)
        start += len(x)
    return OwnedPoints(Path(path), np.concatenate(xs), np.concatenate(ys), np.concatenate(zs), np.concatenate(idx),
                       start)


def too_far(job: TileJob, reach: float) -> str | None:
    """Why a buffer of ``reach`` around the job's tile is refused, or None: as ``tile`` refuses
    such buffers, beyond :data:`MAX_BUFFER_TILES` tiles every tile's job would read its
    neighbours' points out to many tiles away, the project's points again and again."""
    x0, x1, y0, y1 = job.core
    side = min(x1 - x0, y1 - y0)
    if reach <= MAX_BUFFER_TILES * side:
        return None
    return (f"a buffer of {reach:g} m reaches more than {MAX_BUFFER_TILES:g} tiles of {side:g} m beyond the tile "
            f"({len(job.near(reach))} neighbouring tiles); use a --buffer of at most {MAX_BUFFER_TILES * side:g}")


def refuse_far_buffers(sources: list[Path], params_path: str | Path | None, reach: float) -> None:
    """Refuse a run over tiles (a :class:`UsageError`, before anything runs) whose ``--buffer``
    reaches too far beyond a tile (:func:`too_far`): one line for the run, naming the first such
    tile, not one failed job for each. An input that is not a tile, or whose tile cannot be
    read, is left to its job."""
    for source in sources:
        try:
            job = find_tile_job(source, params_path)
        except AldpatError:
            continue
        if job is not None and (why := too_far(job, reach)) is not None:
            raise UsageError(f"{Path(source).name}: {why}")


def tile_points(job: TileJob, reach: float, *, fmt: str | None = None, keep: Keep = None,
                warn: Callable[[str], None] | None = None) -> list[OwnedPoints]:
    """The points within ``reach`` of the job's core, each from the file of the tile owning it:
    the job's own file first, then each neighbour's."""
    x0, x1, y0, y1 = job.core
    if (why := too_far(job, reach)) is not None:  # a run refused it already; a caller of its own
        raise DataError(why, path=job.source)
    region = (x0 - reach, x1 + reach, y0 - reach, y1 + reach)
    near = job.near(reach)
    present = [(row, job.file_of(row)) for row in near]
    missing = [row for row, path in present if not path.is_file()]
    for row in missing:
        if warn is not None:
            warn(f"{job.source.name}: no file {job.file_of(row).name} for the neighbouring tile "
                 f"{row.path.name}: its points near the edge are this tile's buffer points")
    parts = [owned_points(job.source, [job.row, *missing], region, fmt=fmt, keep=keep)]
    own_crs = getattr(open_points(job.source, format=fmt), "crs", None)
    for row, path in present:
        if row in missing:
            continue
        try:
            other_crs = getattr(open_points(path, format=fmt), "crs", None)
        except AldpatError:
            other_crs = None  # said below, when its points are read
        if own_crs is not None and other_crs is not None and other_crs != own_crs:
            # its coordinates are of another system: as a tile that cannot be read, it is waited for
            raise DataError(f"needs the points of its neighbouring tile {path.name} within {reach:g} m, whose CRS "
                            f"({crs_label(other_crs)}) is not this tile's ({crs_label(own_crs)})", path=job.source)
        try:
            parts.append(owned_points(path, [row], region, fmt=fmt, keep=keep))
        except AldpatError:
            # without its points the shared edge would differ from the neighbour's once it is
            # mended, so the tile waits for it (its own job says what is wrong with it, once)
            raise DataError(f"needs the points of its neighbouring tile {path.name} within {reach:g} m, and that "
                            "file cannot be read (its own line says why)", path=job.source) from None
    return parts
