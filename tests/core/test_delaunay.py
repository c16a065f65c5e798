"""The compiled incremental Delaunay triangulation and the adaptive TIN densification built on it.

Known answers: qhull's triangulation of the same random points; on grids (every point co-circular
with its neighbours, many on edges and on the rectangle's border) a valid triangulation -- positive
areas, symmetric neighbours, no vertex inside any circumcircle, the rectangle covered exactly;
and the densification against a reference that builds its TIN anew every round and tests every
candidate.
"""

import numpy as np
import pytest
from scipy.spatial import Delaunay

from aldpat.core.delaunay import DUPLICATE, OUTSIDE, insert, locate, new_tin
from aldpat.filters import atin_densify


def _build(x, y, size=100.0):
    n = len(x)
    px, py, _pz, tv, tn, stamp, count = new_tin(n, 0.0, 0.0, size, size)
    px[4:], py[4:] = x, y
    stack = np.empty(2 * (n + 4) + 8, np.int64)
    results = np.array([insert(px, py, tv, tn, stamp, count, stack, 4 + i, 0) for i in range(n)])
    return px, py, tv[:count[0]], tn[:count[0]], count, results


def _areas(px, py, tv):
    a, b, c = tv[:, 0], tv[:, 1], tv[:, 2]
    return ((px[b] - px[a]) * (py[c] - py[a]) - (py[b] - py[a]) * (px[c] - px[a])) / 2


def _check_valid(px, py, tv, tn, size=100.0):
    areas = _areas(px, py, tv)
    assert areas.min() > 0
    assert areas.sum() == pytest.approx(size * size)
    for t in range(len(tv)):
        for k in range(3):
            o = tn[t, k]
            if o >= 0:
                assert t in tn[o]
                # the shared edge is the edge opposite vertex k, in reverse
                assert set(tv[o]) >= {tv[t, (k + 1) % 3], tv[t, (k + 2) % 3]}
    # empty circumcircles: no vertex clearly inside any triangle's circle
    ax, ay = px[tv[:, 0]], py[tv[:, 0]]
    bx, by = px[tv[:, 1]], py[tv[:, 1]]
    cx, cy = px[tv[:, 2]], py[tv[:, 2]]
    d = 2 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
    ux = ((ax**2 + ay**2) * (by - cy) + (bx**2 + by**2) * (cy - ay) + (cx**2 + cy**2) * (ay - by)) / d
    uy = ((ax**2 + ay**2) * (cx - bx) + (bx**2 + by**2) * (ax - cx) + (cx**2 + cy**2) * (bx - ax)) / d
    r2 = (ax - ux) ** 2 + (ay - uy) ** 2
    used = np.unique(tv)
    for t in range(len(tv)):
        inside = (px[used] - ux[t]) ** 2 + (py[used] - uy[t]) ** 2 < r2[t] * (1 - 1e-9)
        assert not inside.any(), t


def test_random_points_give_qhulls_triangulation():
    rng = np.random.default_rng(3)
    x, y = rng.random(3000) * 100, rng.random(3000) * 100
    px, py, tv, tn, _, results = _build(x, y)
    assert (results >= 0).all()
    expected = Delaunay(np.column_stack([px, py])).simplices
    assert set(map(tuple, np.sort(tv, 1))) == set(map(tuple, np.sort(expected, 1)))
    _check_valid(px, py, tv, tn)


@pytest.mark.parametrize("start, step", [(0.5, 1.0), (0.0, 2.0), (0.0, 12.5)])
def test_grids_with_points_on_edges_and_border(start, step):
    g = np.arange(start, 100, step)
    gx, gy = np.meshgrid(g, g)
    rng = np.random.default_rng(4)
    order = rng.permutation(gx.size)  # any order of insertion
    x, y = gx.ravel()[order], gy.ravel()[order]
    px, py, tv, tn, _, results = _build(x, y)
    corner = (x == 0) & (y == 0)  # the rectangle's own corner: already a vertex
    assert (results[corner] == DUPLICATE).all()
    assert (results[~corner] >= 0).all()
    assert len(np.unique(tv)) == 4 + (~corner).sum()
    _check_valid(px, py, tv, tn)


def test_duplicates_and_outside():
    x, y = np.array([10.0, 10.0, 150.0]), np.array([20.0, 20.0, 5.0])
    px, py, tv, tn, count, results = _build(x, y)
    assert results[0] >= 0 and results[1] == DUPLICATE and results[2] == OUTSIDE
    assert locate(px, py, tv, tn, count, 0, -1.0, 50.0) == OUTSIDE


# ------------------------------------------------- densification: incremental == rebuilt each round


def _reference(x, y, z, seeds, size, z_difference, angle, min_distance, mirror, best):
    """Steps 2-4 the plain way: a TIN built from scratch each round, every candidate tested."""
    ground = seeds.copy()
    sin_angle = np.sin(np.radians(angle)) if angle > 0 else 0.0
    for _ in range(50):
        px, py, pz, tv, tn, stamp, count = new_tin(len(z), 0.0, 0.0, size, size)
        px[4:], py[4:], pz[4:] = x, y, z
        stack = np.empty(len(stamp) + 8, np.int64)
        for i in np.flatnonzero(ground):
            insert(px, py, tv, tn, stamp, count, stack, 4 + i, 0)
        gi = np.flatnonzero(ground)
        for k in range(4):
            pz[k] = z[gi[np.argmin((x[gi] - px[k]) ** 2 + (y[gi] - py[k]) ** 2)]]
        passing, tri, score = [], [], []
        for i in np.flatnonzero(~ground):
            t = locate(px, py, tv, tn, count, 0, x[i], y[i])
            ok, s, _ = atin_densify._test(px, py, pz, tv, tn, count, t, x[i], y[i], z[i], z_difference,
                                          sin_angle, min_distance, mirror)
            if ok:
                passing.append(i)
                tri.append(t)
                score.append(s)
        if not passing:
            break
        passing, tri, score = np.array(passing), np.array(tri), np.array(score)
        if best:
            order = np.lexsort((score, tri))
            first = np.r_[True, tri[order][1:] != tri[order][:-1]]
            passing = passing[order][first]
        ground[passing] = True
    return ground


@pytest.mark.parametrize("angle, min_distance, mirror, best", [
    (0.0, 0.0, True, False), (15.0, 0.0, True, False), (15.0, 1.5, True, False), (0.0, 0.0, False, True),
    (10.0, 1.5, True, True)])
def test_densification_matches_a_tin_rebuilt_every_round(angle, min_distance, mirror, best):
    rng = np.random.default_rng(5)
    n, size = 2500, 100.0
    x, y = rng.random(n) * size, rng.random(n) * size
    z = 0.2 * x + 2 * np.sin(y / 9) + rng.normal(0, 0.15, n)
    z[x > 60] += 6.0  # a cliff
    box = (abs(x - 30) < 8) & (abs(y - 40) < 8)
    z[box] += 5.0
    trees = rng.random(n) < 0.1
    z[trees] += rng.random(trees.sum()) * 10
    seeds = np.zeros(n, bool)
    cell = (np.floor(x / 25) * 4 + np.floor(y / 25)).astype(int)
    for c in np.unique(cell):
        members = np.flatnonzero(cell == c)
        seeds[members[np.argmin(z[members])]] = True
    got, _ = atin_densify.densify(x, y, z, seeds, (0.0, 0.0, size, size), 0.6, angle, min_distance, mirror, best,
                                  50)
    expected = _reference(x, y, z, seeds, size, 0.6, angle, min_distance, mirror, best)
    assert got.sum() > n // 3
    np.testing.assert_array_equal(got, expected)
