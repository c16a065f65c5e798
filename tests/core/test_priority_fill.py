"""Priority boundary interpolation (dissertation ch. 4 §4.2.4 PQBoundInterp, findEmpConn)."""

from __future__ import annotations

import numpy as np
import pytest

from aldpat.core.lowest_grid import fill_nearest
from aldpat.core.priority_fill import empty_sets, priority_fill


def test_empty_sets_four_and_eight_connectivity():
    empty = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1]], bool)
    assert empty_sets(empty, connectivity=8)[1] == 1
    assert empty_sets(empty, connectivity=4)[1] == 3
    with pytest.raises(ValueError):
        empty_sets(empty, connectivity=6)


def test_set_floods_at_its_lowest_boundary_with_a_mean_rim():
    # ground 0 on the left, 3 on the right; a hole in between
    z = np.array([[0.0, np.nan, np.nan, np.nan, 3.0]] * 3)
    empty = np.isnan(z)
    out = priority_fill(z, empty, connectivity=4)
    # interior cell: the lowest boundary value; rims: mean of 4-neighbours (set cells at 0)
    np.testing.assert_allclose(out[1], [0.0, 0.0, 0.0, 0.75, 3.0])  # (0 + 3 + 0 + 0) / 4
    np.testing.assert_allclose(out[0], [0.0, 0.0, 0.0, 1.0, 3.0])   # (0 + 3 + 0) / 3 at the edge


def test_remnant_is_not_widened_as_nearest_neighbour_widens_it():
    z = np.zeros((15, 15))
    empty = np.zeros_like(z, bool)
    empty[2:13, 2:13] = True       # removed ring around ...
    z[6:9, 6:9] = 10.0             # ... a remnant left standing
    empty[6:9, 6:9] = False
    near = fill_nearest(np.where(empty, np.nan, z), empty)
    prio = priority_fill(z, empty, connectivity=8)
    high = lambda a: int((a > 5).sum())
    assert high(near) > 9 * 4           # nearest neighbour spreads the remnant
    assert high(prio) == 9              # priority interpolation leaves it its own size
    assert prio[empty].max() < 10.0 * 3 / 8 + 1e-9  # rim cells see at most 3 remnant cells of 8


def test_small_sets_are_left_alone():
    z = np.zeros((6, 6))
    z[0, 0] = 5.0
    empty = np.zeros_like(z, bool)
    empty[3, 3] = True
    z[3, 3] = 42.0
    out = priority_fill(z, empty, min_conn=1)
    assert out[3, 3] == 42.0
    out = priority_fill(z, empty, min_conn=0)
    assert out[3, 3] == 0.0


def test_rising_flood_follows_the_nearest_low_boundary():
    # a wide removed block on a 1 m/cell slope: rise 0 floods it at its lowest boundary,
    # a rise of 1 m per cell lets each cell take min(z(b) + distance) = its own slope height
    x = np.arange(30.0)
    z = np.tile(x, (12, 1))
    empty = np.zeros_like(z, bool)
    empty[2:10, 1:29] = True
    flat = priority_fill(z, empty, connectivity=8)
    np.testing.assert_allclose(flat[4:8, 3:27], 0.0)
    rising = priority_fill(z, empty, connectivity=8, rise=1.0)
    np.testing.assert_allclose(rising[4:8, 3:27], np.tile(x[3:27], (4, 1)))


def _reference_rising_flood(z, valued, work, rise, max_sweeps=64):
    """The whole-grid numpy form of the rising flood (running minima over offset stretches):
    the compiled one must give the same floats, bit for bit, or classes could move."""
    def offsets_of(stop, step):
        out = []
        for src in (stop, stop[:, ::-1]):
            seg = np.cumsum(src, axis=1, dtype=np.float64)
            out.append((seg[:, -1:] - seg) * step)
        return out

    def envelope(v, offs, step):
        ramp = np.arange(v.shape[1], dtype=np.float64)[None, :] * rise
        out = np.full(v.shape, np.inf)
        for sign, offset in zip((1, -1), offs, strict=False):
            acc = np.minimum.accumulate((v if sign == 1 else v[:, ::-1]) - ramp + offset, axis=1)
            acc += ramp
            acc -= offset
            acc[acc > step / 4.0] = np.inf
            np.minimum(out, acc if sign == 1 else acc[:, ::-1], out=out)
        return out

    stop = valued | (~valued & ~work)
    step = 4.0 * (float(np.abs(z[valued]).max()) + rise * max(z.shape) + 1.0)
    offs, offs_t = offsets_of(stop, step), offsets_of(np.ascontiguousarray(stop.T), step)
    v = np.where(valued, z, np.inf)
    for _ in range(max_sweeps):
        before = v[work]
        np.copyto(v, np.minimum(v, envelope(v, offs, step)), where=work)
        vt = np.ascontiguousarray(v.T)
        np.copyto(vt, np.minimum(vt, envelope(vt, offs_t, step)), where=work.T)
        v = np.ascontiguousarray(vt.T)
        with np.errstate(invalid="ignore"):  # inf - inf where a cell is still unreached
            if not (before - v[work] > 1e-6).any():
                break
    out = z.copy()
    out[work] = v[work]
    return out


def test_compiled_rising_flood_equals_the_whole_grid_form_bit_for_bit():
    from aldpat.core.priority_fill import _rising_flood

    rng = np.random.default_rng(3)
    for _ in range(40):
        rows, cols = rng.integers(2, 40, 2)
        z = np.round(np.cumsum(rng.normal(0, 0.5, (rows, cols)), axis=1) + 300, 2)
        empty = rng.random((rows, cols)) < rng.uniform(0.1, 0.9)
        empty[rng.integers(rows):, rng.integers(cols):] = True
        if empty.all() or not empty.any():
            continue
        work = empty & (rng.random((rows, cols)) < 0.9)  # the rest: barriers (sets left alone)
        rise = float(rng.choice([0.3, 0.8, 1.0]))
        expected = _reference_rising_flood(z, ~empty, work, rise)
        assert np.array_equal(_rising_flood(z, ~empty, work, rise), expected)


def test_rising_flood_on_threads_equals_the_whole_grid_form(monkeypatch):
    """A grid large enough to be cut into row ranges and bands of columns, one per thread."""
    from aldpat.core import priority_fill as module
    from aldpat.core.threads import ENV

    monkeypatch.setenv(ENV, "3")
    rng = np.random.default_rng(5)
    z = np.round(np.cumsum(rng.normal(0, 0.4, (200, 800)), axis=0) + 250, 2)
    empty = rng.random(z.shape) < 0.3
    empty[40:150, 100:700] = True
    work = empty & (rng.random(z.shape) < 0.95)
    assert np.array_equal(module._rising_flood(z, ~empty, work, 0.8), _reference_rising_flood(z, ~empty, work, 0.8))


def test_in_place_gives_the_values_of_a_copy():
    rng = np.random.default_rng(7)
    z = np.round(np.cumsum(rng.normal(0, 0.5, (50, 70)), axis=1) + 120, 2)
    empty = rng.random(z.shape) < 0.5
    expected = priority_fill(z, empty, rise=0.8)
    given = z.copy()
    assert priority_fill(given, empty, rise=0.8, in_place=True) is given
    assert np.array_equal(given, expected)
    kept = z.copy()  # sets left alone keep their own values: a copy, the input untouched
    assert np.array_equal(priority_fill(kept, empty, rise=0.8, min_conn=2, in_place=True),
                          priority_fill(z, empty, rise=0.8, min_conn=2))
    assert np.array_equal(kept, z)
