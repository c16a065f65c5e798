"""Shared by every gridding method: the points as clean float arrays, the grid's nodes in blocks
of whole rows, and the number of worker threads."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
from numpy.typing import ArrayLike

from aldpat.core.grid_extent import GridSpec
from aldpat.core.threads import thread_budget
from aldpat.errors import DataError

#: nodes queried at once by the KD-tree methods (bounds the neighbour arrays)
NODE_BLOCK = 262_144


def worker_count(workers: int | None) -> int:
    """Threads to use: the process's budget (:mod:`aldpat.core.threads`) unless a number is given."""
    return thread_budget() if not workers else int(workers)


def grid_points(x: ArrayLike, y: ArrayLike, z: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x, y, z as float64 arrays of one length, points with a non-finite value left out."""
    x, y, z = (np.asarray(a, dtype=np.float64).ravel() for a in (x, y, z))
    if not (len(x) == len(y) == len(z)):
        raise ValueError("x, y and z differ in length")
    good = np.isfinite(x) & np.isfinite(y) & np.isfinite(z)
    if not good.all():
        x, y, z = x[good], y[good], z[good]
    if len(x) == 0:
        raise DataError("no points to grid")
    return x, y, z


def row_blocks(spec: GridSpec, nodes: int = NODE_BLOCK) -> Iterator[tuple[int, int]]:
    """Slices of whole rows holding about ``nodes`` nodes each."""
    step = max(1, nodes // spec.nx)
    for r0 in range(0, spec.ny, step):
        yield r0, min(spec.ny, r0 + step)


def node_coordinates(spec: GridSpec, r0: int, r1: int, origin: tuple[float, float]) -> np.ndarray:
    """Node coordinates of rows r0..r1 (relative to ``origin``), row-major."""
    gx = spec.x_nodes() - origin[0]
    gy = spec.y_nodes()[r0:r1] - origin[1]
    out = np.empty(((r1 - r0) * spec.nx, 2))
    out[:, 0] = np.tile(gx, r1 - r0)
    out[:, 1] = np.repeat(gy, spec.nx)
    return out
