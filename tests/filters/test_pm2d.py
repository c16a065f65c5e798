"""Progressive morphology with square windows (manual task 8, Morph 2D Filter)."""

import numpy as np

from aldpat.filters.pm2d import PM2DParams, pm2d


def test_square_building_removed_by_the_first_window_wider_than_it():
    z = np.zeros((30, 30))
    z[10:15, 10:15] = 6.0  # 5 x 5 cells
    marks = pm2d(z, np.zeros(z.shape, bool), PM2DParams(window_series=(1, 2, 4, 8)))
    # thresholds 0.3, 0.9, 1.5, 2.5: the 3x3 and 5x5 windows fit on the roof, 9x9 does not
    assert (marks[10:15, 10:15] == 4).all()
    assert marks.sum() == 4 * 25


def test_sloped_ground_within_the_threshold_is_kept():
    r, c = np.mgrid[0:50, 0:50]
    z = 0.2 * r + 0.1 * c  # about 0.22 m per cell, below slope 0.3
    marks = pm2d(z, np.zeros(z.shape, bool), PM2DParams())
    assert marks.max() == 0
