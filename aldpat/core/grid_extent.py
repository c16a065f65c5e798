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
from typing import Any

import numpy as np

from aldpat.core.resources import check_memory, count_text
from aldpat.errors import DataError, UsageError

log = logging.getLogger(__name__)

#: relative tolerance when checking that a range is a whole number of cells
_WHOLE = 1e-6
#: the most nodes a grid has a side: GDAL's raster sizes (and Surfer 7's) are 32-bit integers
MOST_A_SIDE = 2**31 - 1


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

    def check_fits(self, bytes_per_node: float, *, path: str | Path | None = None,
                   change: str = "use a larger --cell, or tile the data (aldpat tile)") -> None:
        """Refuse (:class:`aldpat.core.resources.ResourceError`, naming ``path``) a grid whose
        nodes, at ``bytes_per_node`` while it is made, need more memory than there is now."""
        nodes = self.nx * self.ny
        check_memory(nodes * bytes_per_node, f"a {self.nx} x {self.ny} grid ({count_text(nodes)} nodes) of "
                     f"{self.dx:g} m cells", change, path=path)

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
    steps = steps_between(lo, hi, cell, what)
    if whole_cells(lo, hi, cell):
        return round(steps) + 1
    log.warning("%s range %g..%g is not a whole number of %g-unit cells; the grid is extended to %g to cover it",
                what, lo, hi, cell, lo + math.ceil(steps) * cell)
    return math.ceil(steps) + 1


def steps_between(lo: float, hi: float, cell: float, what: str = "range") -> float:
    """``(hi - lo) / cell``, refused (:class:`DataError`) when no grid could have that many
    nodes a side (a cell of 1e-300 m, a range of 1e300 m)."""
    steps = (hi - lo) / cell
    if not abs(steps) < MOST_A_SIDE:  # NaN and infinity too
        raise DataError(f"{what} {lo:g} .. {hi:g} at {cell:g} m cells would take {abs(steps):.3g} nodes a side, "
                        f"more than a grid holds ({MOST_A_SIDE}); use a larger cell, or look for stray points far "
                        "from the others (a wrong coordinate in the file)")
    return steps


def steps_from_origin(lo: float, hi: float, cell: float, what: str) -> float:
    """``(hi - lo) / cell`` where only a finite count is asked for: the cells from a grid's origin
    to the data, which may be many more than the grid has (UTM northings at millimetre cells)."""
    steps = (hi - lo) / cell
    if not math.isfinite(steps):
        raise DataError(f"{what} {lo:g} .. {hi:g} at {cell:g} m cells is not a finite number of cells")
    return steps


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
    x_min, x_max, y_min, y_max = float(np.min(x)), float(np.max(x)), float(np.min(y)), float(np.max(y))
    # The data's own extent decides whether a grid can hold it (and names it in the refusal);
    # the whole cells from the origin to it may be many more (UTM northings at millimetre cells).
    steps_between(x_min, x_max, cell, "x")
    steps_between(y_min, y_max, cell, "y")
    lo_x = ox + math.floor(steps_from_origin(ox, x_min, cell, "x")) * cell
    lo_y = oy + math.floor(steps_from_origin(oy, y_min, cell, "y")) * cell
    nx = math.ceil(steps_between(lo_x, x_max, cell, "x") - _WHOLE) + 1
    ny = math.ceil(steps_between(lo_y, y_max, cell, "y") - _WHOLE) + 1
    # Surfer grids need two nodes a side to define a spacing.
    return GridSpec(lo_x, lo_y, cell, cell, max(nx, 2), max(ny, 2))


def refuse_held_nodata(values: np.ndarray, nodata: float, path: str | Path, dtype: Any = np.float64) -> None:
    """Refuse (:class:`DataError`) a grid a node of which holds its ``nodata`` value itself, as the
    file stores it (``dtype``): read back, that node would be blank. Every grid format with a
    nodata value of the user's (GeoTIFF, ArcGIS grids, Surfer 7) asks this before it writes."""
    kind = np.dtype(dtype).type
    stored = np.asarray(values).astype(dtype, copy=False)
    if np.any(stored == kind(nodata)):  # NaN equals nothing: blank nodes never match
        raise DataError(f"a node holds the nodata value {nodata:g} itself; choose another nodata value",
                        path=Path(path))
