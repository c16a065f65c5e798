"""Raised segments: a roof of any size is an object, hills and terraces are terrain."""

from __future__ import annotations

import numpy as np

from aldpat.core.segments import raised_segments


def sloped(rows=120, cols=160, slope=0.2, cell=1.0):
    r, c = np.mgrid[0:rows, 0:cols]
    return 100.0 + slope * c * cell + 0.05 * r * cell


def test_a_building_larger_than_any_window_is_raised():
    z = sloped()
    z[30:100, 40:130] += 9.0  # a 70 m x 90 m shed: wider than any morphological window
    raised = raised_segments(z, step=2.0, down_share=0.5)
    assert raised[30:100, 40:130].all()
    assert raised.sum() == 70 * 90  # nothing of the terrain


def test_a_steep_hill_joins_the_terrain():
    r, c = np.mgrid[0:120, 0:160]
    z = 100.0 + 30.0 * np.exp(-(((r - 60) / 25.0) ** 2 + ((c - 80) / 25.0) ** 2))  # slopes up to ~1
    assert not raised_segments(z, step=2.0, down_share=0.5).any()


def test_a_terrace_above_a_cliff_running_out_of_the_data_is_terrain():
    z = sloped()
    z[:, 100:] += 6.0  # the upper terrace: smaller than the lower part, bounded by a cliff
    assert not raised_segments(z, step=2.0, down_share=0.5).any()


def test_a_pit_is_not_raised_and_a_flat_grid_has_no_segments():
    z = sloped()
    z[50:60, 50:60] -= 5.0
    assert not raised_segments(z, step=2.0, down_share=0.5).any()
    assert not raised_segments(np.zeros((3, 3)), step=1.0, down_share=0.5).any()
    assert not raised_segments(np.zeros((1, 1)), step=1.0, down_share=0.5).any()


def test_hand_computed_small_grid():
    # 5 x 5 ground at 0 with a 2 x 2 block at 3 m: the block's 8 perimeter steps all go down
    z = np.zeros((5, 5))
    z[1:3, 2:4] = 3.0
    expected = np.zeros((5, 5), bool)
    expected[1:3, 2:4] = True
    np.testing.assert_array_equal(raised_segments(z, step=1.0, down_share=1.0), expected)
    # a bump of 0.5 m is not a step of 1 m: one segment, the terrain
    z[1:3, 2:4] = 0.5
    assert not raised_segments(z, step=1.0, down_share=0.5).any()
