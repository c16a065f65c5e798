"""Tile layout: tiles of Width x Height on a lattice, with a buffer, along x and y, x only or y only.

ALDPAT 1.0 user manual (2007), Task 7 "Tile Strips": tiles cover the rectangle Min X..Max X,
Min Y..Max Y (given, or the minimal rectangle covering all strips); "XY" increments both x and
y by the tile width and height; "X" increments only x (each tile spans the whole y range, the
height is ignored); "Y" increments only y (the width is ignored). A buffer around each tile
(Fig. 5) keeps filtering and gridding consistent across tile edges.

Tile corners lie on whole multiples of the tile size from an origin (0 0 unless given), as
lastile's and PDAL's tiles do, so that tiles cut apart, by aldpat or another tool, line up and
are named alike: a tile is named by its core's lower-left corner. Along an axis a tile spans
(direction "x" for y, "y" for x), the span is the area given, or the data's range snapped
outward to whole metres from the origin.

Every point belongs to at most one tile core: cores are half-open, [x0, x1) x [y0, y1), and the
test is made against the edge values themselves (the numbers ``tile_parameter.txt`` holds), so
that whoever reads a core back from that file puts every point in the same tile. A point also
goes to every other tile whose buffered box [x0 - b, x1 + b) x [y0 - b, y1 + b) holds it.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import overload

import numpy as np

DIRECTIONS = ("xy", "x", "y")

#: tiles along one axis at most: far beyond any survey, and a bound on what a typo can ask for
MAX_TILES_PER_AXIS = 1_000_000
#: The most copies of a point that squares with buffers may make (the area of a square with its
#: buffer over the square's own, at most 10 x 10: a buffer of 4.5 squares): past that a run writes
#: or works many times its input to gain nothing larger squares would not give. Chunks, tiles and
#: atin's rectangles all keep to it.
MOST_COPIES = 100
#: a buffer may reach this many tiles beyond a tile's core at most: each point is then copied into
#: at most 10 tiles along an axis and :data:`MOST_COPIES` over an area. A buffer of 100 tiles copied
#: every point into 40,401 tiles: ``tile --width 10 --buffer 200`` wrote 1,681 times its input
#: before a tile was done.
MAX_BUFFER_TILES = (math.sqrt(MOST_COPIES) - 1) / 2


def spanned(size: float, buffer: float) -> float:
    """How many squares of ``size`` one grown by ``buffer`` on every side spans along an axis:
    the tiles holding a point there on average (a point lies in at most the next whole number)."""
    return (size + 2 * buffer) / size


def copies_with_buffer(width: float, height: float, buffer: float) -> float:
    """How many ``width`` x ``height`` squares grown by ``buffer`` on every side hold a point, on
    average over a large area: the grown square's area over the square's."""
    return spanned(width, buffer) * spanned(height, buffer)


def least_square_for(buffer: float) -> float:
    """The smallest square side whose ``buffer`` keeps to :data:`MOST_COPIES` copies."""
    return 2 * buffer / (math.sqrt(MOST_COPIES) - 1)


@dataclass(frozen=True)
class Axis:
    """Tiles along one axis: tile ``k`` (0 <= k < n) covers [edge(k), edge(k + 1))."""

    origin: float
    size: float
    first: int  # lattice index of tile 0: its lower edge is origin + first * size
    n: int

    @classmethod
    def tiled(cls, lo: float, hi: float, size: float, origin: float, upper_included: bool) -> Axis:
        """The lattice tiles from the one holding ``lo`` to the one holding ``hi`` (or, when
        ``hi`` is an area's upper edge and not a point, the last one starting below it)."""
        for v in (lo, hi):
            if not abs((v - origin) / size) < 2.0 ** 52:  # beyond that a tile index is not exact
                raise ValueError(f"{v:g} lies {abs(v - origin):g} from the tile origin: too far for tiles of {size:g}")
        if (hi - lo) / size >= MAX_TILES_PER_AXIS:
            raise ValueError(f"{(hi - lo) / size:.3g} tiles along one axis (at most {MAX_TILES_PER_AXIS:,}): "
                             "is the tile size right?")
        lattice = cls(origin, size, 0, 1)
        first, last = (int(k) for k in lattice.index(np.array([lo, hi])))  # the test every point gets
        if not upper_included and hi > lo and lattice.edge(last) >= hi:
            last -= 1  # an area ending on a tile edge does not reach into the next tile
        return cls(origin, size, first, max(1, last - first + 1))

    @classmethod
    def spanned(cls, lo: float, hi: float, origin: float, upper_included: bool) -> Axis:
        """One tile over the area [lo, hi), or over the points from ``lo`` to ``hi``
        (``upper_included``) snapped outward to whole metres from ``origin``."""
        if not upper_included and hi > lo:
            return cls(lo, hi - lo, 0, 1)
        start = origin + math.floor(lo - origin)
        end = origin + math.floor(hi - origin) + 1.0
        return cls(start, end - start, 0, 1)

    def copies(self, buffer: float) -> float:
        """How many tiles along this axis hold a point, on average: a tile with its buffer spans
        ``(size + 2 buffer) / size`` tiles, and there are ``n`` tiles to hold it."""
        return min(float(self.n), spanned(self.size, buffer))

    @overload
    def edge(self, k: int) -> float: ...
    @overload
    def edge(self, k: np.ndarray) -> np.ndarray: ...

    def edge(self, k: int | np.ndarray) -> float | np.ndarray:
        """Lower edge of tile ``k`` (an int or an integer array)."""
        return self.origin + (self.first + k) * self.size

    def index(self, v: np.ndarray) -> np.ndarray:
        """Tile of each value along this axis, relative to tile 0 (outside 0..n-1 for values
        beyond the tiles); ``edge(k) <= v < edge(k + 1)`` holds exactly for the value returned."""
        k = np.floor((v - self.origin) / self.size).astype(np.int64) - self.first
        k -= (v < self.edge(k)).astype(np.int64)  # floating point may put a value a tile off
        k += (v >= self.edge(k + 1)).astype(np.int64)
        return k


def check_buffer(buffer: float, size: float) -> None:
    """A :class:`ValueError` when a tile's buffer reaches more than :data:`MAX_BUFFER_TILES`
    tiles of ``size`` beyond it (each point would be copied into twice that many tiles and one
    more, along this axis alone)."""
    if buffer > MAX_BUFFER_TILES * size:
        copies = math.ceil(spanned(size, buffer))
        raise ValueError(f"a buffer of {buffer:g} reaches more than {MAX_BUFFER_TILES:g} tiles of {size:g} beyond each "
                         f"tile (each point copied into up to {copies:,} tiles along this axis); use a buffer of at "
                         f"most {MAX_BUFFER_TILES * size:g} or larger tiles")


@dataclass(frozen=True)
class TileLayout:
    xs: Axis
    ys: Axis
    buffer: float

    @classmethod
    def build(cls, bounds: tuple[float, float, float, float], width: float, height: float, buffer: float,
              direction: str = "xy", origin: tuple[float, float] | None = None,
              upper_included: bool = True) -> TileLayout:
        """Tiles over ``bounds`` (MINX MINY MAXX MAXY). ``upper_included``: the bounds are the
        data's own extent, whose maximum is a point to hold; otherwise an area's upper edge."""
        minx, miny, maxx, maxy = (float(v) for v in bounds)
        if not (maxx >= minx and maxy >= miny):
            raise ValueError(f"bounds must be MINX MINY MAXX MAXY with max >= min, got {bounds!r}")
        if direction not in DIRECTIONS:
            raise ValueError(f"direction must be one of {DIRECTIONS}, got {direction!r}")
        if not (width > 0 and height > 0 and buffer >= 0):
            raise ValueError("width and height must be > 0 and buffer >= 0")
        ox, oy = (float(v) for v in (origin or (0.0, 0.0)))
        xs = Axis.spanned(minx, maxx, ox, upper_included) if direction == "y" else \
            Axis.tiled(minx, maxx, width, ox, upper_included)
        ys = Axis.spanned(miny, maxy, oy, upper_included) if direction == "x" else \
            Axis.tiled(miny, maxy, height, oy, upper_included)
        for axis in (xs, ys):
            check_buffer(buffer, axis.size)
        return cls(xs, ys, float(buffer))

    @property
    def copies(self) -> float:
        """How many tiles hold a point, its own and those whose buffers reach it (on average)."""
        return self.xs.copies(self.buffer) * self.ys.copies(self.buffer)

    @property
    def nx(self) -> int:
        return self.xs.n

    @property
    def ny(self) -> int:
        return self.ys.n

    @property
    def width(self) -> float:
        return self.xs.size

    @property
    def height(self) -> float:
        return self.ys.size

    def core(self, i: int, j: int) -> tuple[float, float, float, float]:
        """(min x, max x, min y, max y) of tile (i, j)'s core (the manual's tile_parameter order)."""
        return self.xs.edge(i), self.xs.edge(i + 1), self.ys.edge(j), self.ys.edge(j + 1)

    def core_index(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tile column and row whose core holds each point (-1, -1 outside every tile)."""
        i = self.xs.index(np.asarray(x, np.float64))
        j = self.ys.index(np.asarray(y, np.float64))
        out = (i < 0) | (i >= self.nx) | (j < 0) | (j >= self.ny)
        i[out] = -1
        j[out] = -1
        return i, j

    def _axis_members(self, v: np.ndarray, base: np.ndarray, axis: Axis) -> list[tuple[np.ndarray, np.ndarray]]:
        """(tile index, mask) pairs along one axis: tile k's buffered interval holds v where mask."""
        b = self.buffer
        reach = math.ceil(b / axis.size) + 1
        out = []
        for off in range(-reach, reach + 1):
            k = base + off
            mask = (k >= 0) & (k < axis.n) & (v >= axis.edge(k) - b) & (v < axis.edge(k + 1) + b)
            out.append((k, mask))
        return out

    def memberships(self, x: np.ndarray, y: np.ndarray
                    ) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray, bool]]:
        """Yield (tile column, tile row, point index, in the core) groups covering every (point,
        tile) pair where the point lies in the tile's core or buffer; a pair appears once over all.

        Buffer memberships are only looked for among the points within a buffer of a tile edge
        (or outside every core), so the cost stays near one pass over the chunk.
        """
        x = np.asarray(x, np.float64)
        y = np.asarray(y, np.float64)
        ci, cj = self.core_index(x, y)
        has_core = ci >= 0
        if self.buffer > 0:
            bi, bj = self.xs.index(x), self.ys.index(y)
            near = ~has_core | self._near_edge(x, bi, self.xs) | self._near_edge(y, bj, self.ys)
            cand = np.flatnonzero(near)
            if len(cand):
                cx, cy, cci, ccj = x[cand], y[cand], ci[cand], cj[cand]
                for ti, mx in self._axis_members(cx, bi[cand], self.xs):
                    for tj, my in self._axis_members(cy, bj[cand], self.ys):
                        mask = mx & my & ~((cci == ti) & (ccj == tj))  # the core pair is given below
                        if mask.any():
                            yield ti[mask], tj[mask], cand[mask], False
        rows = np.flatnonzero(has_core)
        if len(rows):
            yield ci[rows], cj[rows], rows, True

    def _near_edge(self, v: np.ndarray, k: np.ndarray, axis: Axis) -> np.ndarray:
        """Values within the buffer of an edge of their lattice tile along one axis."""
        return (v - axis.edge(k) <= self.buffer) | (axis.edge(k + 1) - v <= self.buffer)
