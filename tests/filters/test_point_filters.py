"""The manual's point filters (slope, ipf, poly2, atin) on cases with a known answer.

Every filter also runs through the registry loops of ``test_filter_registry.py`` and the
command-line tests; here: a hand-computed case for ``slope``, a sloped plane with boxes and
trees for all four, a cliff for ``atin``'s mirror points, and the independence of ``atin``'s
classes from the size of its rectangles.
"""

import numpy as np
import pytest
from terrain_scenes import slope_with_low_clump

from aldpat.errors import ParamError
from aldpat.filters import FILTERS, ground_filter
from aldpat.filters.atin import AtinParams
from aldpat.filters.polynomial import IpfParams, Poly2Params, half_window
from aldpat.filters.slope import SlopeParams

POINT_FILTERS = ("slope", "ipf", "poly2", "atin")


def test_registered_as_point_filters():
    for name in POINT_FILTERS:
        assert FILTERS[name].on_points


# ---------------------------------------------------------------------------- slope, by hand


def test_slope_five_points_by_hand():
    """Five points, each in its own 1 m cell. Slopes down from each point (rise / run):

    A (0.5, 0.5, 10.0)   B (3.5, 0.5, 10.9)   C (0.5, 4.5, 11.5)   D (6.5, 0.5, 10.0)
    E (0.8, 0.9, 10.2)   (E is 0.5 m from A: the pair is not compared when min_distance > 0.5)

    B -> A: 0.9 / 3 = 0.30;  B -> D: 0.9 / 3 = 0.30;   C -> A: 1.5 / 4 = 0.375;
    C -> E: 1.3 / hypot(0.3, 3.6) = 0.360;  E -> A: 0.2 / 0.5 = 0.40 (compared only when
    min_distance <= 0.5);  A and D have nothing below them.
    """
    x = np.array([0.5, 3.5, 0.5, 6.5, 0.8])
    y = np.array([0.5, 0.5, 4.5, 0.5, 0.9])
    z = np.array([10.0, 10.9, 11.5, 10.0, 10.2])

    def ground(**kw):
        return ground_filter(x, y, z, "slope", SlopeParams(**kw)).is_ground.tolist()

    # max slope 0.35, radius 5: B (0.30) ground; C (0.375) not; E -> A 0.40 not (0.5 m apart, compared)
    assert ground(max_slope=0.35, search_radius=5.0, min_distance=0.1) == [True, True, False, True, False]
    # E's only lower neighbour is A, 0.5 m away: ignored when pairs closer than 0.6 are not compared
    assert ground(max_slope=0.35, search_radius=5.0, min_distance=0.6) == [True, True, False, True, True]
    # a radius of 3.9 m puts A out of C's reach (4 m) but keeps E (3.61 m): 0.360 < 0.37
    assert ground(max_slope=0.37, search_radius=3.9, min_distance=0.1) == [True, True, True, True, False]
    # the slope of B is exactly 0.30: eq. (4) keeps only slopes below the threshold
    assert ground(max_slope=0.30, search_radius=5.0, min_distance=0.6)[1] is False
    # Min Z / Max Z: outside the band nothing is ground
    assert ground(max_slope=1.0, search_radius=5.0, min_distance=0.1, max_z=11.0) == [True, True, False, True, True]


def test_slope_rectangular_cells_compare_lowest_points_only():
    # two points share a 2 m x 1 m cell: the upper one is compared with the lowest one (1.5 m away)
    x = np.array([0.2, 1.7, 5.0])
    y = np.array([0.5, 0.5, 0.5])
    z = np.array([0.0, 1.0, 0.0])
    res = ground_filter(x, y, z, "slope", SlopeParams(cell=2.0, cell_height=1.0, max_slope=0.5, search_radius=4.0))
    assert res.is_ground.tolist() == [True, False, True]
    assert res.grid.spec.shape == (1, 3)  # 2 m cells along x
    c = res.center()
    assert c.x.tolist() == [1.0, 5.0] and c.y.tolist() == [0.5, 0.5]


def test_slope_bad_parameters():
    with pytest.raises(ParamError, match="min_distance"):
        SlopeParams(min_distance=5.0, search_radius=4.0)
    with pytest.raises(ParamError, match="min_z"):
        SlopeParams(min_z=10.0, max_z=5.0)


# ---------------------------------------------------------------------------- a sloped plane


def plane_with_objects(seed=0, size=160.0, spacing=0.8):
    """A plane rising 8 % to the east and 3 % to the north, 0.03 m noise, with boxes 6 to 24 m
    wide (3-10 m high) and round trees; returns x, y, z and the true ground flags."""
    rng = np.random.default_rng(seed)
    g = np.arange(0.0, size, spacing)
    x, y = (a.ravel() for a in np.meshgrid(g, g))
    x = x + rng.uniform(0, spacing, x.size)
    y = y + rng.uniform(0, spacing, y.size)
    z = 0.08 * x + 0.03 * y + rng.normal(0, 0.03, x.size)
    obj = np.zeros(x.size, bool)
    for x0, y0, w, h, height in [(20, 20, 10, 14, 6.0), (70, 40, 24, 20, 10.0), (120, 110, 15, 10, 4.0),
                                 (30, 110, 12, 24, 7.0), (125, 20, 6, 6, 3.0)]:
        inside = (x >= x0) & (x < x0 + w) & (y >= y0) & (y < y0 + h)
        z[inside] = 0.08 * (x0 + w) + 0.03 * (y0 + h) + height  # flat roof above the box's highest corner
        obj |= inside
    for cx, cy, r, height in [(90, 130, 3.0, 8.0), (140, 70, 2.5, 6.0), (50, 75, 2.0, 5.0)]:
        d = np.hypot(x - cx, y - cy)
        inside = (d < r) & ~obj
        z[inside] += height * (1 - 0.5 * (d[inside] / r) ** 2)
        obj |= inside
    return x, y, z, ~obj


@pytest.fixture(scope="module")
def plane():
    return plane_with_objects()


@pytest.mark.parametrize("name", POINT_FILTERS)
def test_sloped_plane_with_boxes_and_trees(name, plane):
    x, y, z, truth = plane
    res = ground_filter(x, y, z, name)
    type1 = 100.0 * np.sum(truth & ~res.is_ground) / truth.sum()
    type2 = 100.0 * np.sum(~truth & res.is_ground) / (~truth).sum()
    # slope compares points within its search radius: the middle of the 24 m box is beyond it
    limit2 = 12.0 if name == "slope" else 1.0
    assert type1 < 1.0, f"{name}: {type1:.2f} % of the ground rejected"
    assert type2 < limit2, f"{name}: {type2:.2f} % of the objects accepted"
    assert set(np.unique(res.point_marks)) <= {0, 1}
    assert np.array_equal(res.point_marks == 0, res.is_ground)


def test_slope_keeps_the_roofs_beyond_its_radius_only(plane):
    x, y, z, truth = plane
    res = ground_filter(x, y, z, "slope", SlopeParams(search_radius=15.0))
    assert np.sum(~truth & res.is_ground) == 0  # every roof point now sees an edge below it


# ---------------------------------------------------------------------------- ipf and poly2


def test_ipf_window_series_follows_the_manuals_formula():
    # floor(log2(40) - log2(1)) + 1 = 6 windows, halving
    assert IpfParams(init_window_length=40.0).windows() == (40.0, 20.0, 10.0, 5.0, 2.5, 1.25)
    assert IpfParams(init_window_length=40.0, window_series_length=3).windows() == (40.0, 20.0, 10.0)
    assert IpfParams(window_series=(30.0, 9.0)).windows() == (30.0, 9.0)
    with pytest.raises(ParamError, match="window_series"):
        IpfParams(window_series=(10.0, 20.0))
    assert half_window(40.0, 2.0) == 10 and half_window(1.25, 2.0) == 0 and half_window(3.0, 1.0) == 1


def test_ipf_recovers_a_hill_top_poly2_two_surfaces(plane):
    """A steep narrow hill: poly2's recovery keeps at least as much of its top as ipf."""
    x, y, z, truth = plane
    hill = np.hypot(x - 100.0, y - 90.0)
    zz = np.where(truth, z + 6.0 * np.exp(-(hill / 8.0) ** 2), z)
    top = truth & (hill < 4.0)
    ipf = ground_filter(x, y, zz, "ipf").is_ground
    poly2 = ground_filter(x, y, zz, "poly2", Poly2Params(sigma_difference=0.0)).is_ground
    assert poly2[top].mean() >= ipf[top].mean()
    assert poly2[top].mean() > 0.9


# ---------------------------------------------------------------------------- atin


def cliff(seed=1, n=40_000):
    """A 12 m cliff at x = 100 (a 1 m face), a 6 m house on the plateau."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(0, 200, n)
    y = rng.uniform(0, 200, n)
    z = np.where(x < 100, 0.02 * y, 12 + 0.02 * y) + rng.normal(0, 0.03, n)
    face = (x >= 99.5) & (x < 100.5)
    z[face] = 12 * (x[face] - 99.5) + 0.02 * y[face]
    house = (x > 140) & (x < 155) & (y > 50) & (y < 70)
    z[house] += 6
    return x, y, z, house


def test_atin_mirror_points_keep_the_foot_and_top_of_a_cliff():
    x, y, z, house = cliff()
    foot = (x > 97) & (x < 99.5)
    top = (x > 100.5) & (x < 103)
    with_mirror = ground_filter(x, y, z, "atin", AtinParams(mirror=True)).is_ground
    without = ground_filter(x, y, z, "atin", AtinParams(mirror=False)).is_ground
    assert with_mirror[foot].mean() > 0.99 and with_mirror[top].mean() > 0.9
    assert without[top].mean() < 0.1  # what the mirror points buy
    assert not with_mirror[house].any()
    assert with_mirror[~house & ~foot & ~top & ((x < 90) | (x > 110))].mean() > 0.999


def test_atin_classes_do_not_depend_on_the_rectangle_size(plane):
    x, y, z, _ = plane
    whole = ground_filter(x, y, z, "atin", AtinParams(tile_x_width=1000.0, tile_y_height=1000.0,
                                                      tile_buffer=0.0)).is_ground
    small = ground_filter(x, y, z, "atin", AtinParams(tile_x_width=50.0, tile_y_height=70.0,
                                                      tile_buffer=80.0)).is_ground
    assert np.array_equal(whole, small)


def test_atin_rectangles_far_smaller_than_their_buffer_are_refused_with_the_size_that_works():
    """Each rectangle triangulates its buffer's candidates again: 1 m rectangles with the default
    100 m buffer took 27 s on 7,492 points. The bound is the chunks' and tiles' (100 copies)."""
    from aldpat.errors import ParamError

    with pytest.raises(ParamError, match=r"triangulate each point 121 times \(at most 100\).* at least 22\.22 m"):
        AtinParams(tile_x_width=20.0, tile_y_height=20.0)
    AtinParams(tile_x_width=22.3, tile_y_height=22.3)
    AtinParams(tile_x_width=1.0, tile_y_height=1.0, tile_buffer=0.0)  # no buffer: each point once


def test_atin_angle_threshold_rejects_points_steep_from_their_vertices():
    x, y, z, truth = plane_with_objects(spacing=1.5)
    # the raised-segment test off: it would take the boxes out before either test sees them
    loose = ground_filter(x, y, z, "atin", AtinParams(z_difference=3.0, angle_threshold=0.0,
                                                      object_step=0.0)).is_ground
    angled = ground_filter(x, y, z, "atin", AtinParams(z_difference=3.0, angle_threshold=10.0,
                                                       object_step=0.0)).is_ground
    assert np.sum(~truth & angled) < np.sum(~truth & loose)


def test_atin_angle_min_distance_keeps_noisy_ground_near_vertices():
    """Ground with 3 cm noise at 1.5 m spacing: a 10-degree angle to a vertex 0.3 m away is 5 cm,
    so the plain angle test drops noisy ground; taken at 1.5 m at least, it keeps it."""
    x, y, z, truth = plane_with_objects(spacing=1.5)
    plain = ground_filter(x, y, z, "atin", AtinParams(angle_threshold=10.0, angle_min_distance=0.0)).is_ground
    relaxed = ground_filter(x, y, z, "atin", AtinParams(angle_threshold=10.0, angle_min_distance=1.5)).is_ground
    assert np.sum(truth & ~relaxed) < np.sum(truth & ~plain)


def test_atin_roof_larger_than_the_seed_squares_is_a_raised_segment():
    """A 70 x 50 m roof 8 m up on a sloped plane: 30 m seed squares lie wholly on it and
    seed it; the raised-segment test (on by default) takes the whole roof out first."""
    rng = np.random.default_rng(2)
    n = 60_000
    x, y = rng.uniform(0, 200, n), rng.uniform(0, 200, n)
    z = 0.05 * x + 0.02 * y + rng.normal(0, 0.03, n)
    roof = (x >= 60) & (x < 130) & (y >= 60) & (y < 110)
    z[roof] = 0.05 * 130 + 0.02 * 110 + 8.0
    plain = ground_filter(x, y, z, "atin", AtinParams(object_step=0.0)).is_ground
    segmented = ground_filter(x, y, z, "atin").is_ground
    assert plain[roof].mean() > 0.5  # seeded from the squares on the roof, it spreads over it
    assert not segmented[roof].any()
    assert segmented[~roof].mean() > 0.999


@pytest.mark.parametrize("name", POINT_FILTERS)
def test_point_filters_set_low_outliers_aside(name):
    """The clump of multipath points of the grid filters' low-outlier test, under every point
    filter: with ``low_outliers`` (the default) the clump is set aside (marked as the grid filters
    mark it) and the ground around it kept."""
    from aldpat.filters.marks import MARK_LOW_OUTLIER

    xs, ys, zs, ground = slope_with_low_clump()
    n = int(ground.sum())
    params = FILTERS[name].params
    without = ground_filter(xs, ys, zs, name, params(low_outliers=None))
    res = ground_filter(xs, ys, zs, name, params())
    lost_without, lost = (~without.is_ground[ground]).sum(), (~res.is_ground[ground]).sum()
    assert lost < lost_without and lost <= 0.01 * n, (lost_without, lost)
    assert res.is_ground[~ground].sum() <= 1
    assert (res.point_marks[~ground] == MARK_LOW_OUTLIER).sum() >= 39
