"""UTM zone prefixes by digit count and the stop gap (manual task 2)."""

import numpy as np

from aldpat.core.returns import stop_gap_mask, strip_zone, zone_prefix


def test_zone_prefix_by_digit_count():
    x = np.array([17_512_345.67, 512_345.67, 5_512_345.0])
    y = np.array([172_834_567.89, 2_834_567.89, 52_834_567.0])
    zx, zy = zone_prefix(x, y)
    assert zx.tolist() == [17, 0, 5]
    assert zy.tolist() == [17, 0, 5]
    sx, sy = strip_zone(x[:1], y[:1], 17)
    # within a few ulps of 1.7e8 (3e-8 each), far below the 0.01 the tape is written with
    assert abs(sx[0] - 512_345.67) < 1e-7 and abs(sy[0] - 2_834_567.89) < 1e-7


def test_stop_gap_marks_unreliable_last_returns():
    first = np.array([10.0, 20.0, 30.0, 40.0])
    last = np.array([10.0, 15.0, 25.01, 30.0])
    assert stop_gap_mask(first, last, 5.0).tolist() == [True, False, True, False]
