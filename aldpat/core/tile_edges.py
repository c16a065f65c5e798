"""Grids of a project in tiles: every tile's nodes on one lattice, and the nodes a tile shares with
its neighbours computed alike in each of them.

ALDPAT 1.0 user manual (2007), task 9 "Gridding Tiles" and Fig. 7: a tile is gridded over its core
(its row of ``tile_parameter.txt``, task 7, Fig. 8), and "the last row and column of a grid tile
overlaps with the first row and column of the adjacent tiles". Here the nodes of every tile are
those of one lattice -- whole multiples of the cell from the origin -- that lie in its closed
core, so a tile edge on the lattice is a column or row that both tiles hold.

Such a node must carry one value, bit for bit, in both tiles. Each tile interpolates from its own
points and its neighbours' within a buffer, so the two point sets differ far from the edge, and
an interpolator's result at a node depends, a little, on every point it was given and on their
order (a TIN's triangles on a grid of points that are exactly cocircular, a sum's rounding). The
nodes on an edge are therefore computed again from the points within ``reach`` of that edge
alone, sorted by (x, y, z), on a lattice spelt from the edge's own coordinates: the two tiles
pass the very same arrays to the very same interpolator and get the very same values. A corner
node, held by up to four tiles, is computed from the points within ``reach`` of the corner. An
edge no other tile holds, on the project's outer edge, keeps the tile's own values.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from aldpat.core.grid_extent import GridSpec
from aldpat.errors import DataError

#: tolerance (in cells) for a tile edge lying on the node lattice
_ON_LATTICE = 1e-6

#: ``fn(x, y, z, spec) -> values``: an interpolator (``aldpat.core.interpolate.interpolate`` with
#: its options bound)
Gridder = Callable[[np.ndarray, np.ndarray, np.ndarray, GridSpec], np.ndarray]
#: a tile's core or a box of points: min x, max x, min y, max y (closed)
Box = tuple[float, float, float, float]


def _first_node(v: float, o: float, cell: float, up: bool) -> tuple[int, float]:
    """The lattice index of the first node at or above ``v`` (``up``) or at or below it, and the
    node's coordinate: ``v`` itself when it lies on the lattice (so that two tiles reading the
    same edge value from tile_parameter.txt place the node identically)."""
    steps = (v - o) / cell
    k = math.ceil(steps - _ON_LATTICE) if up else math.floor(steps + _ON_LATTICE)
    on = abs(steps - k) <= _ON_LATTICE
    return k, (v if on else o + k * cell)


def on_lattice(v: float, o: float, cell: float) -> bool:
    steps = (v - o) / cell
    return abs(steps - round(steps)) <= _ON_LATTICE


def core_nodes(core: tuple[float, float, float, float], cell: float,
               origin: tuple[float, float] = (0.0, 0.0)) -> GridSpec | None:
    """The lattice nodes inside the closed core (min x, max x, min y, max y); None when none."""
    x0, x1, y0, y1 = core
    kx0, xmin = _first_node(x0, origin[0], cell, True)
    kx1, _ = _first_node(x1, origin[0], cell, False)
    ky0, ymin = _first_node(y0, origin[1], cell, True)
    ky1, _ = _first_node(y1, origin[1], cell, False)
    if kx1 < kx0 or ky1 < ky0:
        return None
    return GridSpec(xmin, ymin, cell, cell, kx1 - kx0 + 1, ky1 - ky0 + 1)


@dataclass(frozen=True)
class SharedNodes:
    """Nodes of a tile's grid on one edge or corner of its core: where they are in the grid, the
    lattice they are computed on (the same in every tile holding them) and the box of points they
    are computed from."""

    rows: slice
    cols: slice
    spec: GridSpec
    box: Box  # the points they are computed from


def _meets(a: Box, b: Box, tol: float) -> bool:
    """Whether the closed boxes ``a`` and ``b`` have a point in common."""
    return a[0] - tol <= b[1] and b[0] <= a[1] + tol and a[2] - tol <= b[3] and b[2] <= a[3] + tol


def shared_nodes(spec: GridSpec, core: Box, origin: tuple[float, float], reach: float,
                 others: Sequence[Box] | None = None) -> Iterator[SharedNodes]:
    """The edges on the lattice, then the corners on it (a corner's value replaces its edges');
    with ``others`` (the other tiles' cores) only those another tile holds a node of -- for an
    edge, a node that is not one of its corners: on the project's outer edge the tile's own
    interpolation stands, as in a grid of the whole site."""
    x0, x1, y0, y1 = core
    cell = spec.dx
    ox, oy = origin
    xs = [(x0, slice(0, 1)), (x1, slice(spec.nx - 1, spec.nx))]
    ys = [(y0, slice(0, 1)), (y1, slice(spec.ny - 1, spec.ny))]
    xs = [(v, s) for v, s in xs if on_lattice(v, ox, cell)]
    ys = [(v, s) for v, s in ys if on_lattice(v, oy, cell)]
    # the nodes of a column or row between its corners (empty when lo > hi)
    ylo, yhi = spec.ymin + cell * (y0 in dict(ys)), spec.ymax - cell * (y1 in dict(ys))
    xlo, xhi = spec.xmin + cell * (x0 in dict(xs)), spec.xmax - cell * (x1 in dict(xs))
    parts = [((x, x, ylo, yhi), SharedNodes(slice(0, spec.ny), cols, GridSpec(x, spec.ymin, cell, cell, 1, spec.ny),
                                             (x - reach, x + reach, y0 - reach, y1 + reach))) for x, cols in xs]
    parts += [((xlo, xhi, y, y), SharedNodes(rows, slice(0, spec.nx), GridSpec(spec.xmin, y, cell, cell, spec.nx, 1),
                                              (x0 - reach, x1 + reach, y - reach, y + reach))) for y, rows in ys]
    parts += [((x, x, y, y), SharedNodes(rows, cols, GridSpec(x, y, cell, cell, 1, 1),
                                         (x - reach, x + reach, y - reach, y + reach)))
              for x, cols in xs for y, rows in ys]
    tol = _ON_LATTICE * cell
    for nodes, part in parts:
        if others is None or (nodes[0] <= nodes[1] + tol and nodes[2] <= nodes[3] + tol
                              and any(_meets(box, nodes, tol) for box in others)):
            yield part


def canonical_points(x: np.ndarray, y: np.ndarray, z: np.ndarray,
                     box: tuple[float, float, float, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The points inside ``box``, sorted by x, then y, then z: the same arrays from any superset."""
    inside = np.flatnonzero((x >= box[0]) & (x <= box[1]) & (y >= box[2]) & (y <= box[3]))
    order = inside[np.lexsort((z[inside], y[inside], x[inside]))]
    return x[order], y[order], z[order]


def grid_tile(x: np.ndarray, y: np.ndarray, z: np.ndarray, spec: GridSpec, core: Box,
              origin: tuple[float, float], reach: float, grid: Gridder,
              others: Sequence[Box] | None = None) -> np.ndarray:
    """The tile's nodes from its points and its neighbours' (every point within ``reach`` of its
    core), with the nodes on its edges and corners computed as every tile holding them does
    (``others``: the cores of the tiles around it; None: every edge on the lattice)."""
    values = grid(x, y, z, spec)
    for part in shared_nodes(spec, core, origin, reach, others):
        px, py, pz = canonical_points(x, y, z, part.box)
        try:
            shared = grid(px, py, pz, part.spec)
        except DataError:  # too few points near this edge for the method: blank there
            shared = np.full(part.spec.shape, np.nan)
        values[part.rows, part.cols] = shared
    return values
