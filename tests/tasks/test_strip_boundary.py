"""strip-boundary (manual task 4) on a real strip and on a hand-made one."""

from pathlib import Path

import numpy as np
import pytest

from aldpat.core.polygon import points_in_polygons
from aldpat.tasks import get_task

DATA = Path(__file__).resolve().parents[1] / "data"
STRIP = DATA / "fsite5_strip.laz"


def test_real_strip_ring_encloses_the_strip(tmp_path):
    import laspy

    report = get_task("strip-boundary")([STRIP], cell=3.0, out_format="text",
                                        odir=str(tmp_path))
    assert report.exit_code == 0, report.results[0].error
    out = tmp_path / "fsite5_strip_Bound.txt"
    ring = np.loadtxt(out)
    assert ring.shape[1] == 4  # x y z i
    assert np.array_equal(ring[0], ring[-1])  # closed
    las = laspy.read(STRIP)
    x, y, z, i = (np.asarray(v, dtype=float) for v in (las.x, las.y, las.z, las.intensity))
    real = set(zip(np.round(x, 2), np.round(y, 2), np.round(z, 2), i, strict=False))
    assert all(tuple(p) in real for p in np.round(ring, 2))  # real data points
    inside = points_in_polygons(x, y, [[ring[:, :2]]])
    assert inside.mean() >= 0.97


def test_scan_option_and_grid_alignment(tmp_path):
    # points at cell centres of a 3 x 2 block of 2 m cells, lower left corner at (1, 1):
    # aligned cells are [0, 2) [2, 4) [4, 6) -> the block spans cells 0..3 in x
    xs, ys = np.meshgrid([1.5, 2.5, 3.5, 4.5, 5.5], [1.5, 2.5, 3.5])
    pts = np.column_stack([xs.ravel(), ys.ravel(), np.arange(15.0), np.ones(15)])
    src = tmp_path / "s.txt"
    np.savetxt(src, pts, fmt="%.2f %.2f %.2f %d")
    assert get_task("strip-boundary")([src], cell=2.0, scan="x").exit_code == 0
    ring = np.loadtxt(tmp_path / "s_Bound.txt")
    # rows [0,2) and [2,4): row 0 holds y 1.5, row 1 holds y 2.5 and 3.5; each end cell keeps its lowest z
    # right ends going north: cell (2,0) -> (4.5,1.5) z 3; cell (2,1) -> (4.5,2.5) z 8
    # left ends going south: cell (0,1) -> (1.5,2.5) z 5; cell (0,0) -> (1.5,1.5) z 0
    assert ring[:, :3].tolist() == [[4.5, 1.5, 3], [4.5, 2.5, 8], [1.5, 2.5, 5], [1.5, 1.5, 0], [4.5, 1.5, 3]]
    get_task("strip-boundary")([src], cell=2.0, scan="x", origin=(1.0, 1.0),
                               overwrite=True)
    moved = np.loadtxt(tmp_path / "s_Bound.txt")
    assert moved[:, :2].tolist() != ring[:, :2].tolist()  # --origin moves the cells


def test_too_few_cells_is_reported(tmp_path):
    src = tmp_path / "one.txt"
    np.savetxt(src, [[1.0, 1.0, 1.0], [1.1, 1.1, 1.0]], fmt="%.2f")
    report = get_task("strip-boundary")([src], cell=5.0)
    assert report.exit_code == 1 and "too few occupied cells" in report.results[0].error


def test_a_profile_or_a_strip_narrower_than_a_cell_says_which(tmp_path):
    """Points along one line (a profile) and a strip narrower than a cell were both told "use
    smaller cells": no cell size gives a profile an area. Each now says which it is, in a fresh
    process; the narrow strip at smaller cells has its ring."""
    from tests.cli.fresh import aldpat

    x = np.arange(0.0, 100.0, 0.5)
    np.savetxt(tmp_path / "profile.txt", np.c_[x, np.full_like(x, 10.0), np.ones_like(x)], fmt="%.2f")
    np.savetxt(tmp_path / "narrow.txt", np.c_[x, 10.0 + (x % 2.0), np.ones_like(x)], fmt="%.2f")
    np.savetxt(tmp_path / "point.txt", [[5.0, 5.0, 1.0]], fmt="%.2f")
    for name, why in (("profile", ("(2 boundary points): its points lie on one line (99.5 m by 0 m): a profile has "
                                  "no area, whatever the cells")),
                      ("narrow", ("(2 boundary points): the strip, 99.5 m by 1.5 m, is narrower than one 5 x 5 m "
                                 "cell; use smaller cells")),
                      ("point", "(1 boundary point): its points lie at one position")):
        done = aldpat("strip-boundary", f"{name}.txt", cwd=tmp_path)
        assert done.returncode == 1 and f"{name}.txt: too few occupied cells for a boundary polygon {why}" \
            in done.stderr, done.stderr
        assert not (tmp_path / f"{name}_Bound.txt").exists()
    aldpat("strip-boundary", "narrow.txt", "--cell", "0.5", cwd=tmp_path).ok()
    assert len(np.loadtxt(tmp_path / "narrow_Bound.txt")) >= 4


def test_a_strip_over_degrees_is_measured_in_degrees(tmp_path):
    """The sizes of a strip too narrow for its cells are in the coordinates' units: over longitude
    and latitude they were said in metres ("0.0099969 m by 0.0099975 m")."""
    from tests.cli.fresh import aldpat

    x = np.arange(0.0, 100.0, 0.5)
    np.savetxt(tmp_path / "lonlat.txt", np.c_[11.0 + x * 1e-4, 48.0 + (x % 2.0) * 1e-4, np.ones_like(x)], fmt="%.6f")
    done = aldpat("strip-boundary", "lonlat.txt", "--crs", "EPSG:4326", cwd=tmp_path)
    assert done.returncode == 1, done.stderr
    assert ("the strip, 0.00995 degrees by 0.00015 degrees, is narrower than one 5 x 5 degrees cell"
            in done.stderr), done.stderr


@pytest.mark.parametrize(("crs", "unit"), [(None, "m"), ("EPSG:32617", "m"), ("EPSG:4326", "degrees"),
                                           ("EPSG:2263", "US ft"), ("EPSG:2222", "ft"),
                                           ("EPSG:32632+5773", "m"), ("not a crs", "m")])
def test_the_coordinates_unit_is_named_as_messages_say_it(crs, unit):
    from aldpat.core.crs import coordinate_unit

    assert coordinate_unit(crs, None) == unit
    assert coordinate_unit(None, crs) == unit
