"""The compiled rise above an opening and the removed / band cells equal numpy's, bit for bit."""

import math

import numpy as np

from aldpat.core.height_codes import ScaledHeights
from aldpat.core.rise import heights_and_rise, removed_and_band, scale_and_offset


def test_decoded_rise_is_numpys_to_the_bit():
    rng = np.random.default_rng(3)
    heights = ScaledHeights(0.001, 312.457)
    codes = rng.integers(-2_000_000, 2_000_000, size=(9, 31)).astype(np.int32)
    opened = np.minimum(codes, rng.integers(-2_000_000, 2_000_000, size=codes.shape).astype(np.int32))
    assert scale_and_offset(heights.decode) == (0.001, 312.457)
    z, rise = heights_and_rise(codes, opened, heights.decode)
    assert np.array_equal(z.view(np.int64), heights.decode(codes).view(np.int64))
    expected = heights.decode(codes) - heights.decode(opened)
    assert np.array_equal(rise.view(np.int64), expected.view(np.int64))
    # float heights (no decoding): the array itself and a plain difference
    f = heights.decode(codes)
    same, plain = heights_and_rise(f, f - 1.5)
    assert same is f and np.array_equal(plain, np.full(f.shape, 1.5))
    assert scale_and_offset(None) is None and scale_and_offset(np.negative) is None


def test_removed_and_band_match_the_masks():
    rng = np.random.default_rng(4)
    rise = rng.normal(1.0, 1.0, size=(6, 40))
    rise[0, :3] = np.nan
    unfiltered = rng.random(rise.shape) > 0.2
    for cap, floor in ((2.0, 0.5), (1.0, math.inf), (0.3, 0.3)):
        removed, band = removed_and_band(rise, unfiltered, cap, floor)
        with np.errstate(invalid="ignore"):
            assert np.array_equal(removed, (rise > cap) & unfiltered)
            expected = np.flatnonzero((rise > floor) & unfiltered & ~(rise > cap))
        assert np.array_equal(band, expected)
