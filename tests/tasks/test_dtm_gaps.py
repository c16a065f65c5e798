"""``aldpat dtm``'s data gaps: nodes with no input point of any class within ``--max-gap`` are
blank, building footprints (roof points, none of them ground) stay bridged.

The known answer is a synthetic scene: 200 x 120 m of gently sloping ground (z = 100 + 0.05 x)
at one point a square metre, a 40 m band with no point at all (x 80..120: a river, a gap between
strips) and a 20 m square building whose roof, 10 m up, holds every point over its footprint.
The mean spacing is 1 m, so the default gap is 5 m: the band's nodes 6 m or more from its banks
are blank, those within 3 m are not, and the footprint is the ground's plane.
"""

from __future__ import annotations

from pathlib import Path

import laspy
import numpy as np
import pytest
import rasterio

from aldpat.core.data_gaps import Occupancy, blank_gaps, mean_spacing
from aldpat.core.grid_extent import GridSpec
from aldpat.errors import ParamError
from aldpat.tasks.dtm import DtmParams
from tests.cli.fresh import aldpat

BAND = (80.0, 120.0)  # x range of the band without points
ROOF = (30.0, 50.0, 40.0, 60.0)  # x0, x1, y0, y1 of the building


def scene() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """x, y, z and LAS class (2 ground, 6 building) of the scene's points."""
    rng = np.random.default_rng(27)
    x = rng.uniform(0, 200, 24_000)
    y = rng.uniform(0, 120, 24_000)
    keep = (x < BAND[0]) | (x >= BAND[1])
    x, y = x[keep], y[keep]
    roof = (x >= ROOF[0]) & (x < ROOF[1]) & (y >= ROOF[2]) & (y < ROOF[3])
    z = 100 + 0.05 * x + np.where(roof, 10.0, 0.0)
    return x, y, z, np.where(roof, 6, 2).astype(np.uint8)


@pytest.fixture(scope="module")
def scene_las(tmp_path_factory) -> Path:
    x, y, z, cls = scene()
    header = laspy.LasHeader(point_format=1, version="1.2")
    header.scales = [0.01, 0.01, 0.01]
    header.offsets = [0.0, 0.0, 0.0]
    las = laspy.LasData(header)
    las.x, las.y, las.z = x, y, z
    las.classification = cls
    las.return_number = np.ones(len(x), np.uint8)
    las.number_of_returns = np.ones(len(x), np.uint8)
    path = tmp_path_factory.mktemp("gaps") / "scene.las"
    las.write(path)
    return path


def read_dtm(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The DTM's values (NaN blank) and its node x, y, rows from the north."""
    with rasterio.open(path) as ds:
        band = ds.read(1).astype(np.float64)
        band[band == ds.nodata] = np.nan
        rows, cols = np.mgrid[0:ds.height, 0:ds.width]
        xs, ys = rasterio.transform.xy(ds.transform, rows.ravel(), cols.ravel())
    return band, np.reshape(xs, band.shape), np.reshape(ys, band.shape)


def band_nodes(xs, ys, lo: float, hi: float) -> np.ndarray:
    """Nodes with lo <= x <= hi, away from the scene's north and south borders."""
    return (xs >= lo) & (xs <= hi) & (ys >= 5) & (ys <= 115)


def footprint(xs, ys) -> np.ndarray:
    return (xs >= ROOF[0] + 1) & (xs <= ROOF[1] - 1) & (ys >= ROOF[2] + 1) & (ys <= ROOF[3] - 1)


def check_scene(path: Path, gap: float | None) -> None:
    """The band blank farther than ``gap`` from its banks (all bridged when None), its banks kept,
    the footprint on the ground's plane."""
    z, xs, ys = read_dtm(path)
    plane = 100 + 0.05 * xs
    if gap is None:
        assert not np.isnan(z[band_nodes(xs, ys, *BAND)]).any()
    else:
        assert np.isnan(z[band_nodes(xs, ys, BAND[0] + gap + 1, BAND[1] - gap - 1)]).all()
        kept = band_nodes(xs, ys, BAND[0], BAND[0] + gap - 2) | band_nodes(xs, ys, BAND[1] - gap + 2, BAND[1])
        assert kept.sum() > 100 and not np.isnan(z[kept]).any()
        assert np.abs(z[kept] - plane[kept]).max() < 0.05  # the banks' TIN, not a blank
    roof = footprint(xs, ys)
    assert not np.isnan(z[roof]).any()
    assert np.abs(z[roof] - plane[roof]).max() < 0.3  # bridged by the ground, not the roof 10 m up


def test_default_gap_blanks_the_band_and_bridges_the_building(scene_las, tmp_path):
    done = aldpat("dtm", scene_las, "--odir", tmp_path, "--crs", "EPSG:32632").ok()
    assert "max_gap" not in done.stderr
    log = (tmp_path / "scene_dtm.log").read_text()
    assert "filtered in two passes" in log  # the streamed path
    spacing = float(log.split("mean point spacing ")[1].split(" m")[0])
    assert spacing == pytest.approx(1.0, abs=0.05)
    check_scene(tmp_path / "scene_dtm.tif", 5.0)


def test_max_gap_overrides_and_none_turns_it_off(scene_las, tmp_path):
    aldpat("dtm", scene_las, "--odir", tmp_path / "15", "--max-gap", "15").ok()
    assert "within 15 m (--max-gap)" in (tmp_path / "15" / "scene_dtm.log").read_text()
    check_scene(tmp_path / "15" / "scene_dtm.tif", 15.0)
    aldpat("dtm", scene_las, "--odir", tmp_path / "none", "--max-gap", "none").ok()  # 0 is the same
    check_scene(tmp_path / "none" / "scene_dtm.tif", None)
    bad = aldpat("dtm", scene_las, "--odir", tmp_path / "bad", "--max-gap", "wide")
    assert bad.returncode != 0 and "max_gap" in bad.stderr and "auto or none" in bad.stderr


def test_the_files_own_classes_count_every_point(scene_las, tmp_path):
    # --classes 2: the roof points make no terrain, but they are points: the footprint is bridged
    aldpat("dtm", scene_las, "--odir", tmp_path, "--classes", "2").ok()
    check_scene(tmp_path / "scene_dtm.tif", 5.0)


def test_the_api_blanks_the_same_nodes(scene_las, tmp_path):
    import aldpat as api

    aldpat("dtm", scene_las, "--odir", tmp_path).ok()
    with rasterio.open(tmp_path / "scene_dtm.tif") as ds:
        command = ds.read(1)
    x, y, z, _ = scene()
    raster = api.dtm((np.round(x, 2), np.round(y, 2), np.round(z, 2)), cell=1.0)
    np.testing.assert_array_equal(raster.array == raster.nodata, command == -9999)
    assert (raster.array == raster.nodata).sum() > 110 * 25  # the band's middle
    off = api.dtm((x, y, z), cell=1.0, max_gap="none")
    assert (off.array == off.nodata).sum() < (raster.array == raster.nodata).sum()


def test_tiles_blank_the_band_and_share_their_edge_nodes(scene_las, tmp_path):
    from tests.cli.test_project_in_tiles import shared_nodes

    aldpat("tile", scene_las, "--width", "70", "--height", "60", "--buffer", "10", "--odir", "tiles",
           cwd=tmp_path).ok()
    aldpat("dtm", "tiles", "--odir", "dtm", "--mosaic", "dtm.vrt", "-j", "2", cwd=tmp_path).ok()
    # 70 x 60 m tiles: the band inside the middle column, the edge y = 60 across it and the building
    tifs = sorted((tmp_path / "dtm").glob("*_dtm.tif"))
    shared, differ = shared_nodes(tifs)
    assert shared > 400 and differ == 0
    logs = " ".join(p.read_text() for p in (tmp_path / "dtm").glob("*_dtm.log"))
    assert "mean point spacing 1" in logs  # one spacing for the project: the tile files' own
    check_scene(tmp_path / "dtm.vrt", 5.0)


def test_occupancy_distance_and_spacing_by_hand():
    spec = GridSpec(0.0, 0.0, 1.0, 1.0, 11, 1)  # 11 nodes on a line, 1 m apart
    occ = Occupancy(spec)
    occ.add(np.array([0.2, 10.4, 10.6, 99.0]), np.array([0.0, 0.0, 0.0, 0.0]))  # 10.6 rounds to node 11: outside
    assert occ.count == 4 and np.flatnonzero(occ.cells[0]).tolist() == [0, 10]
    values = np.zeros((1, 11))
    assert blank_gaps(values, spec, occ, 3.0) == 3  # nodes 4, 5, 6: more than 3 m from 0 and 10
    assert np.flatnonzero(np.isnan(values[0])).tolist() == [4, 5, 6]
    window = GridSpec(5.0, 0.0, 1.0, 1.0, 3, 1)  # nodes 5..7: the distance counts the points beyond them
    part = np.zeros((1, 3))
    assert blank_gaps(part, window, occ, 3.0) == 2 and np.isnan(part[0]).tolist() == [True, True, False]
    assert occ.on(GridSpec(9.0, 0.0, 1.0, 1.0, 4, 1)).tolist() == [[False, True, False, False]]
    grid = Occupancy(GridSpec(0.0, 0.0, 1.0, 1.0, 100, 100))
    xs, ys = np.meshgrid(np.arange(0, 50, 2.0), np.arange(0, 100, 2.0))  # half covered, 2 m apart
    grid.add(xs.ravel(), ys.ravel())
    assert mean_spacing(grid) == pytest.approx(2.0, rel=0.1)


def test_max_gap_is_checked_when_given():
    assert DtmParams().gap_setting() == "auto"
    assert DtmParams(max_gap="none").gap_setting() is None
    assert DtmParams(max_gap="0").gap_setting() is None
    assert DtmParams(max_gap="12.5").gap_setting() == 12.5
    for bad in ("-1", "nan", "inf", "wide"):
        with pytest.raises(ParamError, match="max_gap"):
            DtmParams(max_gap=bad)


@pytest.mark.parametrize("cell", [1.0, 1.5, 0.3])
@pytest.mark.parametrize("gaps", [(0.5, 4.0, 30.0), (2.0, 3.0, 5.0), (2 ** 0.5, 5 ** 0.5, 13 ** 0.5),
                                  (2.0 ** 63, 1e30, 250.0)])  # wider than the grids: a disc no larger
def test_gaps_are_those_of_a_distance_transform(cell, gaps):
    """A node is far exactly where a Euclidean distance transform of the grid puts it farther
    than the gap -- the gaps in cells, and the diagonals sqrt(2), sqrt(5), sqrt(13) cells, lie on
    its rounding edge -- on grids wider and narrower than the gap, with rows of no point."""
    from scipy.ndimage import distance_transform_edt

    from aldpat.core import data_gaps

    rng = np.random.default_rng(5)
    for shape in ((203, 57), (40, 3), (1, 30)):
        occupied = rng.random(shape) < 0.02
        occupied[shape[0] // 5:shape[0] // 2] = False  # rows without a point
        occupied[-1, -1] = True
        for gap in gaps:
            gap *= cell if gaps[0] != 0.5 else 1.0
            whole = distance_transform_edt(~occupied, sampling=cell).astype(np.float32) > np.float32(gap)
            np.testing.assert_array_equal(data_gaps.gap_nodes(occupied, gap, cell), whole)
            assert data_gaps.gap_nodes(np.zeros(shape, bool), gap, cell).all()  # no point: every node
