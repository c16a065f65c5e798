"""Points to a grid: nearest neighbour, Delaunay TIN (linear), inverse distance, binning.

ALDPAT 1.0 user manual (2007), task 9 "Gridding Tiles": ALDPAT handed tiles to Surfer, whose methods
these replace (kriging, Surfer's default, lives in :mod:`aldpat.core.kriging`). The nearest
neighbour method is the one of the dissertation (Cui 2013) §4.2 "nearest neighbour grid
interpolation". Every method returns the grid as ``(ny, nx)`` float64, row 0 the southern row,
NaN where a node is blank, so that no terrain is invented far from data:

* ``max_distance`` blanks a node whose nearest point is farther than that (``nearest``,
  ``idw``, ``kriging``) or that falls in a TIN triangle with an edge longer than that
  (``linear``); nodes outside the data's convex hull are always blank for ``linear``, and so
  are those of a hole in the data wider than the TIN's block buffer (:func:`linear`);
* binning (``min``, ``max``, ``mean``) leaves nodes without a point in their cell blank.

Large tiles are processed in blocks of nodes (and, for the TIN, of points with a buffer around
each block), so memory stays bounded and two threads can share the work.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from aldpat._lazy import lazy_import
from aldpat.core.compiled import compiled
from aldpat.core.grid_extent import GridSpec
from aldpat.core.grid_nodes import NODE_BLOCK, grid_points, node_coordinates, row_blocks, worker_count
from aldpat.core.kriging import krige
from aldpat.core.threads import on_threads
from aldpat.core.tin_raster import tin_block
from aldpat.errors import UsageError

if TYPE_CHECKING:
    from scipy import spatial
else:
    spatial = lazy_import("scipy.spatial")

log = logging.getLogger(__name__)

#: Method names of ``aldpat grid --method`` (the README's command list).
METHODS = ("nearest", "linear", "idw", "kriging", "min", "max", "mean")
BINNING = ("min", "max", "mean")
#: Memory a node takes while a method fills a grid (the float64 grid, the method's work arrays
#: and the float32 copy a GeoTIFF is written from), from the peak resident size of ``aldpat
#: grid`` over 2.25 and 9 million nodes: a grid's size is checked against it before it is made.
BYTES_PER_NODE = {"nearest": 32, "linear": 64, "idw": 56, "kriging": 40, "min": 32, "max": 32, "mean": 32}

#: points a TIN block aims at. The blocks decide which long triangles along the data's outline
#: exist (a block triangulates only its points and their buffer), so this size is part of the
#: result: kept at the size the grids were made with when qhull built the blocks.
_TIN_POINTS = 12_000
#: A block of the TIN grid takes points up to this many times its buffer (8 mean spacings) around
#: its nodes to make every triangle over them one of the TIN of all the points (:func:`linear`),
#: in at most :data:`TIN_ATTEMPTS` triangulations; a triangle whose circumcircle reaches farther
#: (a sliver bridging a bay of the data's outline, blank in a DTM as a data gap) is kept as found.
TIN_WIDEST_BUFFER = 8
TIN_ATTEMPTS = 3
#: (triangle, node) candidate pairs rasterised at once
_PAIR_BATCH = 4_000_000


def _block_of(v: float, start: float, step: float, nodes: int, count: int) -> int:
    """The block (of ``nodes`` nodes from node 0 at ``start``, ``count`` of them) holding ``v`` as
    :func:`_block_order` assigns a point: the first or last block beyond the grid."""
    return min(max(math.floor((v - start + step / 2) / (nodes * step)), 0), count - 1)


def _open_past(extent: tuple[float, float, float, float], rect: tuple[float, float, float, float]
               ) -> tuple[float, float, float, float]:
    """``rect`` (x0, y0, x1, y1) with each side past the points' ``extent`` moved to infinity: no
    point lies there for a circumcircle to hold."""
    return (-math.inf if rect[0] <= extent[0] else rect[0], -math.inf if rect[1] <= extent[1] else rect[1],
            math.inf if rect[2] >= extent[2] else rect[2], math.inf if rect[3] >= extent[3] else rect[3])


def _tree(x: np.ndarray, y: np.ndarray) -> tuple[spatial.cKDTree, tuple[float, float]]:
    """A KD-tree on coordinates relative to the data's corner (keeps full precision)."""
    origin = (float(x.min()), float(y.min()))
    return spatial.cKDTree(np.column_stack([x - origin[0], y - origin[1]]), balanced_tree=False), origin


# ---------------------------------------------------------------------------- nearest


def nearest(x: ArrayLike, y: ArrayLike, z: ArrayLike, spec: GridSpec, *, max_distance: float | None = None,
            workers: int | None = None) -> np.ndarray:
    """Each node takes the elevation of its nearest point (dissertation (Cui 2013) §4.2)."""
    x, y, z = grid_points(x, y, z)
    tree, origin = _tree(x, y)
    out = np.full(spec.shape, np.nan)
    bound = np.inf if max_distance is None else max_distance
    for r0, r1 in row_blocks(spec):
        dist, idx = tree.query(node_coordinates(spec, r0, r1, origin), k=1, distance_upper_bound=bound,
                               workers=worker_count(workers))
        hit = np.isfinite(dist)
        vals = np.full(len(dist), np.nan)
        vals[hit] = z[idx[hit]]
        out[r0:r1] = vals.reshape(r1 - r0, spec.nx)
    return out


# ---------------------------------------------------------------------------- idw


def idw(x: ArrayLike, y: ArrayLike, z: ArrayLike, spec: GridSpec, *, power: float = 2.0, radius: float | None = None,
        max_points: int = 16, max_distance: float | None = None, workers: int | None = None) -> np.ndarray:
    """Inverse distance to a power over the ``max_points`` nearest points within ``radius``.

    Surfer's "Inverse Distance to a Power" without smoothing: weights ``1 / d**power``; a node
    on a data point takes that point's value (the mean where several coincide).
    """
    if power <= 0:
        raise UsageError(f"power must be positive, got {power:g}")
    if max_points < 1:
        raise UsageError(f"max_points must be at least 1, got {max_points}")
    x, y, z = grid_points(x, y, z)
    tree, origin = _tree(x, y)
    k = min(max_points, len(x))
    out = np.full(spec.shape, np.nan)
    bound = np.inf if radius is None else radius
    zpad = np.append(z, 0.0)  # index len(z) marks "no neighbour"
    for r0, r1 in row_blocks(spec, NODE_BLOCK // max(1, k // 4)):
        dist, idx = tree.query(node_coordinates(spec, r0, r1, origin), k=[*range(1, k + 1)], distance_upper_bound=bound,
                               workers=worker_count(workers))
        found = np.isfinite(dist)
        exact = found & (dist == 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            # weights relative to the nearest point's (they cancel in the mean): 1 / d**power
            # itself overflows at a large power (d = 0.5 m, --power 1100) and every node went blank
            w = np.where(found & ~exact, (dist / dist[:, :1]) ** -power, 0.0)
            on_point = exact.any(axis=1)
            w[on_point] = exact[on_point].astype(float)
            vals = (w * zpad[idx]).sum(axis=1) / w.sum(axis=1)
        vals[~found[:, 0]] = np.nan
        if max_distance is not None:
            vals[dist[:, 0] > max_distance] = np.nan
        out[r0:r1] = vals.reshape(r1 - r0, spec.nx)
    return out


# ---------------------------------------------------------------------------- binning


class Binner:
    """Minimum, maximum or mean of the points in each node's cell, fed chunk by chunk.

    A node's cell is the cell-sized square centred on it (``GridSpec.nearest_node``); points
    outside every cell are ignored, cells without points stay blank.
    """

    def __init__(self, spec: GridSpec, statistic: str):
        if statistic not in BINNING:
            raise UsageError(f"unknown binning statistic {statistic!r} (use {', '.join(BINNING)})")
        self.spec = spec
        self.statistic = statistic
        size = spec.nx * spec.ny
        self.count = np.zeros(size, dtype=np.int64)
        if statistic == "mean":
            self.acc = np.zeros(size)
        else:
            self.acc = np.full(size, np.inf if statistic == "min" else -np.inf)

    def add(self, x: np.ndarray, y: np.ndarray, z: ArrayLike) -> None:
        col, row, inside = self.spec.nearest_node(x, y)
        z = np.asarray(z, dtype=np.float64)
        inside &= np.isfinite(z)
        flat = row[inside] * self.spec.nx + col[inside]
        z = z[inside]
        size = self.count.size
        self.count += np.bincount(flat, minlength=size)
        if self.statistic == "mean":
            self.acc += np.bincount(flat, weights=z, minlength=size)
        elif self.statistic == "min":
            np.minimum.at(self.acc, flat, z)
        else:
            np.maximum.at(self.acc, flat, z)

    def result(self) -> np.ndarray:
        with np.errstate(invalid="ignore", divide="ignore"):
            vals = self.acc / self.count if self.statistic == "mean" else self.acc.copy()
        vals[self.count == 0] = np.nan
        return vals.reshape(self.spec.shape)


def binned(x: ArrayLike, y: ArrayLike, z: ArrayLike, spec: GridSpec, *, statistic: str) -> np.ndarray:
    """Binning of all points at once (see :class:`Binner`)."""
    binner = Binner(spec, statistic)
    binner.add(*grid_points(x, y, z))
    return binner.result()


# ---------------------------------------------------------------------------- linear (TIN)


def _rasterise(tri_xy: np.ndarray, tri_z: np.ndarray, spec: GridSpec, cols: tuple[int, int],
               rows: tuple[int, int], origin: tuple[float, float], out: np.ndarray) -> None:
    """Linear interpolation on each triangle at the nodes it covers within cols x rows.

    ``tri_xy`` (m, 3, 2) holds vertices relative to ``origin``. Candidate nodes are those in a
    triangle's bounding box; barycentric coordinates keep the ones inside it.
    """
    gx0 = spec.xmin - origin[0]
    gy0 = spec.ymin - origin[1]
    eps = 1e-9
    tx, ty = tri_xy[:, :, 0], tri_xy[:, :, 1]
    c_lo = np.maximum(np.ceil((tx.min(1) - gx0) / spec.dx - eps).astype(np.int64), cols[0])
    c_hi = np.minimum(np.floor((tx.max(1) - gx0) / spec.dx + eps).astype(np.int64), cols[1] - 1)
    r_lo = np.maximum(np.ceil((ty.min(1) - gy0) / spec.dy - eps).astype(np.int64), rows[0])
    r_hi = np.minimum(np.floor((ty.max(1) - gy0) / spec.dy + eps).astype(np.int64), rows[1] - 1)
    ncol = np.clip(c_hi - c_lo + 1, 0, None)
    count = ncol * np.clip(r_hi - r_lo + 1, 0, None)
    keep = np.flatnonzero(count)
    if keep.size == 0:
        return
    ends = np.cumsum(count[keep])
    start = 0
    while start < keep.size:  # batches bound the candidate arrays whatever the triangle sizes
        base = ends[start - 1] if start else 0
        stop = max(start + 1, int(np.searchsorted(ends, base + _PAIR_BATCH, side="right")))
        t = keep[start:stop]
        cnt = count[t]
        tid = np.repeat(np.arange(t.size), cnt)
        k = np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
        col = c_lo[t][tid] + k % ncol[t][tid]
        row = r_lo[t][tid] + k // ncol[t][tid]
        px = gx0 + col * spec.dx
        py = gy0 + row * spec.dy
        v = tri_xy[t][tid]
        x1, y1, x2, y2, x3, y3 = v[:, 0, 0], v[:, 0, 1], v[:, 1, 0], v[:, 1, 1], v[:, 2, 0], v[:, 2, 1]
        det = (y2 - y3) * (x1 - x3) + (x3 - x2) * (y1 - y3)
        with np.errstate(divide="ignore", invalid="ignore"):
            l1 = ((y2 - y3) * (px - x3) + (x3 - x2) * (py - y3)) / det
            l2 = ((y3 - y1) * (px - x3) + (x1 - x3) * (py - y3)) / det
        l3 = 1.0 - l1 - l2
        inside = (l1 >= -eps) & (l2 >= -eps) & (l3 >= -eps) & (det != 0)
        zt = tri_z[t][tid]
        val = l1 * zt[:, 0] + l2 * zt[:, 1] + l3 * zt[:, 2]
        out[row[inside], col[inside]] = val[inside]
        start = stop


def merge_duplicates(pts: np.ndarray, pz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct positions of ``pts`` (n, 2), each with the mean height of the points there.

    A pulse recorded as both first and last return, or an overlap of flight lines, puts two
    heights at one x, y; a TIN can carry one vertex there, and which of them qhull kept depended
    on its processing order (and could differ between two blocks holding the same points)."""
    key = np.lexsort((pts[:, 1], pts[:, 0]))
    s = pts[key]
    new = np.empty(len(s), bool)
    new[:1] = True
    np.any(s[1:] != s[:-1], axis=1, out=new[1:])
    if new.all():
        return pts, pz
    group = np.cumsum(new) - 1
    sums = np.bincount(group, weights=pz[key])
    return s[new], sums / np.bincount(group)


def _tin_block(px: np.ndarray, py: np.ndarray, pz: np.ndarray, spec: GridSpec, cols: tuple[int, int],
               rows: tuple[int, int], max_distance: float | None, out: np.ndarray,
               known: tuple[float, ...] | None = None, most: tuple[float, ...] | None = None
               ) -> tuple[float, float, float, float] | None:
    """The block's nodes from the TIN of its points. With ``known`` (the rectangle whose every
    point ``px``, ``py`` hold) and ``most`` (the largest the caller would take), the rectangle
    (x0, y0, x1, y1) of the circumcircles of the triangles over a node that may not be the TIN of
    every point's (:func:`aldpat.core.tin_raster.tin_block`), if any; else None."""
    if len(px) < 3:
        return None
    origin = (float(px.mean()), float(py.mean()))
    pts = np.column_stack([px - origin[0], py - origin[1]])
    shift = np.array([origin[0], origin[1], origin[0], origin[1]])
    frame = None if known is None else np.array(known) - shift
    grow = None if most is None else np.concatenate([[np.inf, np.inf, -np.inf, -np.inf], np.array(most) - shift])
    done = tin_block(pts, pz, spec.xmin - origin[0], spec.ymin - origin[1], spec.dx, spec.dy, cols, rows,
                     max_distance, out, frame, grow)
    if done is False:
        log.debug("block rows %s cols %s: hull triangles displaced, triangulated by qhull", rows, cols)
        _qhull_block(*merge_duplicates(pts, pz), spec, cols, rows, origin, max_distance, out)
    if grow is None or not np.isfinite(grow[0]):  # no triangle in doubt
        return None
    x0, y0, x1, y1 = (float(v) for v in grow[:4] + shift)
    return x0, y0, x1, y1


def _qhull_block(pts: np.ndarray, pz: np.ndarray, spec: GridSpec, cols: tuple[int, int], rows: tuple[int, int],
                 origin: tuple[float, float], max_distance: float | None, out: np.ndarray) -> None:
    """The block's nodes from qhull's Delaunay triangulation (the compiled TIN's fallback)."""
    try:
        tri = spatial.Delaunay(pts).simplices
    except spatial.QhullError:  # fewer than 3 distinct or all collinear points: nothing to interpolate
        log.debug("block rows %s cols %s: degenerate points, left blank", rows, cols)
        return
    tri_xy = pts[tri]
    if max_distance is not None:
        edges = np.hypot(*(tri_xy - np.roll(tri_xy, 1, axis=1)).transpose(2, 0, 1))
        good = edges.max(axis=1) <= max_distance
        tri, tri_xy = tri[good], tri_xy[good]
    _rasterise(tri_xy, pz[tri], spec, cols, rows, origin, out)


@compiled(nogil=True)
def _block_order(x: np.ndarray, y: np.ndarray, x_lo: float, x_hi: float, y_lo: float, y_hi: float, xmin: float,
                 ymin: float, half_x: float, half_y: float, width: float, height: float, nbx: int, nby: int
                 ) -> tuple[np.ndarray, np.ndarray]:
    """The points inside ``x_lo..x_hi`` x ``y_lo..y_hi`` ordered by block (row-major blocks of
    ``width`` x ``height`` from ``xmin - half_x``, ``ymin - half_y``), in their own order within
    a block -- numpy's stable argsort of the block numbers, by counting -- and each block's start
    in that order."""
    n = len(x)
    key = np.empty(n, np.int32)
    starts = np.zeros(nbx * nby + 1, np.int64)
    for i in range(n):
        if x[i] >= x_lo and x[i] <= x_hi and y[i] >= y_lo and y[i] <= y_hi:
            bx = min(max(int(np.floor((x[i] - xmin + half_x) / width)), 0), nbx - 1)
            by = min(max(int(np.floor((y[i] - ymin + half_y) / height)), 0), nby - 1)
            k = by * nbx + bx
            key[i] = k
            starts[k + 1] += 1
        else:
            key[i] = -1
    for k in range(nbx * nby):
        starts[k + 1] += starts[k]
    order = np.empty(starts[-1], np.int64)
    fill = starts[:-1].copy()
    for i in range(n):
        k = key[i]
        if k >= 0:
            order[fill[k]] = i
            fill[k] += 1
    return order, starts


@compiled(nogil=True)
def _points_in(x: np.ndarray, y: np.ndarray, order: np.ndarray, starts: np.ndarray, nbx: int, b0: int, b1: int,
               j0: int, j1: int, x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    """The points inside ``x0..x1`` x ``y0..y1`` among those of blocks ``b0..b1`` of block rows
    ``j0..j1`` (:func:`_block_order`'s ``order`` and ``starts``), in that order: one pass over
    the blocks' slices, where gathering them and then their coordinates made three copies."""
    total = 0
    for jj in range(j0, j1 + 1):
        total += starts[jj * nbx + b1 + 1] - starts[jj * nbx + b0]
    out = np.empty(total, np.int64)
    k = 0
    for jj in range(j0, j1 + 1):
        for p in range(starts[jj * nbx + b0], starts[jj * nbx + b1 + 1]):
            i = order[p]
            if x[i] >= x0 and x[i] <= x1 and y[i] >= y0 and y[i] <= y1:
                out[k] = i
                k += 1
    return out[:k]


def linear(x: ArrayLike, y: ArrayLike, z: ArrayLike, spec: GridSpec, *, max_distance: float | None = None,
           workers: int | None = None, block_points: int = _TIN_POINTS, dtype: Any = np.float64) -> np.ndarray:
    """Linear interpolation on the Delaunay triangulation of the points (Surfer's
    "Triangulation with Linear Interpolation").

    The tile is cut into blocks of nodes; each block triangulates the points within a buffer
    of 8 mean point spacings around it, and checks that every triangle over its nodes is one of
    the TIN of all the points: a triangle whose circumcircle lies within the rectangle of points
    taken holds no point of any in it. Where a gap wider than the buffer (the ground under a
    building) gives one whose circle reaches out, the block is triangulated again with the points
    its circles reach, up to :data:`TIN_WIDEST_BUFFER` buffers around it: the nodes are then
    those of one TIN of every point (to the cocircular ties of equally valid triangulations), as
    a whole tile and its parts in tiles agree. Past that (a sliver bridging a bay of the data's
    outline), or where the buffer holds no point beyond a gap, a block may keep another valid
    triangle or leave nodes blank. Planes are reproduced exactly. Points sharing
    an x, y are one vertex at their mean height (:func:`merge_duplicates`). ``dtype`` float32
    gives the nodes rounded as a float32 raster stores them, in half the memory.
    """
    x, y, z = grid_points(x, y, z)
    out = np.full(spec.shape, np.nan, dtype)
    area = max((x.max() - x.min()) * (y.max() - y.min()), spec.dx * spec.dy)
    spacing = math.sqrt(area / len(x))
    side = max(16 * spacing, math.sqrt(block_points * area / len(x)))
    bcols = max(1, int(side / spec.dx))
    brows = max(1, int(side / spec.dy))
    buffer = max(8 * spacing, 2 * max(spec.dx, spec.dy))
    if max_distance is not None:
        buffer = max(buffer, 2 * max_distance)
    # the points by block, as indices (no sorted copy of the points): each block gathers its
    # neighbours' points by slices of ``order``. A block takes points up to ``widest`` around its
    # nodes to make its triangles the TIN of every point's: points farther around the grid are
    # not used
    nbx = -(-spec.nx // bcols)
    nby = -(-spec.ny // brows)
    widest = buffer * TIN_WIDEST_BUFFER
    taken = (spec.xmin - spec.dx / 2 - widest, spec.ymin - spec.dy / 2 - widest,
             spec.xmax + spec.dx / 2 + widest, spec.ymax + spec.dy / 2 + widest)
    order, bounds = _block_order(x, y, taken[0], taken[2], taken[1], taken[3],
                                 spec.xmin, spec.ymin, spec.dx / 2, spec.dy / 2, bcols * spec.dx,
                                 brows * spec.dy, nbx, nby)
    extent = (float(x.min()), float(y.min()), float(x.max()), float(y.max()))

    def points_in(rect: tuple[float, float, float, float]) -> np.ndarray:
        """The indices of the points inside ``rect``, gathered by slices of the blocks it meets."""
        x0, y0, x1, y1 = rect
        return _points_in(x, y, order, bounds, nbx, _block_of(x0, spec.xmin, spec.dx, bcols, nbx),
                          _block_of(x1, spec.xmin, spec.dx, bcols, nbx), _block_of(y0, spec.ymin, spec.dy, brows, nby),
                          _block_of(y1, spec.ymin, spec.dy, brows, nby), x0, y0, x1, y1)

    def run(block: tuple[int, int]) -> None:
        i, j = block
        cols = (i * bcols, min(spec.nx, (i + 1) * bcols))
        rows = (j * brows, min(spec.ny, (j + 1) * brows))
        node_rect = (spec.xmin + cols[0] * spec.dx, spec.ymin + rows[0] * spec.dy,
                     spec.xmin + (cols[1] - 1) * spec.dx, spec.ymin + (rows[1] - 1) * spec.dy)
        rect = (node_rect[0] - buffer, node_rect[1] - buffer, node_rect[2] + buffer, node_rect[3] + buffer)
        widest_rect = (node_rect[0] - widest, node_rect[1] - widest, node_rect[2] + widest, node_rect[3] + widest)
        most = _open_past(extent, widest_rect)
        sel = points_in(rect)
        for attempt in range(TIN_ATTEMPTS):
            last = attempt == TIN_ATTEMPTS - 1  # keeps what it finds
            circles = _tin_block(x[sel], y[sel], z[sel], spec, cols, rows, max_distance, out,
                                 None if last else _open_past(extent, rect), None if last else most)
            if circles is None:
                return
            # the rectangle grown (on the sides they reach) to hold the circles, and a spacing more
            rect = (max(widest_rect[0], min(rect[0], circles[0] - spacing)),
                    max(widest_rect[1], min(rect[1], circles[1] - spacing)),
                    min(widest_rect[2], max(rect[2], circles[2] + spacing)),
                    min(widest_rect[3], max(rect[3], circles[3] + spacing)))
            more = points_in(rect)
            if len(more) == len(sel):
                return  # no point where the circles reach past those taken (a sliver along the outline)
            out[rows[0]:rows[1], cols[0]:cols[1]] = np.nan  # gridded again with the points the circles reach
            sel = more

    blocks = [(i, j) for j in range(nby) for i in range(nbx)]
    on_threads(run, blocks, worker_count(workers))  # the compiled TIN and qhull release the GIL
    return out


# ---------------------------------------------------------------------------- the methods


@dataclass(frozen=True)
class GridOptions:
    """The options of ``aldpat grid`` a method may use (each takes what applies to it)."""

    power: float = 2.0
    radius: float | None = None
    max_points: int = 16
    max_distance: float | None = None
    variogram: str = "linear"
    nugget: float = 0.0
    drift: str = "none"
    workers: int | None = None


def _kriging(x: ArrayLike, y: ArrayLike, z: ArrayLike, spec: GridSpec, o: GridOptions) -> np.ndarray:
    return krige(x, y, z, spec, model=o.variogram, nugget=o.nugget, drift=o.drift, max_points=o.max_points,
                 radius=o.radius, max_distance=o.max_distance, workers=o.workers)


def _binning(statistic: str) -> Callable[[Any, Any, Any, GridSpec, GridOptions], np.ndarray]:
    def grid(x: ArrayLike, y: ArrayLike, z: ArrayLike, spec: GridSpec, o: GridOptions) -> np.ndarray:
        return binned(x, y, z, spec, statistic=statistic)

    return grid


#: ``aldpat grid --method`` name -> gridder ``fn(x, y, z, spec, options)``, in the order ``--help``
#: lists them.
GRIDDERS: dict[str, Callable[[Any, Any, Any, GridSpec, GridOptions], np.ndarray]] = {
    "nearest": lambda x, y, z, spec, o: nearest(x, y, z, spec, max_distance=o.max_distance, workers=o.workers),
    "linear": lambda x, y, z, spec, o: linear(x, y, z, spec, max_distance=o.max_distance, workers=o.workers),
    "idw": lambda x, y, z, spec, o: idw(x, y, z, spec, power=o.power, radius=o.radius, max_points=o.max_points,
                                        max_distance=o.max_distance, workers=o.workers),
    "kriging": _kriging,
    **{stat: _binning(stat) for stat in BINNING},
}
assert tuple(GRIDDERS) == METHODS


def interpolate(x: ArrayLike, y: ArrayLike, z: ArrayLike, spec: GridSpec, *, method: str = "linear", workers: int | None = None,
                **options: Any) -> np.ndarray:
    """Grid the points with one of :data:`METHODS` (see the module docstring); ``options`` are
    those of :class:`GridOptions`."""
    gridder = GRIDDERS.get(method)
    if gridder is None:
        raise UsageError(f"unknown gridding method {method!r} (use {', '.join(METHODS)})")
    return gridder(x, y, z, spec, GridOptions(workers=workers, **options))
