"""Progressive morphology with circular windows (manual task 8, Morph Circle Filter)."""

import numpy as np

from aldpat.core.morphology import disk_footprint
from aldpat.filters.pm2d import PM2DParams, pm2d
from aldpat.filters.pmcircle import PMCircleParams, pmcircle


def test_disk_cuts_square_corners_where_a_square_window_does_not():
    z = np.zeros((30, 30))
    z[10:15, 10:15] = 6.0  # 5 x 5 cells
    empty = np.zeros(z.shape, bool)
    disk = pmcircle(z, empty, PMCircleParams(window_series=(2, 4)))
    square = pm2d(z, empty, PM2DParams(window_series=(2, 4)))
    # the only disk of radius 2 inside the 5x5 roof is centred on it: the roof cells it does
    # not cover (corners and their neighbours) go at window 2, the rest at 4
    inside = disk_footprint(2)
    assert disk[10:15, 10:15].tolist() == np.where(inside, 4, 2).tolist()
    assert disk[10, 10] == 2 and disk[10, 12] == 4
    assert (square[10:15, 10:15] == 4).all()
    assert disk.sum() == 4 * inside.sum() + 2 * (25 - inside.sum())


def test_round_object_removed_whatever_its_orientation():
    r, c = np.mgrid[0:41, 0:41]
    z = np.where(np.hypot(r - 20, c - 20) <= 3.2, 5.0, 0.0)  # a 7-cell wide round tank
    marks = pmcircle(z, np.zeros(z.shape, bool), PMCircleParams(window_series=(1, 2, 4)))
    assert (marks[z > 0] > 0).all() and (marks[z == 0] == 0).all()
