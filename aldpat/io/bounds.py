"""The horizontal extent of a point file, as cheaply as its format allows: a LAS/LAZ header
says it; a text file is read once, in chunks, keeping only the running minimum and maximum."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aldpat.io.registry import open_points
from aldpat.io.table import PointTable


@dataclass(frozen=True)
class Bounds:
    minx: float
    miny: float
    maxx: float
    maxy: float

    def grown(self, by: float) -> Bounds:
        return Bounds(self.minx - by, self.miny - by, self.maxx + by, self.maxy + by)

    def meets(self, other: Bounds) -> bool:
        """True when the two rectangles overlap or touch."""
        return (self.minx <= other.maxx and other.minx <= self.maxx
                and self.miny <= other.maxy and other.miny <= self.maxy)

    def holds(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Which of the points lie inside (edges included)."""
        return (x >= self.minx) & (x <= self.maxx) & (y >= self.miny) & (y <= self.maxy)


def point_bounds(path: str | Path, *, format: str | None = None) -> Bounds:
    """The x/y extent of the points of ``path`` (errors as :func:`open_points` raises them)."""
    reader = open_points(path, format=format)
    if reader.format == "las":
        header = reader.header  # type: ignore[attr-defined]
        (minx, miny), (maxx, maxy) = header.mins[:2], header.maxs[:2]
        return Bounds(float(minx), float(miny), float(maxx), float(maxy))
    return scanned_bounds(reader.chunks()) or Bounds(np.inf, np.inf, -np.inf, -np.inf)


def scanned_bounds(chunks: Iterable[PointTable]) -> Bounds | None:
    """The x/y extent of the points of ``chunks``, read through once keeping only the running
    minimum and maximum; None when they hold no point."""
    lo = np.array([np.inf, np.inf])
    hi = -lo
    for chunk in chunks:
        if len(chunk):
            lo = np.minimum(lo, [chunk.x.min(), chunk.y.min()])
            hi = np.maximum(hi, [chunk.x.max(), chunk.y.max()])
    return Bounds(float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])) if np.isfinite(lo[0]) else None
