"""Strip boundary from a min-z grid (manual task 4): hand-made grids and a real strip."""

from pathlib import Path

import numpy as np

from aldpat.core.boundary import BoundaryScan
from aldpat.core.polygon import points_in_polygons, signed_area

DATA = Path(__file__).resolve().parents[1] / "data"


def grid_points():
    """A 4 x 2 block of 1 m cells, two points in each cell: the lower one is the cell's point."""
    xs, ys, zs = [], [], []
    for i in range(4):
        for j in range(2):
            xs += [i + 0.25, i + 0.75]
            ys += [j + 0.25, j + 0.75]
            zs += [10.0 + i + j, 5.0 + i + j]  # the second point (i+.75, j+.75) is lower
    return np.array(xs), np.array(ys), np.array(zs)


def test_row_scan_takes_the_lowest_points_of_the_end_cells_of_each_row():
    x, y, z = grid_points()
    scan = BoundaryScan(1.0, 1.0)
    scan.add(x, y, z)
    assert scan.direction("auto") == "x"  # 4 m wide, 2 m tall
    ring = scan.ring("auto")
    pts = list(zip(ring["x"].tolist(), ring["y"].tolist(), strict=False))
    # right ends going north, then left ends going south, closed
    assert pts == [(3.75, 0.75), (3.75, 1.75), (0.75, 1.75), (0.75, 0.75), (3.75, 0.75)]
    assert signed_area(np.column_stack([ring["x"], ring["y"]])) > 0  # counter-clockwise


def test_column_scan_and_chunking_give_the_same_ring():
    x, y, z = grid_points()
    whole = BoundaryScan(1.0, 1.0)
    whole.add(x, y, z)
    parts = BoundaryScan(1.0, 1.0)
    for k in range(0, len(x), 3):  # chunks that split cells
        parts.add(x[k:k + 3], y[k:k + 3], z[k:k + 3])
    for scan in ("x", "y"):
        a, b = whole.ring(scan), parts.ring(scan)
        for key in ("x", "y", "z"):
            assert np.array_equal(a[key], b[key])
    ring = whole.ring("y")
    pts = list(zip(ring["x"].tolist(), ring["y"].tolist(), strict=False))
    # bottom ends going east, then top ends going west
    assert pts[:4] == [(0.75, 0.75), (1.75, 0.75), (2.75, 0.75), (3.75, 0.75)]
    assert pts[4:] == [(3.75, 1.75), (2.75, 1.75), (1.75, 1.75), (0.75, 1.75), (0.75, 0.75)]


def test_auto_scans_columns_when_the_strip_is_taller_than_wide():
    x, y, z = grid_points()
    scan = BoundaryScan(1.0, 1.0)
    scan.add(y, x, z)
    assert scan.direction("auto") == "y"


def test_boundary_points_are_real_points_and_enclose_a_real_strip():
    import laspy
    las = laspy.read(DATA / "fsite5_strip.laz")
    x, y, z = np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)
    scan = BoundaryScan(3.0, 3.0)
    for k in range(0, len(x), 5000):
        scan.add(x[k:k + 5000], y[k:k + 5000], z[k:k + 5000])
    ring = scan.ring("auto")
    assert ring["x"][0] == ring["x"][-1] and ring["y"][0] == ring["y"][-1]
    real = set(zip(x.tolist(), y.tolist(), z.tolist(), strict=False))
    assert all(p in real for p in zip(ring["x"].tolist(), ring["y"].tolist(), ring["z"].tolist(), strict=False))
    inside = points_in_polygons(x, y, [[np.column_stack([ring["x"], ring["y"]])]])
    assert inside.mean() >= 0.97
