"""The adaptive TIN filter's densification, compiled (numba): steps 2-4 of :mod:`aldpat.filters.atin`.

The TIN is never rebuilt: the points a round accepts are inserted into it
(:mod:`aldpat.core.delaunay`), and a candidate that failed is tested again only when the
triangle below it, or the one below its mirror point, has changed since (each triangle carries a
stamp raised at every change) -- the same answers as testing every candidate every round against
a TIN built anew, at a cost proportional to what changes.

Coordinates are local (the buffered rectangle's lower-left corner at 0, 0).
"""

from __future__ import annotations

import numpy as np

from aldpat.core.compiled import compiled
from aldpat.core.delaunay import DUPLICATE, OUTSIDE, insert, locate, new_tin

#: A candidate's mirror triangle when it was not mirrored (not level with its nearest vertex).
NOT_MIRRORED = -2
#: A candidate's state: tested and failed against the triangles remembered.
FAILED = 1

#: The final TIN of :func:`densify` (the arrays of :func:`aldpat.core.delaunay.new_tin`): vertex
#: coordinates px, py, pz, triangles' vertices tv and neighbours tn, and the triangle count.
Tin = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]


@compiled(inline="always")
def _plane_distance(px: np.ndarray, py: np.ndarray, pz: np.ndarray, tv: np.ndarray, t: int, x: float, y: float,
                    z: float) -> tuple[float, float]:
    """Signed distance (up positive) of (x, y, z) to the plane of triangle t, and the z
    component of the plane's unit normal."""
    a, b, c = tv[t, 0], tv[t, 1], tv[t, 2]
    ux, uy, uz = px[b] - px[a], py[b] - py[a], pz[b] - pz[a]
    vx, vy, vz = px[c] - px[a], py[c] - py[a], pz[c] - pz[a]
    nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    norm = np.sqrt(nx * nx + ny * ny + nz * nz)
    if norm == 0.0:
        return np.inf, 1.0
    if nz < 0.0:
        norm = -norm
    return (nx * (x - px[a]) + ny * (y - py[a]) + nz * (z - pz[a])) / norm, nz / norm


@compiled(inline="always")
def _angle_ok(px: np.ndarray, py: np.ndarray, pz: np.ndarray, tv: np.ndarray, t: int, x: float, y: float, z: float,
              dist: float, sin_angle: float, min_distance: float) -> bool:
    """Whether the largest angle between the plane of t and the lines from the point to t's
    vertices is under the threshold: the sine of that angle is |dist| over the shortest line,
    taken as ``min_distance`` at least."""
    shortest = np.inf
    for k in range(3):
        w = tv[t, k]
        d = np.sqrt((x - px[w]) ** 2 + (y - py[w]) ** 2 + (z - pz[w]) ** 2)
        shortest = min(shortest, d)
    return abs(dist) < sin_angle * max(shortest, min_distance)


@compiled()
def _test(px: np.ndarray, py: np.ndarray, pz: np.ndarray, tv: np.ndarray, tn: np.ndarray, count: np.ndarray, t: int,
          x: float, y: float, z: float, z_difference: float, sin_angle: float, min_distance: float,
          mirror: bool) -> tuple[bool, float, int]:
    """Step 3 for one point in triangle t: (passes, score, mirror point's triangle)."""
    dist, _ = _plane_distance(px, py, pz, tv, t, x, y, z)
    good = abs(dist) < z_difference
    if good and sin_angle > 0.0:
        good = _angle_ok(px, py, pz, tv, t, x, y, z, dist, sin_angle, min_distance)
    if good or not mirror:
        return good, abs(dist), NOT_MIRRORED
    # the vertex nearest in x, y; only a point level with it continues the surface behind it
    best, v = np.inf, -1
    for k in range(3):
        w = tv[t, k]
        d2 = (x - px[w]) ** 2 + (y - py[w]) ** 2
        if d2 < best:
            best, v = d2, w
    if not abs(z - pz[v]) < z_difference:
        return False, abs(dist), NOT_MIRRORED
    mx, my, mz = 2.0 * px[v] - x, 2.0 * py[v] - y, 2.0 * pz[v] - z
    ms = locate(px, py, tv, tn, count, t, mx, my)
    if ms < 0:
        return False, abs(dist), OUTSIDE
    mdist, nz = _plane_distance(px, py, pz, tv, ms, mx, my, mz)
    # height above the plane: behind a cliff face the perpendicular distance is small however high
    mgood = abs(mdist / nz) < z_difference
    if mgood and sin_angle > 0.0:
        mgood = _angle_ok(px, py, pz, tv, ms, mx, my, mz, mdist, sin_angle, min_distance)
    if mgood:
        return True, abs(mdist), ms
    return False, abs(dist), ms


@compiled()
def _set_corner_heights(px: np.ndarray, py: np.ndarray, pz: np.ndarray, tv: np.ndarray, stamp: np.ndarray,
                        count: np.ndarray, ground: np.ndarray, first_vertex: int) -> None:
    """Each virtual corner at the height of the ground point nearest to it; the triangles of a
    corner whose height changes are changed triangles."""
    n = len(ground)
    for corner in range(4):
        best, z = np.inf, pz[corner]
        for i in range(n):
            if ground[i]:
                v = first_vertex + i
                d2 = (px[v] - px[corner]) ** 2 + (py[v] - py[corner]) ** 2
                if d2 < best:
                    best, z = d2, pz[v]
        if z != pz[corner]:
            pz[corner] = z
            for t in range(count[0]):
                if tv[t, 0] == corner or tv[t, 1] == corner or tv[t, 2] == corner:
                    stamp[t] += 1


@compiled()
def _densify(px: np.ndarray, py: np.ndarray, pz: np.ndarray, tv: np.ndarray, tn: np.ndarray, stamp: np.ndarray,
             count: np.ndarray, ground: np.ndarray, z_difference: float, sin_angle: float, min_distance: float,
             mirror: bool, best_per_triangle: bool, max_rounds: int) -> None:
    n = len(ground)
    first = 4  # candidate i is vertex first + i
    stack = np.empty(len(stamp) + 8, np.int64)
    tri = np.full(n, -1, np.int64)
    tri_stamp = np.zeros(n, np.int64)
    mtri = np.full(n, NOT_MIRRORED, np.int64)
    mtri_stamp = np.zeros(n, np.int64)
    state = np.zeros(n, np.int8)
    passing = np.zeros(n, np.bool_)
    score = np.zeros(n)
    best_of = np.full(len(stamp), -1, np.int64)
    last = 0
    for i in range(n):  # the seeds, in the caller's (row-major) order: short walks
        if ground[i]:
            r = insert(px, py, tv, tn, stamp, count, stack, first + i, last)
            if r >= 0:
                last = r
    for _ in range(max_rounds):
        _set_corner_heights(px, py, pz, tv, stamp, count, ground, first)
        any_pass = False
        for i in range(n):
            passing[i] = False
            if ground[i]:
                continue
            t = tri[i]
            if state[i] == FAILED and stamp[t] == tri_stamp[i]:
                m = mtri[i]
                if m == NOT_MIRRORED or (m >= 0 and stamp[m] == mtri_stamp[i]):
                    continue
            v = first + i
            t = locate(px, py, tv, tn, count, t if t >= 0 else last, px[v], py[v])
            if t < 0:
                state[i] = 0
                continue
            last = t
            ok, s, m = _test(px, py, pz, tv, tn, count, t, px[v], py[v], pz[v], z_difference, sin_angle, min_distance, mirror)
            tri[i] = t
            tri_stamp[i] = stamp[t]
            if ok:
                passing[i] = True
                score[i] = s
                state[i] = 0
                any_pass = True
            else:
                state[i] = FAILED
                mtri[i] = m
                if m >= 0:
                    mtri_stamp[i] = stamp[m]
        if not any_pass:
            break
        if best_per_triangle:
            for i in range(n):
                if passing[i]:
                    t = tri[i]
                    b = best_of[t]
                    if b < 0 or score[i] < score[b]:
                        best_of[t] = i
            for i in range(n):
                if passing[i]:
                    t = tri[i]
                    passing[i] = best_of[t] == i
            for i in range(n):
                if tri[i] >= 0:
                    best_of[tri[i]] = -1
        for i in range(n):
            if passing[i]:
                ground[i] = True
                r = insert(px, py, tv, tn, stamp, count, stack, first + i, tri[i])
                if r >= 0:
                    last = r
                elif r != DUPLICATE:
                    ground[i] = False  # outside the rectangle: cannot happen for a point inside it
    # the final TIN's corners, for the points classified against it (after the last round's
    # insertions when the rounds ran out; otherwise as the last round set them)
    _set_corner_heights(px, py, pz, tv, stamp, count, ground, first)


def _sine(angle_threshold: float) -> float:
    """The angle test's threshold as the sine the kernels compare with (0: no angle test)."""
    return float(np.sin(np.radians(angle_threshold))) if angle_threshold > 0 else 0.0


def densify(x: np.ndarray, y: np.ndarray, z: np.ndarray, seeds: np.ndarray, bounds: tuple[float, float, float, float],
            z_difference: float, angle_threshold: float, min_distance: float, mirror: bool, best_per_triangle: bool,
            max_rounds: int) -> tuple[np.ndarray, Tin]:
    """Ground flags of the candidates (local coordinates, inside ``bounds``) and the final TIN.

    ``seeds`` flags the candidates the TIN starts from; the TIN's four virtual corners sit at the
    corners of ``bounds``, each at the height of the ground point nearest to it."""
    n = len(z)
    x0, y0, x1, y1 = bounds
    px, py, pz, tv, tn, stamp, count = new_tin(n, x0, y0, x1, y1)
    px[4:], py[4:], pz[4:] = x, y, z
    ground = seeds.copy()
    sin_angle = _sine(angle_threshold)
    _densify(px, py, pz, tv, tn, stamp, count, ground, float(z_difference), sin_angle, float(min_distance), bool(mirror),
             bool(best_per_triangle), int(max_rounds))
    return ground, (px, py, pz, tv, tn, count)


@compiled()
def _classify(px: np.ndarray, py: np.ndarray, pz: np.ndarray, tv: np.ndarray, tn: np.ndarray, count: np.ndarray,
              x: np.ndarray, y: np.ndarray, z: np.ndarray, z_difference: float, sin_angle: float, min_distance: float,
              mirror: bool, out: np.ndarray) -> None:
    last = 0
    for i in range(len(x)):
        t = locate(px, py, tv, tn, count, last, x[i], y[i])
        if t < 0:
            out[i] = False
            continue
        last = t
        ok, _, _ = _test(px, py, pz, tv, tn, count, t, x[i], y[i], z[i], z_difference, sin_angle, min_distance, mirror)
        out[i] = ok


def passes(tin: Tin, x: np.ndarray, y: np.ndarray, z: np.ndarray, z_difference: float, angle_threshold: float,
           min_distance: float, mirror: bool) -> np.ndarray:
    """Whether each point (local coordinates; best in spatial order: the walks are short) passes
    step 3's test against the final TIN."""
    px, py, pz, tv, tn, count = tin
    out = np.zeros(len(x), bool)
    sin_angle = _sine(angle_threshold)
    _classify(px, py, pz, tv, tn, count, np.ascontiguousarray(x, float), np.ascontiguousarray(y, float),
              np.ascontiguousarray(z, float), float(z_difference), sin_angle, float(min_distance), bool(mirror), out)
    return out
