"""Every registered grid filter on synthetic terrain with known ground.

The tests loop over :data:`aldpat.filters.FILTERS`, so a filter is tested here the moment it
is registered.
"""

import inspect

import numpy as np
import pytest

from aldpat.filters import FILTERS, MARK_INTERPOLATED, ground_filter
from aldpat.params import specs

ALL = sorted(FILTERS)
#: Filters whose classes depend only on a bounded neighbourhood: a tile filtered with
#: a buffer wider than that neighbourhood gets the classes of the whole area in its core.
LOCAL = ("etew", "pm", "pm2d", "pmcircle")
#: Filters meant to remove isolated outliers only (dissertation §4.1.1), not buildings or trees.
OUTLIERS_ONLY = {"outlier"}
GROUND_FILTERS = [n for n in ALL if n not in OUTLIERS_ONLY]
#: Settings a user gives for this scene where the defaults are made for other data: slope tests
#: a point against neighbours within its search radius only, so the radius must reach the edge
#: from the middle of the widest building (20 x 18 m here; the default 8 m suits ISPRS data).
SCENE_PARAMS = {"slope": {"search_radius": 12.0}}


def terrain(seed=0, size=150.0, spacing=0.7):
    """Rolling ground (slopes up to ~0.25), buildings up to 20 m wide, trees; known labels."""
    rng = np.random.default_rng(seed)
    g = np.arange(0.0, size, spacing)
    x, y = (a.ravel() for a in np.meshgrid(g, g))
    x = x + rng.uniform(0, spacing, x.size)
    y = y + rng.uniform(0, spacing, y.size)
    ground_z = 6 * np.sin(x / 30.0) + 4 * np.cos(y / 25.0) + 0.05 * x + rng.normal(0, 0.03, x.size)
    z = ground_z.copy()
    obj = np.zeros(x.size, bool)
    for x0, y0, w, h, height in [(20, 20, 8, 12, 6.0), (60, 30, 20, 18, 9.0), (100, 90, 15, 10, 4.0),
                                 (30, 100, 12, 25, 7.0), (110, 20, 6, 6, 3.0)]:
        inside = (x >= x0) & (x < x0 + w) & (y >= y0) & (y < y0 + h)
        roof = 6 * np.sin((x0 + w / 2) / 30.0) + 4 * np.cos((y0 + h / 2) / 25.0) + 0.05 * (x0 + w / 2) + height
        z[inside] = roof
        obj |= inside
    for cx, cy, r, height in [(80, 120, 3.0, 8.0), (130, 60, 2.5, 6.0), (45, 70, 2.0, 5.0), (125, 130, 3.5, 10.0)]:
        d = np.hypot(x - cx, y - cy)
        inside = (d < r) & ~obj
        z[inside] = ground_z[inside] + height * (1 - 0.5 * (d[inside] / r) ** 2)
        obj |= inside
    return x, y, z, ~obj


@pytest.fixture(scope="module")
def scene():
    return terrain()


@pytest.fixture(scope="module")
def results(scene):
    x, y, z, _ = scene
    return {name: ground_filter(x, y, z, name, FILTERS[name].params(**SCENE_PARAMS.get(name, {})))
            for name in ALL}


def test_the_manuals_filters_are_registered():
    assert set(LOCAL) <= set(FILTERS)


@pytest.mark.parametrize("name", ALL)
def test_declaration(name):
    spec = FILTERS[name]
    assert spec.summary and spec.name == name
    spec.params()  # defaults are within their own bounds: checked as the instance is made
    for s in specs(spec.params):
        assert s.help, f"{name}.{s.name} has no help"
    doc = inspect.getmodule(spec.fn).__doc__ or ""
    assert "manual" in doc.lower() or "dissertation" in doc.lower(), "docstring must cite its source"


@pytest.mark.parametrize("name", GROUND_FILTERS)
def test_known_ground_with_defaults(name, scene, results):
    _, _, _, truth = scene
    res = results[name]
    type1 = 100.0 * np.sum(truth & ~res.is_ground) / truth.sum()
    type2 = 100.0 * np.sum(~truth & res.is_ground) / (~truth).sum()
    assert type1 < 1.0, f"{name}: {type1:.2f} % of the ground rejected"
    assert type2 < 2.0, f"{name}: {type2:.2f} % of the objects accepted"


@pytest.mark.parametrize("name", ALL)
def test_isolated_high_outliers(name):
    """Birds and other isolated high points: every filter removes them and keeps the ground."""
    rng = np.random.default_rng(7)
    x, y, z, truth = terrain(seed=3, size=80.0)
    k = rng.choice(np.flatnonzero(truth), 40, replace=False)
    z = z.copy()
    z[k] += rng.uniform(10.0, 40.0, k.size)
    res = ground_filter(x, y, z, name)
    assert not res.is_ground[k].any()
    others = truth.copy()
    others[k] = False
    assert np.mean(~res.is_ground[others]) < 0.01


@pytest.mark.parametrize("name", ALL)
def test_marks_agree_with_classes(name, results):
    res = results[name]
    assert res.point_marks.dtype == np.int32 and res.is_ground.dtype == bool
    assert np.array_equal(res.is_ground, res.point_marks == 0)
    assert (res.point_marks >= 0).all()  # interpolated marks never reach a point
    assert np.array_equal(res.marks == MARK_INTERPOLATED, res.grid.empty)
    c = res.center()
    assert len(c.x) == int((~res.grid.empty).sum())
    assert np.array_equal(c.is_ground, c.marks == 0)


@pytest.mark.parametrize("name", ALL)
def test_input_order_does_not_matter(name, scene, results):
    x, y, z, _ = scene
    order = np.random.default_rng(5).permutation(len(z))
    res = ground_filter(x[order], y[order], z[order], name, results[name].params)
    assert np.array_equal(res.is_ground, results[name].is_ground[order])


@pytest.mark.parametrize("name", ALL)
@pytest.mark.parametrize("case", ["one point", "one row", "flat"])
def test_degenerate_inputs(name, case):
    if case == "one point":
        x, y, z = np.array([5.5]), np.array([7.2]), np.array([3.0])
    elif case == "one row":
        x = np.arange(0.0, 50.0, 0.5)
        y = np.full_like(x, 3.3)
        z = np.where((x > 20) & (x < 24), 5.0, 0.0)
    else:
        x, y = (a.ravel() for a in np.meshgrid(np.arange(0.0, 20.0, 0.5), np.arange(0.0, 10.0, 0.5)))
        z = np.full(x.shape, 12.0)
    res = ground_filter(x, y, z, name)
    assert res.is_ground.shape == z.shape
    if case == "flat" or case == "one point":
        assert res.is_ground.all()
    else:
        assert res.is_ground[z == 0].all()


def _largest_window(name, p) -> int:
    """Full width (cells) of the largest window the filter uses."""
    from aldpat.filters.pm import window_series

    k = 2 ** (p.loop_times - 1) if name == "etew" else max(window_series(p))
    return 2 * k + 1


@pytest.mark.parametrize("name", LOCAL)
def test_tile_with_buffer_matches_whole_area(name):
    """A tile filtered with a buffer wider than the largest window, cut to its core,
    gets the classes of the whole area (the windows, the fill and the classification are local)."""
    x, y, z, _ = terrain(seed=1, size=140.0, spacing=0.8)
    kw = {"loop_times": 4} if name == "etew" else {"window_series": (1, 2, 4, 8)}
    p = FILTERS[name].params(**kw)
    whole = ground_filter(x, y, z, name, p)
    core = (x >= 50) & (x < 90) & (y >= 50) & (y < 90)
    buffer = (_largest_window(name, p) + 1) * p.cell
    tile = (x >= 50 - buffer) & (x < 90 + buffer) & (y >= 50 - buffer) & (y < 90 + buffer)
    part = ground_filter(x[tile], y[tile], z[tile], name, p)
    assert np.array_equal(part.is_ground[core[tile]], whole.is_ground[core])
    assert np.array_equal(part.point_marks[core[tile]], whole.point_marks[core])
