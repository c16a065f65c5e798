"""Grey-scale morphology with line, square and disk windows against brute force."""

import numpy as np
import pytest

from aldpat.core.morphology import (
    WINDOWS,
    closing,
    dilation,
    disk_footprint,
    disk_rectangles,
    erosion,
    opening,
)


def _footprint(window, k, axis):
    if window == "line":
        shape = (1, 2 * k + 1) if axis == 1 else (2 * k + 1, 1)
        return np.ones(shape, bool)
    if window == "square":
        return np.ones((2 * k + 1, 2 * k + 1), bool)
    return disk_footprint(k)


def _brute(z, fp, maximum):
    """Window clipped to the grid: pad with +-inf and take min/max over the footprint."""
    hr, hc = fp.shape[0] // 2, fp.shape[1] // 2
    pad = -np.inf if maximum else np.inf
    p = np.pad(z, ((hr, hr), (hc, hc)), constant_values=pad)
    out = np.full(z.shape, pad)
    for dr, dc in zip(*np.nonzero(fp), strict=False):
        part = p[dr:dr + z.shape[0], dc:dc + z.shape[1]]
        out = np.maximum(out, part) if maximum else np.minimum(out, part)
    return out


@pytest.mark.parametrize("window,axis", [("line", 0), ("line", 1), ("square", 1), ("disk", 1)])
@pytest.mark.parametrize("k", [0, 1, 2, 3, 5, 7])
def test_erosion_dilation_match_brute_force(window, axis, k):
    rng = np.random.default_rng(k)
    z = rng.normal(size=(17, 23))
    fp = _footprint(window, k, axis)
    assert np.array_equal(erosion(z, k, window=window, axis=axis), _brute(z, fp, False))
    assert np.array_equal(dilation(z, k, window=window, axis=axis), _brute(z, fp, True))
    e = _brute(z, fp, False)
    assert np.array_equal(opening(z, k, window=window, axis=axis), _brute(e, fp, True))
    d = _brute(z, fp, True)
    assert np.array_equal(closing(z, k, window=window, axis=axis), _brute(d, fp, False))


@pytest.mark.parametrize("k", range(25))
def test_disk_rectangles_cover_the_disk_exactly(k):
    cover = np.zeros((2 * k + 1, 2 * k + 1), bool)
    for hr, hc in disk_rectangles(k):
        cover[k - hr:k + hr + 1, k - hc:k + hc + 1] = True
    assert np.array_equal(cover, disk_footprint(k))


def test_disk_footprint_radius_two():
    assert disk_footprint(2).astype(int).tolist() == [
        [0, 0, 1, 0, 0],
        [0, 1, 1, 1, 0],
        [1, 1, 1, 1, 1],
        [0, 1, 1, 1, 0],
        [0, 0, 1, 0, 0],
    ]


def test_opening_removes_objects_narrower_than_the_window():
    # a flat ground at 0 with a 3-cell wide "building" of height 10 along x
    z = np.zeros((5, 20))
    z[:, 8:11] = 10.0
    assert opening(z, 1, window="line", axis=1).max() == 10.0  # window 3 cells: kept
    assert opening(z, 2, window="line", axis=1).max() == 0.0  # window 5 cells: removed
    # along y the building is as long as the grid: never removed
    assert opening(z, 2, window="line", axis=0).max() == 10.0
    assert opening(z, 2, window="square").max() == 0.0
    # a closing fills a one-cell pit
    z = np.zeros((5, 5))
    z[2, 2] = -5.0
    assert closing(z, 1, window="disk").min() == 0.0


def test_does_not_modify_input_and_k0_is_identity():
    z = np.arange(12.0).reshape(3, 4)
    for w in WINDOWS:
        out = opening(z, 0, window=w)
        assert np.array_equal(out, z) and out is not z
    erosion(z, 2)
    assert np.array_equal(z, np.arange(12.0).reshape(3, 4))


@pytest.mark.parametrize("kwargs", [{"k": -1}, {"k": 1.5}, {"k": 1, "window": "hex"}, {"k": 1, "window": "line", "axis": 2}])
def test_bad_arguments(kwargs):
    k = kwargs.pop("k")
    with pytest.raises(ValueError):
        erosion(np.zeros((3, 3)), k, **kwargs)
    with pytest.raises(ValueError):
        erosion(np.zeros(3), 1)


@pytest.mark.parametrize("window", WINDOWS)
def test_out_and_work_buffers_give_the_same_answer(window):
    rng = np.random.default_rng(11)
    z = rng.normal(size=(20, 30))
    out, work = np.empty_like(z), np.empty_like(z)
    got = opening(z, 3, window=window, out=out, work=work)
    assert got is out and np.array_equal(out, opening(z, 3, window=window))
    assert erosion(z, 2, window=window, out=work) is work
    assert np.array_equal(work, erosion(z, 2, window=window))
    with pytest.raises(ValueError, match="separate"):
        erosion(z, 1, window=window, out=z)
    with pytest.raises(ValueError, match="separate"):
        dilation(z, 1, window=window, out=np.empty((3, 3)))
    with pytest.raises(ValueError, match="separate"):
        erosion(z, 1, window=window, out=np.empty(z.shape, np.float32))
    z32 = z.astype(np.float32)
    assert erosion(z32, 2, window=window).dtype == np.float32
    assert np.array_equal(erosion(z32, 2, window=window), erosion(z, 2, window=window).astype(np.float32))


def test_opening_along_trend_keeps_a_slope_rising_to_the_edge():
    """The edge cell repeated makes the last k cells of a rising slope a bump (the nearest
    opening cuts them); continued along the trend they stay, and a plane is its own opening."""
    from aldpat.core.morphology import opening_along_trend

    c = np.arange(60, dtype=float)
    rising = np.vstack([0.4 * c, -0.3 * c + 5.0, np.full(60, 2.0)])
    assert np.allclose(opening_along_trend(rising, 8), rising)
    nearest = opening(rising, 8, window="line", axis=1)
    assert nearest[0, -1] == pytest.approx(0.4 * (59 - 8))  # what the nearest border does
    # a roof at the edge, narrower than the window, is continued at the ground's height beside
    # it and opened away, as it is with the edge cell repeated
    roof = np.zeros((1, 60))
    roof[0, 53:] = 6.0
    assert np.allclose(opening_along_trend(roof, 8), 0.0)
    # away from the ends (2 k cells) it is the plain opening
    rng = np.random.default_rng(1)
    z = rng.normal(size=(5, 70))
    assert np.array_equal(opening_along_trend(z, 6)[:, 12:-12], opening(z, 6, window="line", axis=1)[:, 12:-12])
    short = rng.normal(size=(2, 3))
    assert np.array_equal(opening_along_trend(short, 2), opening(short, 2, window="line", axis=1))


@pytest.mark.parametrize("k, n", [(1, 4), (1, 5), (2, 8), (2, 9), (3, 13), (6, 70), (8, 20), (20, 81)])
def test_trend_opening_at_ends_is_the_whole_rows_opening_there(k, n):
    """The end pieces opened alone give the very values of opening the whole rows along the
    trend: on rows just longer than 4 k (the pieces' reach) and on rows the pieces cover."""
    from aldpat.core.morphology import opening_along_trend, trend_opening_at_ends

    rng = np.random.default_rng(k * 100 + n)
    z = np.round(rng.normal(size=(7, n)).cumsum(axis=1), 2)
    z[2] = np.linspace(0, 30, n)  # rising to the edge: the continuation's values get picked
    whole = opening_along_trend(z, k)
    first, last = trend_opening_at_ends(z, k)
    reach = min(2 * k, n)
    assert np.array_equal(first, whole[:, :reach])
    assert np.array_equal(last, whole[:, n - reach:])
