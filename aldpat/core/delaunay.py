"""Incremental Delaunay triangulation in the plane, compiled with numba.

Lawson's incremental insertion (de Berg, Cheong, van Kreveld & Overmars 2008, *Computational
Geometry*, ch. 9): the triangle holding a new point is found by a visibility walk from a nearby
triangle, split in three (or, with its neighbour, in four when the point lies on their common
edge), and every edge opposite the new point that fails the empty-circumcircle test is flipped
until none does. Each point costs time proportional to the triangles it touches, so a TIN that
grows round after round -- the adaptive TIN filter's -- is never rebuilt from scratch.

The triangulation starts as a rectangle (two triangles on four corner vertices, numbers 0-3)
that must hold every point inserted. Arrays are allocated once by :func:`new_tin`:

* ``px``, ``py``, ``pz``: vertex coordinates, best kept small (shifted to a local origin) so the
  orientation and circle tests keep their precision;
* ``tv[t, k]``: the k-th vertex of triangle t, counter-clockwise;
* ``tn[t, k]``: the triangle across the edge opposite ``tv[t, k]`` (-1: the rectangle's edge);
* ``stamp[t]``: raised every time triangle t changes, so that a remembered ``(t, stamp[t])``
  says whether the triangle a point was tested against is still the same triangle;
* ``count[0]``: triangles in use.

Robustness: the tests are plain floating point. A flip decided wrongly on (nearly) co-circular
points leaves a valid triangulation that is not exactly Delaunay there; insertion always ends
(each flip raises the new point's degree); a walk that does not end in a bounded number of steps
falls back to testing every triangle.
"""

from __future__ import annotations

import numpy as np

from aldpat.core.compiled import compiled

#: What :func:`insert` returns for a point at the position of a vertex (nothing inserted).
DUPLICATE = -2
#: What :func:`locate` and :func:`insert` return for a point outside the rectangle.
OUTSIDE = -1


@compiled(nogil=True)
def new_tin(n_points: int, x0: float, y0: float, x1: float, y1: float
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Arrays of a TIN over the rectangle ``x0..x1`` x ``y0..y1`` with room for ``n_points``
    more vertices (numbered from 4); corners 0-3 are (x0, y0), (x1, y0), (x0, y1), (x1, y1), at
    height 0 until the caller sets them. Compiled, so that compiled code can start a TIN too."""
    nv = n_points + 4
    cap = 2 * nv
    px = np.zeros(nv)
    py = np.zeros(nv)
    pz = np.zeros(nv)
    px[0], px[1], px[2], px[3] = x0, x1, x0, x1
    py[0], py[1], py[2], py[3] = y0, y0, y1, y1
    tv = np.zeros((cap, 3), np.int64)
    tn = np.full((cap, 3), -1, np.int64)
    # (0, 1, 3) and (0, 3, 2), both counter-clockwise, share the diagonal 0-3
    tv[0, 0], tv[0, 1], tv[0, 2] = 0, 1, 3
    tv[1, 0], tv[1, 1], tv[1, 2] = 0, 3, 2
    tn[0, 1] = 1  # opposite 1 is edge 3-0: triangle 1
    tn[1, 2] = 0  # opposite 2 is edge 0-3: triangle 0
    stamp = np.zeros(cap, np.int64)
    count = np.full(1, 2, np.int64)
    return px, py, pz, tv, tn, stamp, count


@compiled(inline="always")
def orient(ax: float, ay: float, bx: float, by: float, cx: float, cy: float) -> float:
    """Twice the signed area of a, b, c: positive when counter-clockwise."""
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@compiled(inline="always")
def in_circle(ax: float, ay: float, bx: float, by: float, cx: float, cy: float, dx: float, dy: float) -> float:
    """Positive when d lies inside the circle through the counter-clockwise a, b, c."""
    adx, ady = ax - dx, ay - dy
    bdx, bdy = bx - dx, by - dy
    cdx, cdy = cx - dx, cy - dy
    return ((adx * adx + ady * ady) * (bdx * cdy - bdy * cdx)
            + (bdx * bdx + bdy * bdy) * (cdx * ady - cdy * adx)
            + (cdx * cdx + cdy * cdy) * (adx * bdy - ady * bdx))


@compiled()
def locate(px: np.ndarray, py: np.ndarray, tv: np.ndarray, tn: np.ndarray, count: np.ndarray, start: int, x: float,
           y: float) -> int:
    """The triangle holding (x, y) (on its boundary counts), walking from triangle ``start``;
    :data:`OUTSIDE` when the point is outside the rectangle."""
    t = start if 0 <= start < count[0] else 0
    limit = 64 + 4 * int(np.sqrt(count[0]))
    for step in range(limit):
        moved = False
        for j in range(3):
            k = (j + step) % 3  # a rotating first edge keeps the walk from circling
            a = tv[t, (k + 1) % 3]
            b = tv[t, (k + 2) % 3]
            if orient(px[a], py[a], px[b], py[b], x, y) < 0.0:
                nb = tn[t, k]
                if nb < 0:
                    return OUTSIDE
                t = nb
                moved = True
                break
        if not moved:
            return t
    for t in range(count[0]):  # the walk did not end: inconsistent rounding; test every triangle
        a, b, c = tv[t, 0], tv[t, 1], tv[t, 2]
        if (orient(px[a], py[a], px[b], py[b], x, y) >= 0.0 and orient(px[b], py[b], px[c], py[c], x, y) >= 0.0
                and orient(px[c], py[c], px[a], py[a], x, y) >= 0.0):
            return t
    return OUTSIDE


@compiled(inline="always")
def _repoint(tn: np.ndarray, t: int, old: int, new: int) -> None:
    """Make triangle t (if any) name ``new`` where it named its neighbour ``old``."""
    if t >= 0:
        for k in range(3):
            if tn[t, k] == old:
                tn[t, k] = new
                return


@compiled()
def _legalize(px: np.ndarray, py: np.ndarray, tv: np.ndarray, tn: np.ndarray, stamp: np.ndarray, stack: np.ndarray,
              top: int) -> None:
    """Flip the edges opposite vertex 0 (the new point) of the triangles on ``stack`` until every
    one passes the empty-circumcircle test."""
    while top > 0:
        top -= 1
        t = stack[top]
        o = tn[t, 0]
        if o < 0:
            continue
        j = 0
        while tn[o, j] != t:
            j += 1
        p, b, c = tv[t, 0], tv[t, 1], tv[t, 2]
        d = tv[o, j]
        if in_circle(px[p], py[p], px[b], py[b], px[c], py[c], px[d], py[d]) <= 0.0:
            continue
        # t = (p, b, c) and o = (d, c, b) become t = (p, b, d) and o = (p, d, c)
        o_bd = tn[o, (j + 1) % 3]
        o_dc = tn[o, (j + 2) % 3]
        t_cp = tn[t, 1]
        t_pb = tn[t, 2]
        tv[t, 0], tv[t, 1], tv[t, 2] = p, b, d
        tn[t, 0], tn[t, 1], tn[t, 2] = o_bd, o, t_pb
        tv[o, 0], tv[o, 1], tv[o, 2] = p, d, c
        tn[o, 0], tn[o, 1], tn[o, 2] = o_dc, t_cp, t
        _repoint(tn, o_bd, o, t)
        _repoint(tn, t_cp, t, o)
        stamp[t] += 1
        stamp[o] += 1
        stack[top] = t
        stack[top + 1] = o
        top += 2


@compiled()
def insert(px: np.ndarray, py: np.ndarray, tv: np.ndarray, tn: np.ndarray, stamp: np.ndarray, count: np.ndarray,
           stack: np.ndarray, v: int, start: int) -> int:
    """Insert vertex ``v`` (its coordinates already in px, py), walking from triangle ``start``.

    Returns a triangle that has ``v`` as a vertex, :data:`DUPLICATE` when a vertex already sits
    at its position, or :data:`OUTSIDE`. ``stack`` is scratch room of at least ``count`` + 8."""
    x, y = px[v], py[v]
    t = locate(px, py, tv, tn, count, start, x, y)
    if t < 0:
        return OUTSIDE
    for k in range(3):
        w = tv[t, k]
        if px[w] == x and py[w] == y:
            return DUPLICATE
    on_edge = -1
    for k in range(3):
        a = tv[t, (k + 1) % 3]
        b = tv[t, (k + 2) % 3]
        if orient(px[a], py[a], px[b], py[b], x, y) == 0.0:
            on_edge = k
            break
    top = 0
    if on_edge < 0:
        a, b, c = tv[t, 0], tv[t, 1], tv[t, 2]
        na, nb, nc = tn[t, 0], tn[t, 1], tn[t, 2]
        t1 = count[0]
        t2 = t1 + 1
        count[0] += 2
        tv[t, 0], tv[t, 1], tv[t, 2] = v, b, c
        tn[t, 0], tn[t, 1], tn[t, 2] = na, t1, t2
        tv[t1, 0], tv[t1, 1], tv[t1, 2] = v, c, a
        tn[t1, 0], tn[t1, 1], tn[t1, 2] = nb, t2, t
        tv[t2, 0], tv[t2, 1], tv[t2, 2] = v, a, b
        tn[t2, 0], tn[t2, 1], tn[t2, 2] = nc, t, t1
        _repoint(tn, nb, t, t1)
        _repoint(tn, nc, t, t2)
        stamp[t] += 1
        stamp[t1] += 1
        stamp[t2] += 1
        stack[0], stack[1], stack[2] = t, t1, t2
        top = 3
    else:
        # v on the edge b-c of t = (a, b, c): t becomes (v, a, b), a new t1 (v, c, a); across the
        # edge, o = (d, c, b) becomes (v, b, d) and a new t3 (v, d, c)
        k = on_edge
        a, b, c = tv[t, k], tv[t, (k + 1) % 3], tv[t, (k + 2) % 3]
        n_ab = tn[t, (k + 2) % 3]
        n_ca = tn[t, (k + 1) % 3]
        o = tn[t, k]
        t1 = count[0]
        count[0] += 1
        tv[t, 0], tv[t, 1], tv[t, 2] = v, a, b
        tv[t1, 0], tv[t1, 1], tv[t1, 2] = v, c, a
        if o < 0:
            tn[t, 0], tn[t, 1], tn[t, 2] = n_ab, -1, t1
            tn[t1, 0], tn[t1, 1], tn[t1, 2] = n_ca, t, -1
            _repoint(tn, n_ca, t, t1)
            stamp[t] += 1
            stamp[t1] += 1
            stack[0], stack[1] = t, t1
            top = 2
        else:
            j = 0
            while tn[o, j] != t:
                j += 1
            d = tv[o, j]
            o_bd = tn[o, (j + 1) % 3]
            o_dc = tn[o, (j + 2) % 3]
            t3 = count[0]
            count[0] += 1
            tn[t, 0], tn[t, 1], tn[t, 2] = n_ab, o, t1
            tn[t1, 0], tn[t1, 1], tn[t1, 2] = n_ca, t, t3
            tv[o, 0], tv[o, 1], tv[o, 2] = v, b, d
            tn[o, 0], tn[o, 1], tn[o, 2] = o_bd, t3, t
            tv[t3, 0], tv[t3, 1], tv[t3, 2] = v, d, c
            tn[t3, 0], tn[t3, 1], tn[t3, 2] = o_dc, t1, o
            _repoint(tn, n_ca, t, t1)
            _repoint(tn, o_dc, o, t3)
            stamp[t] += 1
            stamp[t1] += 1
            stamp[o] += 1
            stamp[t3] += 1
            stack[0], stack[1], stack[2], stack[3] = t, t1, o, t3
            top = 4
    _legalize(px, py, tv, tn, stamp, stack, top)
    return t
