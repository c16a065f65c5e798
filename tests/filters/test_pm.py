"""Progressive morphology with line (``pm``), square (``pm2d``) and disk (``pmcircle``) windows
(manual appendix PM, task 8)."""

import numpy as np
import pytest

from aldpat.core.morphology import disk_footprint
from aldpat.errors import ParamError
from aldpat.filters import FILTERS, ground_filter
from aldpat.filters.pm import (
    PM2DParams,
    PMCircleParams,
    PMParams,
    pm,
    rotation_angles,
    threshold_series,
    window_series,
)


def test_power_window_series_and_min_window():
    # 2 ** (0, 0.5, 1 ... 4) = 1, 1.41, 2, 2.83, 4, 5.66, 8, 11.3, 16: rounded, repeats dropped
    assert window_series(PMParams()) == (1, 2, 3, 4, 6, 8, 11, 16)
    assert window_series(PMParams(power_increment=1.0, window_series_length=5)) == (1, 2, 4, 8, 16)
    assert window_series(PMParams(window_base=3.0, power_increment=1.0, window_series_length=3)) == (1, 3, 9)
    # base 1.5: 1, 1.5, 2.25, 3.375 -> 1, 2, 2, 3: repeats dropped
    assert window_series(PMParams(window_base=1.5, power_increment=1.0, window_series_length=4)) == (1, 2, 3)
    assert window_series(PMParams(min_window=3)) == (3, 4, 6, 8, 11, 16)
    assert window_series(PMParams(window_series=(2, 5, 9))) == (2, 5, 9)
    with pytest.raises(ParamError, match="ascending"):
        window_series(PMParams(window_series=(4, 2)))
    with pytest.raises(ParamError, match="min_window"):
        window_series(PMParams(window_series=(1, 2), min_window=3))


def test_threshold_rule_of_the_manual():
    # w = 3, 5, 9, 17, 33 cells; dh = 0.3 for w <= 3, else 0.3 * (w - w_prev) * 1 + 0.3, cap 2.5
    p = PMParams(cell=1.0, slope=0.3, init_threshold=0.3, max_threshold=2.5)
    assert threshold_series(p, (1, 2, 4, 8, 16)) == pytest.approx((0.3, 0.9, 1.5, 2.5, 2.5))
    # cell 2 m doubles the slope term; a first window above 3 cells grows from w = 1
    p = PMParams(cell=2.0, slope=0.1, init_threshold=0.2, max_threshold=9999.0)
    assert threshold_series(p, (2, 3)) == pytest.approx((0.1 * 4 * 2 + 0.2, 0.1 * 2 * 2 + 0.2))
    p = PMParams(window_series=(1, 2), threshold_series=(0.5, 1.0))
    assert threshold_series(p, (1, 2)) == (0.5, 1.0)
    with pytest.raises(ParamError, match="threshold_series"):
        threshold_series(p, (1, 2, 4))
    with pytest.raises(ParamError, match="threshold_series: expected one value per window"):
        PMParams(threshold_series=(0.5, 1.0))  # eight windows by default: refused when made


def test_direction_picks_the_axis():
    # a wall long in y (rows) and 3 cells wide in x
    z = np.zeros((40, 40))
    z[:, 18:21] = 5.0
    empty = np.zeros(z.shape, bool)
    along_x = pm(z, empty, PMParams(direction="x", window_series=(1, 2)))
    along_y = pm(z, empty, PMParams(direction="y", window_series=(1, 2)))
    both = pm(z, empty, PMParams(direction="xy", window_series=(1, 2)))
    assert (along_x[:, 18:21] == 2).all() and along_x.sum() == 2 * 40 * 3
    assert (along_y == 0).all()
    assert np.array_equal(both, along_x)


def test_rotation_angles():
    assert rotation_angles(PMParams()) == (0.0,)
    assert rotation_angles(PMParams(rotate_angle=30.0)) == (0.0,)  # rotate_times 0: unrotated
    assert rotation_angles(PMParams(rotate_angle=30.0, rotate_times=2)) == (30.0, 60.0)


def _dike(angle_deg):
    """Flat ground with a 2 m dike, 3 m wide and 80 m long, running at angle_deg."""
    g = np.arange(0.25, 100, 0.5)
    x, y = (a.ravel() for a in np.meshgrid(g, g))
    t = np.radians(angle_deg)
    along = (x - 50) * np.cos(t) + (y - 50) * np.sin(t)
    across = -(x - 50) * np.sin(t) + (y - 50) * np.cos(t)
    on = (np.abs(across) < 1.5) & (np.abs(along) < 40)
    core = (np.abs(across) < 0.5) & (np.abs(along) < 30)  # cells wholly on the dike
    return x, y, np.where(on, 2.0, 0.0), on, core


def test_rotation_lines_windows_up_with_a_linear_feature():
    """Rotating the data onto the dike keeps it with windows along x (manual, Rotate Angle)."""
    x, y, z, on, inner = _dike(45.0)
    base = {"cell": 1.0, "direction": "x", "window_series": (1, 2, 4, 8), "threshold_series": (0.3, 0.5, 0.5, 0.5)}
    plain = ground_filter(x, y, z, "pm", PMParams(**base))
    assert not plain.is_ground[on].any()  # the 45-degree dike crosses the x windows: removed
    rotated = ground_filter(x, y, z, "pm", PMParams(**base, rotate_angle=-45.0, rotate_times=1))
    assert rotated.angles == (-45.0,)
    assert rotated.is_ground[inner].all()
    assert rotated.is_ground[~on].all()
    # a second rotation at -90 degrees puts x across the dike again: removed
    twice = ground_filter(x, y, z, "pm", PMParams(**base, rotate_angle=-45.0, rotate_times=2))
    assert not twice.is_ground[inner].any()


def test_one_method_three_window_shapes():
    """pm, pm2d and pmcircle are the one progressive opening; their params fix the window."""
    assert {FILTERS[name].fn for name in ("pm", "pm2d", "pmcircle")} == {pm}
    assert PMParams(direction="xy").openings() == (("line", 1), ("line", 0))
    assert PMParams(direction="y").openings() == (("line", 0),)
    assert PM2DParams().openings() == (("square", 1),)
    assert PMCircleParams().openings() == (("disk", 1),)


def test_square_building_removed_by_the_first_window_wider_than_it():
    z = np.zeros((30, 30))
    z[10:15, 10:15] = 6.0  # 5 x 5 cells
    marks = pm(z, np.zeros(z.shape, bool), PM2DParams(window_series=(1, 2, 4, 8)))
    # thresholds 0.3, 0.9, 1.5, 2.5: the 3x3 and 5x5 windows fit on the roof, 9x9 does not
    assert (marks[10:15, 10:15] == 4).all()
    assert marks.sum() == 4 * 25


def test_sloped_ground_within_the_threshold_is_kept():
    r, c = np.mgrid[0:50, 0:50]
    z = 0.2 * r + 0.1 * c  # about 0.22 m per cell, below slope 0.3
    marks = pm(z, np.zeros(z.shape, bool), PM2DParams())
    assert marks.max() == 0


def test_disk_cuts_square_corners_where_a_square_window_does_not():
    z = np.zeros((30, 30))
    z[10:15, 10:15] = 6.0  # 5 x 5 cells
    empty = np.zeros(z.shape, bool)
    disk = pm(z, empty, PMCircleParams(window_series=(2, 4)))
    square = pm(z, empty, PM2DParams(window_series=(2, 4)))
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
    marks = pm(z, np.zeros(z.shape, bool), PMCircleParams(window_series=(1, 2, 4)))
    assert (marks[z > 0] > 0).all() and (marks[z == 0] == 0).all()


def test_a_long_wrong_window_series_is_quoted_by_its_start():
    """A parameter file's window series of a thousand ones was quoted whole in the error (3 kB)."""
    from aldpat.filters.pm import PMParams

    with pytest.raises(ParamError) as refused:
        PMParams(window_series=(1,) * 1000)
    assert str(refused.value).endswith("... (3,000 characters)") and len(str(refused.value)) < 200
