"""Thresholds decided at the data's precision, not by floating-point noise."""

from __future__ import annotations

import numpy as np

from aldpat.core.precision import above, below
from aldpat.core.returns import stop_gap_mask
from aldpat.tasks.split_tape import strip_starts


def test_a_difference_of_exactly_the_stop_gap_is_never_below_it():
    # each pair differs by exactly 5.00 m as written; in binary some differ by 4.999999999999999
    z_first = np.array([8.04, 10.00, 8.12, 255.83, 8.29])
    z_last = np.array([3.04, 5.00, 3.12, 250.83, 3.29])
    plain = (z_first - z_last) < 5.0
    assert plain.any() and not plain.all()  # the noise this guards against
    assert not stop_gap_mask(z_first, z_last, 5.0, decimals=2).any()
    assert stop_gap_mask(np.array([5.26]), np.array([0.27]), 5.0, decimals=2).all()  # 4.99 is below


def test_a_threshold_finer_than_the_data():
    assert below(np.array([4.99]), np.array([0.0]), 4.995, 2).all()
    assert not below(np.array([5.00]), np.array([0.0]), 4.995, 2).any()


def test_unknown_precision_falls_back_to_plain_comparison():
    assert below(np.array([1.0]), np.array([0.0]), 1.5, None).all()
    assert above(np.array([2e15]), np.array([0.0]), 1.0, 6).all()  # too fine to scale exactly


def test_a_time_jump_of_exactly_the_interval_does_not_split():
    t = np.array([318000.01, 318060.01, 318120.02, 318180.03])  # jumps 60.00, 60.01, 60.01
    assert strip_starts(t, None, 60.0, decimals=2).tolist() == [2, 3]
    assert strip_starts(t, 317940.01, 60.0, decimals=2).tolist() == [2, 3]
    assert strip_starts(t, 317940.00, 60.0, decimals=2).tolist() == [0, 2, 3]
