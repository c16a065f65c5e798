"""A block of a TIN grid, compiled: triangulate the block's points, interpolate at its nodes.

The linear gridder (:func:`aldpat.core.interpolate.linear`) cuts a grid into blocks of nodes and
triangulates each block's points with a buffer around it. Here both steps are compiled loops:

* the points are inserted one by one into a Delaunay triangulation (Lawson's incremental
  insertion, :mod:`aldpat.core.delaunay`) that starts as a rectangle far larger than the block;
  the points are taken in a serpentine order of small squares, so that each point's walk starts
  next to it. Every triangle without a corner of that rectangle is a Delaunay triangle of the
  points themselves: its circumcircle holds no point;
* each such triangle interpolates linearly at the nodes it covers (barycentric coordinates, the
  same arithmetic as Surfer's "Triangulation with Linear Interpolation" in
  :func:`aldpat.core.interpolate._rasterise`), node rows and columns read off its bounding box.

Near the outside of the data a few triangles of the points' convex hull may be missing, replaced
by triangles reaching a corner of the rectangle; :func:`tin_block` finds the block's nodes that
this leaves blank inside the convex hull and then grids that block with qhull instead (the
caller's fallback), so the nodes are those of the Delaunay TIN of the points either way.

The loops release the GIL, so blocks run on several threads at once.
"""

from __future__ import annotations

import math

import numpy as np

from aldpat.core import delaunay
from aldpat.core.compiled import compiled

#: The rectangle the triangulation starts from reaches this many times the block's extent beyond
#: it on every side: the farther its corners, the fewer hull triangles they displace.
CORNER_REACH = 200.0
#: Squares of the insertion order, in mean point spacings.
ORDER_SQUARE = 4.0


@compiled(nogil=True)
def _insert_all(px: np.ndarray, py: np.ndarray, pz: np.ndarray, tv: np.ndarray, tn: np.ndarray, stamp: np.ndarray,
                count: np.ndarray, stack: np.ndarray, n: int) -> None:
    """Insert vertices 4 .. n + 3 in turn, each walk starting at the previous point's triangle.
    A point at the position of a vertex is not inserted: the vertex takes the mean height of
    all the points there (:func:`aldpat.core.interpolate.merge_duplicates`)."""
    t = 0
    total = pz.copy()
    points = np.ones(len(pz), np.int64)
    merged = False
    for v in range(4, n + 4):
        r = delaunay.insert(px, py, tv, tn, stamp, count, stack, v, t)
        if r >= 0:
            t = r
        elif r == delaunay.DUPLICATE:
            held = delaunay.locate(px, py, tv, tn, count, t, px[v], py[v])
            for k in range(3):
                w = tv[held, k]
                if px[w] == px[v] and py[w] == py[v]:
                    total[w] += pz[v]
                    points[w] += 1
                    merged = True
                    break
    if merged:
        for v in range(4, n + 4):
            if points[v] > 1:
                pz[v] = total[v] / points[v]


@compiled(nogil=True)
def _rasterise(px: np.ndarray, py: np.ndarray, pz: np.ndarray, tv: np.ndarray, n_tri: int, gx0: float, gy0: float,
               dx: float, dy: float, c0: int, c1: int, r0: int, r1: int, max_edge: float, out: np.ndarray,
               covered: np.ndarray, known: np.ndarray, grow: np.ndarray) -> int:
    """Linear interpolation on every triangle without a corner vertex (0-3), at the nodes of
    columns c0..c1-1 and rows r0..r1-1 it covers; ``max_edge`` >= 0 leaves out triangles with a
    longer edge. Node (row, col) lies at (gx0 + col dx, gy0 + row dy) in the vertices' frame.
    ``covered[row - r0, col - c0]`` is set for every node under a triangle, long edges or not.

    Returns how many of the triangles covering a node have a circumcircle reaching out of
    ``known`` (x0, y0, x1, y1: the rectangle all of whose points were triangulated) but inside
    ``grow[4:]`` (the most the caller would take), and widens ``grow[:4]`` (x0, y0, x1, y1) to
    hold their circles. Such a triangle may not be one of the TIN of every point: a point beyond
    the rectangle may lie in its circumcircle. One whose circle lies inside holds no point of
    any (the block's points are every point there), so it is; one whose circle reaches past
    what the caller would take (a sliver along the data's outline) is kept as it is."""
    eps = 1e-9
    unsure = 0
    for t in range(n_tri):
        a = tv[t, 0]
        b = tv[t, 1]
        c = tv[t, 2]
        if a < 4 or b < 4 or c < 4:
            continue
        x1, y1, x2, y2, x3, y3 = px[a], py[a], px[b], py[b], px[c], py[c]
        short = not (max_edge >= 0.0 and (math.hypot(x1 - x3, y1 - y3) > max_edge
                                          or math.hypot(x2 - x1, y2 - y1) > max_edge
                                          or math.hypot(x3 - x2, y3 - y2) > max_edge))
        det = (y2 - y3) * (x1 - x3) + (x3 - x2) * (y1 - y3)
        if det == 0.0:
            continue
        col_lo = max(math.ceil((min(x1, x2, x3) - gx0) / dx - eps), c0)
        col_hi = min(math.floor((max(x1, x2, x3) - gx0) / dx + eps), c1 - 1)
        row_lo = max(math.ceil((min(y1, y2, y3) - gy0) / dy - eps), r0)
        row_hi = min(math.floor((max(y1, y2, y3) - gy0) / dy + eps), r1 - 1)
        z1, z2, z3 = pz[a], pz[b], pz[c]
        hit = False
        for row in range(row_lo, row_hi + 1):
            qy = gy0 + row * dy
            for col in range(col_lo, col_hi + 1):
                qx = gx0 + col * dx
                l1 = ((y2 - y3) * (qx - x3) + (x3 - x2) * (qy - y3)) / det
                l2 = ((y3 - y1) * (qx - x3) + (x1 - x3) * (qy - y3)) / det
                l3 = 1.0 - l1 - l2
                if l1 >= -eps and l2 >= -eps and l3 >= -eps:
                    covered[row - r0, col - c0] = True
                    hit = True
                    if short:
                        out[row, col] = l1 * z1 + l2 * z2 + l3 * z3
        if not hit:
            continue
        bx, by, cx, cy = x2 - x1, y2 - y1, x3 - x1, y3 - y1  # the circumcircle, from the first vertex
        d2 = 2.0 * (bx * cy - by * cx)
        b2, c2 = bx * bx + by * by, cx * cx + cy * cy
        ux = (cy * b2 - by * c2) / d2
        uy = (bx * c2 - cx * b2) / d2
        r = math.sqrt(ux * ux + uy * uy) * (1.0 + 1e-9)
        ux += x1
        uy += y1
        lo_x, lo_y, hi_x, hi_y = ux - r, uy - r, ux + r, uy + r
        if lo_x >= known[0] and lo_y >= known[1] and hi_x <= known[2] and hi_y <= known[3]:
            continue
        if lo_x >= grow[4] and lo_y >= grow[5] and hi_x <= grow[6] and hi_y <= grow[7]:
            unsure += 1
            grow[0] = min(grow[0], lo_x)
            grow[1] = min(grow[1], lo_y)
            grow[2] = max(grow[2], hi_x)
            grow[3] = max(grow[3], hi_y)
    return unsure


@compiled(nogil=True)
def _square_keys(x: np.ndarray, y: np.ndarray, square: float) -> tuple[np.ndarray, int]:
    """Each point's square (row, then column: east to west in odd rows) as one number, and the
    count of numbers."""
    row = np.floor((y - y.min()) / square).astype(np.int64)
    col = np.floor((x - x.min()) / square).astype(np.int64)
    last = col.max()
    width = last + 1
    key = np.empty(len(x), np.int64)
    for i in range(len(x)):
        key[i] = row[i] * width + (last - col[i] if row[i] % 2 == 1 else col[i])
    return key, (row.max() + 1) * width


@compiled(nogil=True)
def _counting_order(key: np.ndarray, size: int) -> np.ndarray:
    """The stable order of ``key`` (0 .. size - 1), by counting."""
    starts = np.zeros(size + 1, np.int64)
    for k in key:
        starts[k + 1] += 1
    for k in range(size):
        starts[k + 1] += starts[k]
    order = np.empty(len(key), np.int64)
    for i in range(len(key)):
        order[starts[key[i]]] = i
        starts[key[i]] += 1
    return order


@compiled(nogil=True)
def insertion_order(x: np.ndarray, y: np.ndarray, square: float) -> np.ndarray:
    """A serpentine order of ``square``-sized squares (rows of squares south to north, every
    other row east to west): consecutive points lie close together."""
    key, size = _square_keys(x, y, square)
    if size <= 4 * len(x) + 1024:
        return _counting_order(key, size)
    return np.argsort(key, kind="mergesort")  # stable: the order of numpy's stable sort


@compiled(nogil=True)
def _triangulated(x: np.ndarray, y: np.ndarray, pz: np.ndarray, dx: float, dy: float
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """The TIN of points ``x``, ``y`` (heights ``pz``) from a rectangle :data:`CORNER_REACH`
    times their extent beyond them, inserted in :func:`insertion_order` of squares of
    :data:`ORDER_SQUARE` spacings (cells ``dx`` x ``dy`` at least): vertex x, y and heights
    (the corners first), the triangles' vertices and neighbours, and how many there are. One
    compiled call, where each step in Python copied the block's points again."""
    n = len(x)
    x_lo, x_hi, y_lo, y_hi = x.min(), x.max(), y.min(), y.max()
    width = max(x_hi - x_lo, y_hi - y_lo, dx, dy)
    reach = CORNER_REACH * width
    spacing = math.sqrt(max(width * width / n, dx * dy))
    order = insertion_order(x, y, ORDER_SQUARE * spacing)
    px, py, vz, tv, tn, stamp, count = delaunay.new_tin(n, x_lo - reach, y_lo - reach, x_hi + reach, y_hi + reach)
    for i in range(n):
        k = order[i]
        px[i + 4] = x[k]
        py[i + 4] = y[k]
        vz[i + 4] = pz[k]
    stack = np.zeros(len(tv) + 8, np.int64)
    _insert_all(px, py, vz, tv, tn, stamp, count, stack, n)
    return px, py, vz, tv, tn, count[0]


def tin_block(pts: np.ndarray, pz: np.ndarray, gx0: float, gy0: float, dx: float, dy: float, cols: tuple[int, int], rows: tuple[int, int],
              max_distance: float | None, out: np.ndarray, known: np.ndarray | None = None,
              grow: np.ndarray | None = None) -> bool | None:
    """Grid the nodes ``rows`` x ``cols`` of ``out`` from the TIN of ``pts`` (n, 2: coordinates
    in a local frame; ``gx0``, ``gy0``: node (0, 0) in the same frame) with heights ``pz``.

    False when some node of the block lies inside the points' convex hull but under no triangle
    of the points (a hull triangle displaced by the starting rectangle): the caller grids the
    block another way. None when the nodes are gridded but a triangle over a node may not be one
    of the TIN of every point (:func:`_rasterise`: its circumcircle reaches out of ``known``, the
    rectangle whose every point ``pts`` holds, in the same frame, and inside ``grow[4:]``, the
    most the caller would take; default: no bound): ``grow[:4]`` then holds those circles, and
    the caller keeps the nodes if no point lies there, else grids the block again with those
    points. Nodes the TIN leaves blank stay as they were (NaN).
    """
    from scipy import spatial

    px, py, vz, tv, _, n_tri = _triangulated(np.ascontiguousarray(pts[:, 0]), np.ascontiguousarray(pts[:, 1]),
                                             np.ascontiguousarray(pz, np.float64), float(dx), float(dy))
    covered = np.zeros((rows[1] - rows[0], cols[1] - cols[0]), np.bool_)
    bound = np.array([-np.inf, -np.inf, np.inf, np.inf]) if known is None else np.asarray(known, np.float64)
    if grow is None:
        grow = np.array([np.inf, np.inf, -np.inf, -np.inf, 0.0, 0.0, 0.0, 0.0])
    unsure = _rasterise(px, py, vz, tv, int(n_tri), gx0, gy0, dx, dy, cols[0], cols[1], rows[0], rows[1],
                        -1.0 if max_distance is None else float(max_distance), out, covered, bound, grow)
    sure = None if unsure else True
    blank_r, blank_c = np.nonzero(~covered)
    if not len(blank_r):
        return sure
    try:
        hull = spatial.ConvexHull(pts)
    except spatial.QhullError:  # fewer than 3 distinct or all collinear points: no triangle at all
        return sure
    qx = gx0 + (cols[0] + blank_c) * dx
    qy = gy0 + (rows[0] + blank_r) * dy
    eq = hull.equations  # unit outward normals: a x + b y + c <= 0 inside
    for a, b, c in eq:
        keep = a * qx + b * qy + c <= 1e-7
        qx, qy = qx[keep], qy[keep]
        if not len(qx):
            return sure
    return False
