"""Tile layout: tiles of Width x Height with a buffer, along x and y, x only or y only.

ALDPAT 1.0 user manual (2007), Task 7 "Tile Strips": tiles cover the rectangle Min X..Max X,
Min Y..Max Y (given, or the minimal rectangle covering all strips); "XY" increments both x and
y by the tile width and height; "X" increments only x (each tile spans the whole y range, the
height is ignored); "Y" increments only y (the width is ignored). A buffer around each tile
(Fig. 5) keeps filtering and gridding consistent across tile edges.

Every point inside the rectangle belongs to exactly one tile core: cores are half-open
[x0, x1) x [y0, y1), except that the last column and row also take their upper edge (so the
point at Max X, Max Y is not lost). Tiles keep their full size: the last column and row may
reach beyond Max X and Max Y, and points there belong to them. A point also goes to every other tile whose buffered box
[x0 - b, x1 + b) x [y0 - b, y1 + b) holds it.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

DIRECTIONS = ("xy", "x", "y")


@dataclass(frozen=True)
class TileLayout:
    minx: float
    miny: float
    maxx: float
    maxy: float
    width: float  # effective tile width (the whole x range for direction "y")
    height: float  # effective tile height (the whole y range for direction "x")
    buffer: float
    nx: int
    ny: int

    @classmethod
    def build(cls, bounds: tuple[float, float, float, float], width: float, height: float, buffer: float,
              direction: str = "xy") -> TileLayout:
        minx, miny, maxx, maxy = (float(v) for v in bounds)
        if not (maxx >= minx and maxy >= miny):
            raise ValueError(f"bounds must be MINX MINY MAXX MAXY with max >= min, got {bounds!r}")
        if direction not in DIRECTIONS:
            raise ValueError(f"direction must be one of {DIRECTIONS}, got {direction!r}")
        if not (width > 0 and height > 0 and buffer >= 0):
            raise ValueError("width and height must be > 0 and buffer >= 0")
        if direction == "y":
            width = max(maxx - minx, 0.0)
        if direction == "x":
            height = max(maxy - miny, 0.0)

        def count(extent: float, size: float) -> int:
            if size <= 0:
                return 1
            # a hair of tolerance: 2000.0000000001 / 1000 is still 2 tiles
            return max(1, math.ceil(extent / size - 1e-9))

        return cls(minx, miny, maxx, maxy, float(width), float(height), float(buffer),
                   count(maxx - minx, width), count(maxy - miny, height))

    def __len__(self) -> int:
        return self.nx * self.ny

    def core(self, i: int, j: int) -> tuple[float, float, float, float]:
        """(min x, max x, min y, max y) of tile (i, j)'s core (the manual's tile_parameter order)."""
        x0 = self.minx + i * self.width
        y0 = self.miny + j * self.height
        return x0, x0 + self.width, y0, y0 + self.height

    def _axis_core(self, v: np.ndarray, lo: float, size: float, n: int) -> np.ndarray:
        """Core index along one axis; -1 outside [lo, lo + n*size] (the last tile keeps its upper edge)."""
        if size > 0:
            k = np.floor((v - lo) / size).astype(np.int64)
        else:
            k = np.zeros(len(v), dtype=np.int64)
        hi = lo + n * size
        k[(k >= n) & (v <= hi)] = n - 1
        k[(v < lo) | (v > hi) | (k >= n)] = -1
        return k

    def core_index(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tile column and row whose core holds each point (-1, -1 outside the bounds)."""
        i = self._axis_core(np.asarray(x, np.float64), self.minx, self.width, self.nx)
        j = self._axis_core(np.asarray(y, np.float64), self.miny, self.height, self.ny)
        out = (i < 0) | (j < 0)
        i[out] = -1
        j[out] = -1
        return i, j

    def _axis_members(self, v: np.ndarray, lo: float, size: float, n: int) -> list[tuple[np.ndarray, np.ndarray]]:
        """(tile index, mask) pairs along one axis: tile k's buffered interval holds v where mask."""
        u = v - lo
        b = self.buffer
        if size <= 0:  # one tile of zero extent
            return [(np.zeros(len(v), np.int64), (u >= -b) & (u <= b))]
        base = np.floor(u / size).astype(np.int64)
        reach = math.ceil(b / size) + 1
        out = []
        for off in range(-reach, reach + 1):
            k = base + off
            mask = (k >= 0) & (k < n) & (u >= k * size - b) & (u < (k + 1) * size + b)
            out.append((k, mask))
        return out

    def memberships(self, x: np.ndarray, y: np.ndarray) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Yield (tile column, tile row, point index) triples of arrays covering every (point, tile)
        pair where the point lies in the tile's core or buffer; a pair appears once over all.

        Buffer memberships are only looked for among the points within a buffer of a tile edge
        (or outside every core), so the cost stays near one pass over the chunk.
        """
        x = np.asarray(x, np.float64)
        y = np.asarray(y, np.float64)
        ci, cj = self.core_index(x, y)
        has_core = ci >= 0
        if self.buffer > 0:
            near = ~has_core | self._near_edge(x, self.minx, self.width) | self._near_edge(y, self.miny, self.height)
            cand = np.flatnonzero(near)
            if len(cand):
                cx, cy, cci, ccj = x[cand], y[cand], ci[cand], cj[cand]
                for ti, mx in self._axis_members(cx, self.minx, self.width, self.nx):
                    for tj, my in self._axis_members(cy, self.miny, self.height, self.ny):
                        # the core pair is given below, once, with the closed upper edge
                        mask = mx & my & ~((cci == ti) & (ccj == tj))
                        if mask.any():
                            yield ti[mask], tj[mask], cand[mask]
        rows = np.flatnonzero(has_core)
        if len(rows):
            yield ci[rows], cj[rows], rows

    def _near_edge(self, v: np.ndarray, lo: float, size: float) -> np.ndarray:
        """Points within the buffer (plus a rounding margin) of a tile edge along one axis."""
        if size <= 0:
            return np.ones(len(v), dtype=bool)
        u = v - lo
        off = u - np.floor(u / size) * size
        margin = self.buffer + 1e-9 * (abs(lo) + size + np.abs(u))
        return (off <= margin) | (size - off <= margin)
