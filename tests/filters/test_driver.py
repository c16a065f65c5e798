"""The grid-filter registry and the driver's point classification."""

from dataclasses import dataclass

import numpy as np
import pytest
from terrain_scenes import slope_with_low_clump

from aldpat.errors import DataError, ParamError
from aldpat.filters.driver import ground_filter
from aldpat.filters.marks import MARK_INTERPOLATED, MARK_NON_GROUND
from aldpat.filters.options import GroundParams
from aldpat.filters.registry import FILTERS, get_filter, register_filter
from aldpat.params import param


@dataclass(frozen=True)
class _StepParams(GroundParams):
    height: float = param(1.0, "cells higher than this above the grid minimum are removed", unit="m")


@dataclass(frozen=True)
class _RotParams(GroundParams):
    angles: tuple[float, ...] = param((0.0,), "angles", unit="deg")


@pytest.fixture
def step_filter():
    """A filter whose answer is known: cells above min + height get mark 3."""
    seen = {}

    def fn(z, empty, params):
        seen["z"], seen["empty"] = z.copy(), empty.copy()
        marks = np.where(z > z.min() + params.height, 3, 0).astype(np.int32)
        marks[empty] = 99  # the driver must override this
        return marks

    register_filter("_step", params=_StepParams, summary="test")(fn)
    register_filter("_rot", params=_RotParams, summary="test", rotations=lambda p: p.angles)(
        lambda z, empty, p: np.where(z > z.min() + 1.0, 2, 0))
    yield seen
    FILTERS.pop("_step")
    FILTERS.pop("_rot")


def test_classification_hand_case(step_filter):
    # 1 m cells over x 0..4, y 0..1: a 3 x 1 grid with the middle... laid out explicitly
    x = np.array([0.5, 0.6, 1.5, 1.4, 3.5, 3.2])
    y = np.array([0.5, 0.5, 0.5, 0.5, 0.5, 0.5])
    z = np.array([0.0, 0.2, 5.0, 0.25, 0.1, 2.0])
    # cells: (0,0) pts 0,1 lowest 0; (0,1) pts 2,3 lowest 3 (z .25); (0,2) empty; (0,3) pts 4,5
    res = ground_filter(x, y, z, "_step", _StepParams(cell=1.0, ground_tolerance=0.3))
    assert res.grid.empty.tolist() == [[False, False, True, False]]
    # the filter saw the empty cell filled by its nearest neighbour (tie between .25 and .1)
    assert step_filter["z"][0, 2] in (0.25, 0.1)
    assert step_filter["empty"].tolist() == [[False, False, True, False]]
    assert res.marks.tolist() == [[0, 0, MARK_INTERPOLATED, 0]]
    # point 1: 0.2 above a surface of 0.0 .. 0.25 -> ground; point 2: 5 m up -> removed,
    # no window removed it -> MARK_NON_GROUND; point 5: 1.9 above -> removed
    assert res.is_ground.tolist() == [True, True, False, True, True, False]
    assert res.point_marks.tolist() == [0, 0, MARK_NON_GROUND, 0, 0, MARK_NON_GROUND]


def test_lowest_points_follow_cell_marks_and_others_the_surface(step_filter):
    # flat ground at 0 with 3 points per cell at 0, 0.2, 0.6 ... and a 4 x 4 block at +5
    g = np.arange(0.5, 10, 1.0)
    gx, gy = np.meshgrid(g, g)
    gx, gy = gx.ravel(), gy.ravel()
    roof = (gx > 3) & (gx < 7) & (gy > 3) & (gy < 7)
    base = np.where(roof, 5.0, 0.0)
    x = np.concatenate([gx, gx + 0.1, gx - 0.1])
    y = np.concatenate([gy, gy, gy + 0.2])
    z = np.concatenate([base, base + 0.2, base + 0.6])
    res = ground_filter(x, y, z, "_step", _StepParams(cell=1.0, ground_tolerance=0.3))
    n = len(gx)
    roof3 = np.tile(roof, 3)
    assert res.point_marks[:n][roof].tolist() == [3] * roof.sum()
    assert res.is_ground[:n].tolist() == (~roof).tolist()
    assert res.is_ground[n:2 * n].tolist() == (~roof).tolist()  # 0.2 above ground: kept
    assert not res.is_ground[2 * n:].any()  # 0.6 above: removed everywhere
    # non-lowest roof points take their cell's mark, others the smallest window
    assert (res.point_marks[n:][roof3[n:]] == 3).all()
    assert (res.point_marks[2 * n:][~roof] == MARK_NON_GROUND).all()
    # the final ground surface under the roof is filled from ground cells
    assert np.nanmax(res.surface) == 0.0 and not np.isnan(res.surface).any()


def test_center_mode_gives_one_point_per_cell(step_filter):
    x = np.array([0.1, 0.9, 2.2])
    y = np.array([0.3, 0.8, 0.4])
    z = np.array([1.0, 0.5, 9.0])
    res = ground_filter(x, y, z, "_step", _StepParams(cell=1.0))
    c = res.center()
    assert c.x.tolist() == [0.5, 2.5] and c.y.tolist() == [0.5, 0.5]
    assert c.z.tolist() == [0.5, 9.0] and c.index.tolist() == [1, 2]
    assert c.is_ground.tolist() == [True, False] and c.marks.tolist() == [0, 3]


def test_rotations_combine_ground_only_if_every_orientation_keeps_it(step_filter):
    rng = np.random.default_rng(0)
    x = rng.uniform(0, 20, 800)
    y = rng.uniform(0, 20, 800)
    z = np.where(np.hypot(x - 10, y - 10) < 3, 4.0, 0.0)
    one = ground_filter(x, y, z, "_rot", _RotParams(angles=(0.0,)))
    three = ground_filter(x, y, z, "_rot", _RotParams(angles=(0.0, 30.0, 60.0)))
    assert three.angles == (0.0, 30.0, 60.0)
    assert np.array_equal(one.is_ground, z == 0)
    assert np.array_equal(three.is_ground, z == 0)
    # a rotated-only run still reports the axis-aligned grid
    rot = ground_filter(x, y, z, "_rot", _RotParams(angles=(45.0,)))
    assert rot.marks.shape == one.marks.shape and np.array_equal(rot.is_ground, z == 0)


def test_unknown_filter_suggests_a_name(step_filter):
    with pytest.raises(ParamError, match="did you mean '_step'"):
        get_filter("_stepp")


def test_wrong_params_and_bad_values(step_filter):
    x = np.zeros(3)
    with pytest.raises(ParamError, match="takes _StepParams"):
        ground_filter(x, x, x, "_step", GroundParams())
    with pytest.raises(ParamError, match="cell"):
        ground_filter(x, x, x, "_step", _StepParams(cell=-1.0))
    with pytest.raises(DataError):
        ground_filter(x, x, np.array([0.0, np.nan, 1.0]), "_step")


def test_empty_input(step_filter):
    res = ground_filter(np.zeros(0), np.zeros(0), np.zeros(0), "_step")
    assert res.count == 0 and res.is_ground.dtype == bool


def test_registration_rules():
    with pytest.raises(TypeError):
        register_filter("_bad", params=int, summary="x")
    register_filter("_twice", params=GroundParams, summary="x")(lambda z, e, p: z)
    try:
        with pytest.raises(ValueError, match="twice"):
            register_filter("_twice", params=GroundParams, summary="x")(lambda z, e, p: z)
    finally:
        FILTERS.pop("_twice")


def test_low_outliers_are_set_aside_and_the_ground_around_them_kept():
    """A clump of 40 multipath points 3-8 m below a slope and 10 isolated ones: without the
    test most of them are taken for ground, and ground around them is rejected; the defaults
    set every one aside and keep all the ground."""
    from aldpat.filters.gapm import GapmParams
    from aldpat.filters.marks import MARK_LOW_OUTLIER

    xs, ys, zs, ground = slope_with_low_clump(isolated=10)
    without = ground_filter(xs, ys, zs, "gapm", GapmParams(low_outliers=None))
    assert (~without.is_ground[ground]).sum() > 5 and without.is_ground[~ground].sum() > 40
    res = ground_filter(xs, ys, zs, "gapm", GapmParams())
    assert (~res.is_ground[ground]).sum() == 0 and res.is_ground[~ground].sum() == 0
    assert (res.point_marks[~ground] == MARK_LOW_OUTLIER).all()
    assert len(res.is_ground) == len(zs)  # every point classified, none dropped
