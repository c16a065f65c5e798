"""Even-odd point in polygon: concave polygons, holes, either orientation, closing vertex."""

import numpy as np
import pytest

from aldpat.core.polygon import (
    clean_ring,
    crossing_parity,
    oriented,
    points_in_polygons,
    signed_area,
)

# a U shape (concave): the notch 2 < x < 4, 2 < y < 6 is outside
U = np.array([[0, 0], [6, 0], [6, 6], [4, 6], [4, 2], [2, 2], [2, 6], [0, 6]], dtype=float)
PROBES = np.array([[1, 1], [1, 5], [3, 1], [3, 4], [5, 5], [7, 3], [-1, 3], [3, 7], [3, 1.999]])
INSIDE = [True, True, True, False, True, False, False, False, True]


@pytest.mark.parametrize("ring", [U, U[::-1], np.vstack([U, U[:1]])], ids=["ccw", "cw", "closed"])
def test_concave_polygon_in_either_orientation(ring):
    assert points_in_polygons(PROBES[:, 0], PROBES[:, 1], [[ring]]).tolist() == INSIDE


def test_hole_is_outside_and_polygons_unite():
    outer = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], float)
    hole = np.array([[3, 3], [7, 3], [7, 7], [3, 7]], float)
    other = np.array([[20, 0], [30, 0], [30, 5]], float)
    x = np.array([1.0, 5.0, 8.0, 25.0, 15.0, 29.0])
    y = np.array([1.0, 5.0, 8.0, 1.0, 5.0, 1.0])
    got = points_in_polygons(x, y, [[outer, hole], [other]])
    assert got.tolist() == [True, False, True, True, False, True]


def test_vertex_on_the_ray_counts_once():
    # the ray from (0, 1) to the right passes exactly through the vertex (2, 1) of a diamond
    diamond = np.array([[1, 0], [2, 1], [1, 2], [0.5, 1]], float)
    assert points_in_polygons(np.array([0.75, 0.0, 3.0]), np.array([1.0, 1.0, 1.0]), [[diamond]]).tolist() == \
        [True, False, False]


def test_agrees_with_a_brute_force_crossing_count():
    rng = np.random.default_rng(7)
    angles = np.sort(rng.uniform(0, 2 * np.pi, 40))
    radius = rng.uniform(2, 10, 40)  # a star-shaped, very concave polygon
    ring = np.column_stack([radius * np.cos(angles), radius * np.sin(angles)])
    px, py = rng.uniform(-11, 11, 3000), rng.uniform(-11, 11, 3000)
    expected = np.zeros(len(px), dtype=bool)
    xj, yj = ring[-1]
    for xi, yi in ring:
        crosses = ((yi > py) != (yj > py)) & (px < (xj - xi) * (py - yi) / (yj - yi) + xi)
        expected ^= crosses
        xj, yj = xi, yi
    assert np.array_equal(crossing_parity(px, py, [ring]), expected)


def test_orientation_and_cleaning():
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0, 1], [0, 0]], float)
    assert len(clean_ring(square)) == 4
    assert signed_area(square) == pytest.approx(1.0)
    assert signed_area(oriented(square, clockwise=True)) == pytest.approx(-1.0)
    assert signed_area(oriented(square[::-1], clockwise=False)) == pytest.approx(1.0)
