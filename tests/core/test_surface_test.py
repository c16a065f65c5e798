"""SMRF's final test: every point judged against the interpolated provisional ground surface."""

from __future__ import annotations

import numpy as np

from aldpat.core.lowest_grid import GridSpec
from aldpat.core.surface_test import bilinear, provisional_surface, slope_of, within_surface


def plane(spec: GridSpec, a=0.3, b=-0.1, c=50.0):
    xc, yc = spec.centers()
    return c + a * xc[None, :] + b * yc[:, None]


def test_the_surface_of_a_plane_with_a_building_hole_is_the_plane():
    spec = GridSpec(0.0, 0.0, 1.0, 40, 50)
    z = plane(spec)
    ground = np.ones(z.shape, bool)
    ground[10:30, 15:35] = False  # the building's cells: interpolated across, not filled by steps
    z[~ground] += 8.0
    surface = provisional_surface(z, ground, spec)
    np.testing.assert_allclose(surface, plane(spec), atol=1e-9)
    np.testing.assert_allclose(slope_of(surface, 1.0), np.hypot(0.3, 0.1), atol=1e-9)


def test_points_within_threshold_plus_slope_term():
    spec = GridSpec(0.0, 0.0, 1.0, 20, 20)
    surface = plane(spec, a=0.5, b=0.0)  # slope 0.5
    x = np.array([5.5, 5.5, 5.5, 5.5, 10.0])
    y = np.array([5.5, 5.5, 5.5, 5.5, 10.0])
    at = 50.0 + 0.5 * x
    z = at + np.array([0.0, 0.79, 0.81, -0.79, 2.0])
    # tolerance 0.3 + 1.0 x 0.5 = 0.8 m on either side
    got = within_surface(x, y, z, surface, spec, threshold=0.3, slope_scalar=1.0)
    assert got.tolist() == [True, True, False, True, False]
    assert bilinear(surface, spec, np.array([3.0]), np.array([7.0]))[0] == 50.0 + 0.5 * 3.0
