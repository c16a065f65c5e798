"""Raised segments: a roof of any size is an object, hills and terraces are terrain."""

from __future__ import annotations

import numpy as np
import pytest

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


def test_terraces_stepping_up_a_slope_are_terrain():
    """Four 40-cell terraces behind 4 m walls: each middle terrace steps down along one side (120
    cells) and up along the other (120), with 80 cells of open edge: 120 / 320 = 0.375 of its
    perimeter goes down, under half; the top one likewise (120 down, 200 open)."""
    _, c = np.mgrid[0:120, 0:160]
    z = 100.0 + 4.0 * (c // 40) + 0.01 * c
    assert not raised_segments(z, step=2.0, down_share=0.5).any()
    assert raised_segments(z, step=2.0, down_share=0.35)[:, 40:].all()  # what the share guards


def test_a_hall_around_a_courtyard_is_raised_and_the_courtyard_is_not():
    """A 60 x 80 hall around a 40 x 50 courtyard sunk to the ground: the hall steps down on its
    280 outer and 180 inner perimeter cells (raised); the courtyard steps only up (terrain)."""
    z = sloped()
    z[30:90, 40:120] += 6.0
    z[40:80, 50:100] -= 6.0
    expected = np.zeros(z.shape, bool)
    expected[30:90, 40:120] = True
    expected[40:80, 50:100] = False
    np.testing.assert_array_equal(raised_segments(z, step=2.0, down_share=0.7), expected)


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


def test_strips_label_the_grid_as_a_whole():
    """Labelled a few rows at a time (segments joined across the strips' edges), the raised cells
    are those of labelling the whole grid at once; heights given as codes give the same."""
    from pathlib import Path

    import laspy

    from aldpat.core.height_codes import ScaledHeights
    from aldpat.core.lowest_grid import fill_nearest, lowest_grid

    las = laspy.read(Path(__file__).resolve().parents[1] / "data" / "fsite5_strip.laz")
    grid = lowest_grid(np.asarray(las.x), np.asarray(las.y), np.asarray(las.z), 1.0)
    z = fill_nearest(grid.z, grid.empty)
    whole = raised_segments(z, 2.5, 0.4, strip_rows=z.shape[0])
    assert 0 < whole.sum() < whole.size // 4  # objects found, terrain left
    for rows in (1, 2, 7, 64):
        assert np.array_equal(raised_segments(z, 2.5, 0.4, strip_rows=rows), whole)
    heights = ScaledHeights(float(las.header.scales[2]), float(las.header.offsets[2]))
    codes = np.rint((z - heights.offset) / heights.scale).astype(np.int32)
    assert np.array_equal(heights.decode(codes), z)
    assert np.array_equal(raised_segments(codes, 2.5, 0.4, decode=heights.decode, strip_rows=5), whole)


def test_equal_largest_segments_keep_the_first_as_terrain():
    """Two terrain halves of equal size split by a wall: the first in row order is the terrain,
    as one labelling of the whole grid numbers it -- whichever strip each starts in."""
    z = np.zeros((12, 9))
    z[6:, :] = 5.0  # the upper half is raised, bounded by down-steps on one side
    for rows in (1, 3, 5, 12):
        raised = raised_segments(z, 1.0, 0.1, strip_rows=rows)
        assert not raised[:6].any() and raised[6:].all()


def test_a_building_is_removed_level_by_level():
    """A 60 x 80 hall around a 40 x 50 tower: the hall steps down on its 280 outer cells and up on
    its 180 inner ones (280 / 460 = 0.61 < 0.7). Once the tower (all down-steps) is raised, the
    steps up into it no longer count and the hall is raised too; counting every step, it is not."""
    z = sloped()
    z[30:90, 40:120] += 6.0
    z[40:80, 50:100] += 8.0
    expected = np.zeros(z.shape, bool)
    expected[30:90, 40:120] = True
    np.testing.assert_array_equal(raised_segments(z, step=2.0, down_share=0.7), expected)
    plain = raised_segments(z, step=2.0, down_share=0.7, levels=False)
    assert plain[40:80, 50:100].all() and not plain[30:40].any()


def test_a_lower_building_in_a_courtyard_corner_is_raised():
    """A ring (15 cells wide) round a courtyard; a lower building fills its north-west corner:
    up to the ring on two sides, down to the courtyard on two (a share of 0.5). Once the ring is
    raised the building is; the courtyard, stepping only up, stays terrain."""
    z = sloped()
    z[20:100, 30:130] += 20.0  # the ring
    z[35:85, 45:115] -= 20.0  # the courtyard, back at ground level
    z[35:60, 45:85] += 8.0  # the lower building against the ring's inner corner
    raised = raised_segments(z, step=2.0, down_share=0.55)
    assert raised[35:60, 45:85].all()
    assert not raised[60:85, 45:115].any() and not raised[35:60, 85:115].any()
    assert not raised_segments(z, step=2.0, down_share=0.55, levels=False)[35:60, 45:85].any()


def test_a_level_sunk_into_a_roof_is_raised_and_a_sunken_courtyard_is_not():
    """A roof level 4 m below the roof around it, 10 m above the ground: stepping only up, into
    the raised roof, yet standing above the ground the roof steps down to -- raised. The same
    hollow sunk to the ground is a courtyard (terrain)."""
    z = sloped()
    z[30:90, 40:120] += 14.0
    z[45:75, 60:100] -= 4.0
    raised = raised_segments(z, step=2.0, down_share=0.55)
    assert raised[30:90, 40:120].all() and raised.sum() == 60 * 80
    z[45:75, 60:100] -= 10.0
    raised = raised_segments(z, step=2.0, down_share=0.55)
    assert not raised[45:75, 60:100].any() and raised[30:45, 40:120].all()


def test_a_terrace_below_a_house_and_the_next_terrace_is_terrain():
    """A terrace stepping down to the one below, up to the next one and, along part of that side,
    up into a house: once the house is raised, the steps up into the next terrace still hold it."""
    _, c = np.mgrid[0:120, 0:160]
    z = 100.0 + 4.0 * (c // 40) + 0.01 * c
    z[40:80, 72:80] += 7.0  # a house against the terrace wall above (columns 72-79)
    raised = raised_segments(z, step=2.0, down_share=0.55)
    assert raised[40:80, 72:80].all() and raised.sum() == 40 * 8


def test_sparse_points_on_a_steep_hill_are_one_segment():
    """Points 5.5 m apart on a hill with 45 % slopes, filled by their nearest: neighbouring cells
    of different points differ by up to 2.5 m, more than the step, so the hilltop stands above
    steps down all round. Told how far apart the points are, the test reads those differences as
    the slope's; a 6 m wall between points is still a step."""
    from aldpat.core.lowest_grid import fill_nearest

    r, c = np.mgrid[0:176, 0:176].astype(float)
    hill = 130 - 0.45 * 0.5 * np.hypot(r - 88, c - 88)  # 0.5 m cells
    holders = (r % 11 == 5) & (c % 11 == 5)
    spacing = np.empty(hill.shape, np.uint8)
    filled = fill_nearest(np.where(holders, hill, np.nan), ~holders, spacing=spacing)
    assert raised_segments(filled, 2.0, 0.55).any()  # the hilltop, split off by the filled cells' steps
    assert not raised_segments(filled, 2.0, 0.55, spacing=spacing, cell=0.5).any()
    block = hill + np.where((r >= 55) & (r < 121) & (c >= 55) & (c < 121), 6.0, 0.0)
    filled = fill_nearest(np.where(holders, block, np.nan), ~holders, spacing=spacing)
    roof = raised_segments(filled, 2.0, 0.55, spacing=spacing, cell=0.5)
    assert roof[60:116, 60:116].all() and not roof[:50].any()


def test_a_plateau_larger_than_any_roof_is_terrain_and_a_roof_beside_it_is_not():
    """A mesa of 400 m x 300 m (12 ha) standing 20 m above the plain on every side, and a 60 m
    square hall on the plain: both are enclosed by down-steps, only the hall is an object. A block
    of terrain is no roof, whatever its steps (``MAX_OBJECT_AREA``: 10 ha)."""
    from aldpat.core.segments import MAX_OBJECT_AREA

    cell = 1.0
    z = sloped(rows=500, cols=600, slope=0.01, cell=cell)
    z[50:350, 50:450] += 20.0  # the mesa
    z[400:460, 480:540] += 8.0  # the hall
    assert 300 * 400 * cell ** 2 > MAX_OBJECT_AREA > 60 * 60 * cell ** 2
    raised = raised_segments(z, step=2.0, down_share=0.5, cell=cell)
    assert raised[400:460, 480:540].all()
    assert raised.sum() == 60 * 60  # nothing of the mesa or the plain
    # the bound is an area: 200 x 200 cells enclosed by a 20 m cliff are an object at 0.5 m cells
    # (1 ha), terrain at 2 m cells (16 ha)
    small = sloped(rows=300, cols=300, slope=0.01)
    small[50:250, 50:250] += 20.0
    assert raised_segments(small, step=2.0, down_share=0.5, cell=0.5).sum() == 200 * 200
    assert not raised_segments(small, step=2.0, down_share=0.5, cell=2.0).any()


@pytest.mark.parametrize("threads", ["1", "3"])
def test_compiled_graph_equals_the_numpy_form_bit_for_bit(threads, monkeypatch):
    """The segments, their sizes, open edges and mean heights, and per pair of segments the
    steps, cells and the lower cells' height sums: the values of the former numpy form (strips
    labelled as images, pairs found by sorting) to the last bit, for heights and for codes, with
    and without the spacing of filled cells, strips of 1 row to the whole grid, the strips
    labelled on one thread or several."""
    monkeypatch.setenv("ALDPAT_THREADS", threads)
    from aldpat.core.height_codes import ScaledHeights
    from aldpat.core.segments import _segment_graph
    from tests.core.segments_reference import segment_graph

    rng = np.random.default_rng(7)
    heights = ScaledHeights(0.01, 10.0)
    for case in range(12):
        rows, cols = rng.integers(2, 30, 2)
        if case % 3 == 2:  # roofs and yards: level patches a step apart
            z = rng.choice([0.0, 3.0, 6.0, 0.3], (rows, cols)) + rng.normal(0, 0.2, (rows, cols))
        else:  # rough terrain
            z = rng.normal(0, 2, (rows, cols)).cumsum(axis=case % 2)
        z = np.round(z, 2)
        codes = np.rint((z - heights.offset) / heights.scale).astype(np.int32)
        spacing = rng.integers(0, 5, (rows, cols)).astype(np.uint8) if case % 4 else None
        step, cell = float(rng.choice([0.3, 1.5, 2.0])), float(rng.choice([0.5, 1.0]))
        for strip_rows in (1, 3, 256):
            for grid, decode in ((z, None), (codes, heights.decode)):
                new = _segment_graph(grid, step, decode, spacing, cell, strip_rows)
                old = segment_graph(grid, step, decode, spacing, cell, strip_rows)
                assert new.terrain == old.terrain
                for name in ("segment", "open", "size", "height", "high", "low", "edges", "high_cells",
                             "low_cells", "low_sum"):
                    a, b = getattr(new, name), getattr(old, name)
                    assert a.shape == b.shape, name
                    assert np.array_equal(a, b), name
                    if b.dtype.kind == "f" and b.size:  # the float sums to the bit
                        assert a.dtype == b.dtype and np.array_equal(a.view(np.uint8), b.view(np.uint8)), name
