"""Where the nodes of a terrain grid lie: from a tile row, from bounds, or from the data.

ALDPAT 1.0 user manual (2007), task 9 "Gridding Tiles" and Fig. 7: a grid's range is the tile's
minimum and maximum x and y taken from ``tile_parameter.txt`` (task 7, Fig. 8: one row per tile
holding the tile file's path, min x, max x, min y, max y, width, height, buffer) together with
the cell size, and "the last row and column of a grid tile overlaps with the first row and
column of the adjacent tiles". Nodes therefore sit *on* the range limits: a tile from 0 to
2000 m at 1 m has 2001 nodes a side and shares its last column with the next tile's first.
Without a reference file the manual uses the minimum and maximum x and y of the tile's points;
here those are snapped outward to whole multiples of the cell size (the grid alignment of every grid task, moved
by ``origin``) so that grids made apart still line up.

Extents are node centres, as in Surfer grids (row 0 is the southern row).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aldpat.errors import DataError, InputFormatError, InputMissingError, UsageError

log = logging.getLogger(__name__)

#: relative tolerance when checking that a range is a whole number of cells
_WHOLE = 1e-6


@dataclass(frozen=True)
class GridSpec:
    """A lattice of ``nx`` x ``ny`` nodes; (xmin, ymin) is the south-west node centre."""

    xmin: float
    ymin: float
    dx: float
    dy: float
    nx: int
    ny: int

    def __post_init__(self) -> None:
        # plain Python numbers, so that headers print them the same whatever built the spec
        for name in ("xmin", "ymin", "dx", "dy"):
            object.__setattr__(self, name, float(getattr(self, name)))
        for name in ("nx", "ny"):
            object.__setattr__(self, name, int(getattr(self, name)))
        if not (self.dx > 0 and self.dy > 0):
            raise UsageError(f"grid spacing must be positive, got {self.dx:g} x {self.dy:g}")
        if self.nx < 1 or self.ny < 1:
            raise UsageError(f"grid needs at least one node a side, got {self.nx} x {self.ny}")

    @property
    def xmax(self) -> float:
        return self.xmin + (self.nx - 1) * self.dx

    @property
    def ymax(self) -> float:
        return self.ymin + (self.ny - 1) * self.dy

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, columns), rows from the south."""
        return self.ny, self.nx

    def x_nodes(self) -> np.ndarray:
        return self.xmin + np.arange(self.nx) * self.dx

    def y_nodes(self) -> np.ndarray:
        return self.ymin + np.arange(self.ny) * self.dy

    def corner_transform(self) -> tuple[float, float, float, float, float, float]:
        """GDAL geotransform of the north-up raster whose cells are centred on the nodes."""
        return (self.xmin - self.dx / 2, self.dx, 0.0, self.ymax + self.dy / 2, 0.0, -self.dy)

    def nearest_node(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Column, row and an inside mask of the node whose cell holds each point.

        A node's cell is the ``dx`` x ``dy`` square centred on it (half-open towards east and
        north), so every point within half a cell of the grid belongs to exactly one node.
        """
        col = np.floor((np.asarray(x, dtype=float) - self.xmin) / self.dx + 0.5).astype(np.int64)
        row = np.floor((np.asarray(y, dtype=float) - self.ymin) / self.dy + 0.5).astype(np.int64)
        inside = (col >= 0) & (col < self.nx) & (row >= 0) & (row < self.ny)
        return col, row, inside


def whole_cells(lo: float, hi: float, cell: float) -> bool:
    """Whether ``hi - lo`` is a whole number of cells (to a relative 1e-6)."""
    steps = (hi - lo) / cell
    return abs(steps - round(steps)) <= _WHOLE * max(1.0, steps)


def _count(lo: float, hi: float, cell: float, what: str) -> int:
    """Nodes from ``lo`` to ``hi`` inclusive at ``cell`` spacing; ranges not a whole number of
    cells are extended (with a warning) so the grid still covers them."""
    if hi < lo:
        raise UsageError(f"{what}: maximum {hi:g} is below minimum {lo:g}")
    steps = (hi - lo) / cell
    if whole_cells(lo, hi, cell):
        return round(steps) + 1
    log.warning("%s range %g..%g is not a whole number of %g cells; grid extended to %g",
                what, lo, hi, cell, lo + math.ceil(steps) * cell)
    return math.ceil(steps) + 1


def from_bounds(minx: float, miny: float, maxx: float, maxy: float, cell: float) -> GridSpec:
    """Nodes on the bounds themselves (the first and last row and column lie on them)."""
    if not cell > 0:
        raise UsageError(f"cell size must be positive, got {cell:g}")
    return GridSpec(minx, miny, cell, cell, _count(minx, maxx, cell, "x"), _count(miny, maxy, cell, "y"))


def from_data(x: np.ndarray, y: np.ndarray, cell: float, *, origin: tuple[float, float] = (0.0, 0.0)) -> GridSpec:
    """The smallest grid on whole multiples of ``cell`` (from ``origin``) covering the points."""
    if len(x) == 0:
        raise DataError("no points to grid")
    if not cell > 0:
        raise UsageError(f"cell size must be positive, got {cell:g}")
    ox, oy = origin
    lo_x = ox + math.floor((float(np.min(x)) - ox) / cell) * cell
    lo_y = oy + math.floor((float(np.min(y)) - oy) / cell) * cell
    nx = math.ceil((float(np.max(x)) - lo_x) / cell - _WHOLE) + 1
    ny = math.ceil((float(np.max(y)) - lo_y) / cell - _WHOLE) + 1
    # Surfer grids need two nodes a side to define a spacing.
    return GridSpec(lo_x, lo_y, cell, cell, max(nx, 2), max(ny, 2))


# ------------------------------------------------------------------ tile_parameter.txt


@dataclass(frozen=True)
class TileRow:
    """One row of ``tile_parameter.txt`` (manual task 7, Fig. 8)."""

    path: Path
    minx: float
    maxx: float
    miny: float
    maxy: float
    width: float
    height: float
    buffer: float
    line: int

    def grid(self, cell: float) -> GridSpec:
        return from_bounds(self.minx, self.miny, self.maxx, self.maxy, cell)


def _parse_row(text: str) -> tuple[str, list[float]] | None:
    """Split a row into its path and seven numbers; None for a header line.

    The path may hold spaces: comma- or tab-separated rows split on that delimiter, others on
    the last seven runs of white space.
    """
    if "," in text:
        parts = [p.strip() for p in text.rsplit(",", 7)]
    elif "\t" in text:
        parts = [p.strip() for p in text.rsplit("\t", 7)]
    else:
        parts = text.rsplit(None, 7)
    if len(parts) != 8:
        return None
    try:
        numbers = [float(p) for p in parts[1:]]
    except ValueError:
        return None
    return parts[0].strip().strip('"'), numbers


def read_tile_parameters(path: str | Path) -> list[TileRow]:
    """All tile rows; relative tile paths are taken from the parameter file's folder."""
    path = Path(path)
    if not path.is_file():
        raise InputMissingError("no such tile parameter file", path=path)
    rows: list[TileRow] = []
    with open(path, encoding="utf-8", errors="replace") as fh:
        for number, raw in enumerate(fh, start=1):
            text = raw.strip()
            if not text or text.startswith("#"):
                continue
            parsed = _parse_row(text)
            if parsed is None:
                if rows:
                    raise InputFormatError(
                        "expected: path, min x, max x, min y, max y, width, height, buffer", path=path, line=number)
                continue  # header line
            name, (minx, maxx, miny, maxy, width, height, buffer) = parsed
            if maxx <= minx or maxy <= miny:
                raise InputFormatError(f"tile range is empty ({minx:g}..{maxx:g}, {miny:g}..{maxy:g})",
                                       path=path, line=number)
            tile = Path(name.replace("\\", "/"))
            if not tile.is_absolute():
                tile = path.parent / tile
            rows.append(TileRow(tile, minx, maxx, miny, maxy, width, height, buffer, number))
    if not rows:
        raise InputFormatError("no tile rows", path=path)
    return rows


def tile_row_for(params_path: str | Path, input_path: str | Path) -> TileRow:
    """The row of ``params_path`` describing ``input_path``.

    Matched by path, then by file name, then by stem; a filtered tile (``tile_1_2_gapm.txt``)
    matches its tile (``tile_1_2.txt``) through the longest row stem it starts with followed by
    ``_``, because task 9 grids the filter's output of task 8.
    """
    rows = read_tile_parameters(params_path)
    input_path = Path(input_path)
    target = input_path.resolve()
    for row in rows:
        if row.path.resolve() == target:
            return row
    for key in (lambda p: p.name.lower(), lambda p: p.stem.lower()):
        hits = [r for r in rows if key(r.path) == key(input_path)]
        if hits:
            return hits[0]
    stem = input_path.stem.lower()
    prefixed = [r for r in rows if stem.startswith(r.path.stem.lower() + "_")]
    if prefixed:
        return max(prefixed, key=lambda r: len(r.path.stem))
    raise DataError(f"no row for {input_path.name} in tile parameter file {params_path}", path=input_path)
