"""``aldpat dtm``: ground filter + TIN grid + GeoTIFF, tile by tile with buffers.

The known answer is ISPRS sample 24's reference labels: the DTM must pass through the bare-earth
points, and four buffered tiles must give the DTM of the whole file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rasterio

from aldpat.errors import ParamError
from aldpat.io.bounds import Bounds, point_bounds
from aldpat.tasks import get_task
from aldpat.tasks.dtm import DtmParams, plan_neighbours

SAMPLE = Path(__file__).resolve().parents[2] / "jobs" / "data" / "samp24.txt"  # x y z label


@pytest.fixture(scope="module")
def tiles(tmp_path_factory) -> Path:
    """Sample 24 whole and cut into 2 x 2 equal tiles, as ``aldpat tile`` cuts a project (no overlap:
    the buffer must come from the neighbours)."""
    root = tmp_path_factory.mktemp("dtm")
    rows = np.loadtxt(SAMPLE)
    np.savetxt(root / "whole.txt", rows[:, :3], fmt="%.2f")
    xm, ym = (rows[:, :2].min(axis=0) + rows[:, :2].max(axis=0)) / 2
    for i, west in enumerate((True, False)):
        for j, south in enumerate((True, False)):
            keep = ((rows[:, 0] < xm) == west) & ((rows[:, 1] < ym) == south)
            np.savetxt(root / f"tile_{i}{j}.txt", rows[keep, :3], fmt="%.2f")
    return root


def run_dtm(inputs, odir: Path, **options):
    report = get_task("dtm")(inputs, odir=str(odir), crs="EPSG:32632", **options)
    assert report.exit_code == 0, [r.error for r in report.results]
    return report


def ground_error(path: Path) -> tuple[float, float]:
    """RMSE (m) of the DTM at the reference bare-earth points, and the share of them it covers."""
    rows = np.loadtxt(SAMPLE)
    ground = rows[rows[:, 3] == 0]
    with rasterio.open(path) as ds:
        values = np.array([v[0] for v in ds.sample(ground[:, :2])], float)
        values[values == ds.nodata] = np.nan
    diff = values - ground[:, 2]
    covered = np.isfinite(diff)
    return float(np.sqrt(np.mean(diff[covered] ** 2))), float(covered.mean())


@pytest.fixture(scope="module")
def made(tiles, tmp_path_factory) -> dict[str, Path]:
    out = tmp_path_factory.mktemp("dtm_out")
    run_dtm([tiles / "whole.txt"], out / "whole")
    tiles_in = sorted(tiles.glob("tile_*.txt"))
    run_dtm(tiles_in, out / "buffered", mosaic=str(out / "buffered" / "dtm.vrt"))
    run_dtm(tiles_in, out / "unbuffered", mosaic=str(out / "unbuffered" / "dtm.vrt"), buffer=0.0)
    return {"whole": out / "whole" / "whole_dtm.tif", "buffered": out / "buffered" / "dtm.vrt",
            "unbuffered": out / "unbuffered" / "dtm.vrt"}


def test_dtm_passes_through_the_reference_ground(made):
    rmse, covered = ground_error(made["whole"])
    assert covered > 0.98
    assert rmse < 0.5  # 0.44 m measured; roofs or bushes kept as ground would add metres


def test_buffered_tiles_give_the_whole_files_dtm(made):
    with rasterio.open(made["whole"]) as a, rasterio.open(made["buffered"]) as b, \
            rasterio.open(made["unbuffered"]) as c:
        assert (a.bounds, a.shape) == (b.bounds, b.shape) == (c.bounds, c.shape)
        whole, buffered, unbuffered = (ds.read(1, masked=True) for ds in (a, b, c))
    buffered_gap = float(np.ma.abs(whole - buffered).mean())
    unbuffered_gap = float(np.ma.abs(whole - unbuffered).mean())
    assert buffered_gap < 0.01  # 0.002 m measured
    assert unbuffered_gap > 10 * buffered_gap  # without the buffer the tile edges go wrong
    rmse_whole, _ = ground_error(made["whole"])
    rmse_buffered, covered = ground_error(made["buffered"])
    rmse_unbuffered, _ = ground_error(made["unbuffered"])
    assert covered > 0.98 and rmse_buffered < rmse_whole + 0.02 < rmse_unbuffered


def test_the_dtm_is_a_georeferenced_cog(made, tiles):
    with rasterio.open(made["whole"]) as ds:
        assert ds.crs.to_epsg() == 32632 and ds.dtypes == ("float32",) and ds.nodata == -9999
        assert ds.tags(ns="IMAGE_STRUCTURE").get("LAYOUT") == "COG"
        assert ds.res == (1.0, 1.0)
        west, north = ds.xy(0, 0)  # node centres on whole metres, covering the points
        assert west % 1 == pytest.approx(0) and north % 1 == pytest.approx(0)
        b = point_bounds(tiles / "whole.txt")
        assert west <= b.minx < west + 1 and north - 1 < b.maxy <= north


def test_the_log_says_what_was_read(made):
    log = (made["buffered"].parent / "tile_00_dtm.log").read_text()
    assert "of 3 neighbouring inputs within 30 m" in log and "ground (gapm)" in log


def test_filter_parameters_and_auto(tiles, tmp_path):
    params = tmp_path / "pm.toml"
    params.write_text("cell = 2.0\nwindow_series = [1, 2, 4, 8]\n")
    run_dtm([tiles / "tile_00.txt"], tmp_path / "pm", algorithm="pm", filter_params=str(params), cell=2.0)
    with rasterio.open(tmp_path / "pm" / "tile_00_dtm.tif") as ds:
        assert ds.res == (2.0, 2.0)
    run_dtm([tiles / "tile_00.txt"], tmp_path / "auto", auto=True, grid_format="geotiff")
    assert "--auto: cell =" in (tmp_path / "auto" / "tile_00_dtm.log").read_text()
    with pytest.raises(ParamError, match="auto"):
        DtmParams(algorithm="pm", auto=True)
    params.write_text("window_series = [4, 2]\n")
    with pytest.raises(ParamError, match=r"filter_params: .*pm\.toml: window_series"):
        DtmParams(algorithm="pm", filter_params=str(params))


def test_a_filter_params_files_low_outlier_settings_stand_unless_the_command_sets_them(tmp_path):
    """``dtm``'s low-outlier and class options rank as a command line does: above a
    ``--filter-params`` file when set, below it when left at their defaults (set 01 turns the
    test off; a file's window, reach and classes stand)."""
    assert DtmParams().ground_params().low_outlier_window == 2  # dtm's own default, the shared one
    set01 = Path(__file__).resolve().parents[2] / "jobs" / "params" / "gapm-isprs-set01.toml"
    assert DtmParams(filter_params=str(set01)).ground_params().low_outliers is None
    own = tmp_path / "gapm.toml"
    own.write_text("low_outlier_window = 5\nlow_outlier_reach = 30.0\nignore_classes = [7]\n")
    from_file = DtmParams(filter_params=str(own)).ground_params()
    assert (from_file.low_outlier_window, from_file.low_outlier_reach, from_file.ignore_classes) == (5, 30.0, (7,))
    given = DtmParams(filter_params=str(own), low_outlier_window=3, low_outliers=None, ignore_classes=(18,))
    assert given.set_options() == {"low_outlier_window": 3, "low_outliers": None, "ignore_classes": (18,)}
    values = given.ground_params()
    assert (values.low_outlier_window, values.low_outliers, values.ignore_classes, values.low_outlier_reach) == \
        (3, None, (18,), 30.0)


def test_neighbours_are_the_inputs_within_the_buffer(tmp_path):
    for k in range(3):  # three 100 m tiles in a row, 100 m apart
        np.savetxt(tmp_path / f"t{k}.txt", [[200.0 * k, 0, 1], [200.0 * k + 100, 100, 1], [200.0 * k + 50, 50, 1]])
    sources = sorted(tmp_path.glob("t*.txt"))
    input_params = type("Input", (), {"format": None})()
    near = plan_neighbours(sources, DtmParams(buffer=120.0), input_params)
    assert [[Path(p).name for p in job] for job in near] == [["t0.txt", "t1.txt"], ["t1.txt", "t0.txt", "t2.txt"],
                                                              ["t2.txt", "t1.txt"]]
    assert plan_neighbours(sources, DtmParams(buffer=90.0), input_params) == [[str(s)] for s in sources]
    assert point_bounds(sources[1]) == Bounds(200.0, 0.0, 300.0, 100.0)


def test_a_neighbour_that_cannot_be_read_leaves_the_others_dtm_made(tiles, tmp_path):
    """A truncated neighbour fails alone, in one line of its own; the input beside it is still
    made, from its own points at that edge (the DTM made without the neighbour), with a warning."""
    import laspy

    rows = np.loadtxt(tiles / "tile_10.txt")
    las = laspy.LasData(laspy.LasHeader(point_format=0, version="1.2"))
    las.header.scales, las.header.offsets = [0.01] * 3, [513000.0, 5403000.0, 0.0]
    las.x, las.y, las.z = rows[:, 0], rows[:, 1], rows[:, 2]
    las.write(tmp_path / "whole.laz")
    bad = tmp_path / "tile_10.laz"  # its header whole (its extent known), its points cut short
    data = (tmp_path / "whole.laz").read_bytes()
    bad.write_bytes(data[:len(data) * 2 // 3])
    good = tmp_path / "tile_00.txt"
    good.write_text((tiles / "tile_00.txt").read_text())
    report = get_task("dtm")([good, bad], odir=str(tmp_path / "both"), crs="EPSG:32632")
    assert report.exit_code == 1
    failed = [r for r in report.results if r.error is not None]
    assert len(failed) == 1 and "tile_10.laz: truncated or corrupt LAS/LAZ" in str(failed[0].error)
    log = (tmp_path / "both" / "tile_00_dtm.log").read_text()
    assert "the buffer leaves out the neighbouring input tile_10.laz, which cannot be read" in log
    run_dtm([good], tmp_path / "alone")
    with rasterio.open(tmp_path / "both" / "tile_00_dtm.tif") as a, rasterio.open(tmp_path / "alone" / "tile_00_dtm.tif") as b:
        assert np.array_equal(a.read(1), b.read(1))


def shared_nodes_differing(folder: Path) -> tuple[int, int]:
    """(nodes held by two DTMs or more, of them those whose values differ in any bit)."""
    seen: dict[tuple[int, int], list[bytes]] = {}
    for path in sorted(folder.glob("*_dtm.tif")):
        with rasterio.open(path) as ds:
            band = ds.read(1)
            for r in range(ds.height):
                for c in range(ds.width):
                    x, y = ds.xy(r, c)
                    seen.setdefault((round(x), round(y)), []).append(band[r, c].tobytes())
    shared = [v for v in seen.values() if len(v) > 1]
    return len(shared), sum(len(set(v)) > 1 for v in shared)


@pytest.fixture(scope="module")
def project(tmp_path_factory) -> Path:
    """Sample 24 cut by 'aldpat tile' into 60 m tiles with a 10 m buffer: 3 x 2 tiles."""
    root = tmp_path_factory.mktemp("project")
    assert get_task("tile")([SAMPLE], width=60.0, height=60.0, buffer=10.0, fields="xyz",
                            odir=str(root / "tiles")).exit_code == 0
    return root


def test_tile_dtms_cover_their_cores_and_share_edge_nodes_bit_for_bit(project, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # --mosaic is a path like any other: from where the command runs
    run_dtm([project / "tiles"], tmp_path / "dtm", mosaic="all.vrt", jobs=2)
    tifs = sorted((tmp_path / "dtm").glob("*_dtm.tif"))
    assert len(tifs) == 6 and (tmp_path / "all.vrt").exists() and not (tmp_path / "dtm" / "all.vrt").exists()
    for path in tifs:
        x0, y0 = (float(v) for v in path.name.split("_")[1:3])
        with rasterio.open(path) as ds:
            assert ds.bounds == (x0 - 0.5, y0 - 0.5, x0 + 60.5, y0 + 60.5)  # the core's nodes, no buffer
    shared, differ = shared_nodes_differing(tmp_path / "dtm")
    assert (shared, differ) == (2 * 121 + 181 - 2, 0)  # the edges x 513780, x 513840, y 5403180
    rmse, covered = ground_error(tmp_path / "all.vrt")
    assert covered > 0.98 and rmse < 0.5  # 0.49 m measured (the whole file's DTM: 0.44 m)
    log = (tmp_path / "dtm" / "tile_513780_5403120_dtm.log").read_text()
    assert "neighbouring tiles within 30 m" in log and "ground points within 30 m of the core" in log
    assert not list(tmp_path.rglob(".aldpat-scratch-*"))
    # a tile's DTM does not depend on which other tiles were asked for in the same run
    run_dtm([project / "tiles" / "tile_513780_5403120.txt"], tmp_path / "one")
    with rasterio.open(tmp_path / "one" / "tile_513780_5403120_dtm.tif") as a, \
            rasterio.open(tmp_path / "dtm" / "tile_513780_5403120_dtm.tif") as b:
        assert a.read(1).tobytes() == b.read(1).tobytes()


def test_a_tile_without_a_node_is_a_warning_and_the_mosaic_has_the_others(project, tmp_path):
    # 60 m tiles and 90 m cells: one node in each core (x 513720, 513810 or 513900, y 5403150 or
    # 5403240), and only 513810 5403150 lies among the sample's points (x 513750..513870, y
    # 5403124..5403197)
    report = run_dtm([project / "tiles"], tmp_path / "dtm", cell=90.0, mosaic=str(tmp_path / "all.vrt"))
    warned = [w for r in report.results for w in r.warnings if "no grid written" in w]
    assert len(warned) == 5 and all("every node of its core is blank" in w for w in warned)
    assert [p.name for p in (tmp_path / "dtm").glob("*_dtm.tif")] == ["tile_513780_5403120_dtm.tif"]
    with rasterio.open(tmp_path / "all.vrt") as ds:
        assert len(ds.files) == 2 and ds.read(1, masked=True).count() == 1


def test_a_las_is_filtered_in_two_passes_with_the_in_memory_dtm(tmp_path, monkeypatch):
    # the FSite5 strip (LAZ, first and last returns, some at one position): the ground points of
    # the two streaming passes give the DTM of the points read whole, node for node
    from aldpat.tasks import dtm

    strip = Path(__file__).resolve().parents[1] / "data" / "fsite5_strip.laz"
    run_dtm([strip], tmp_path / "streamed", cell=1.0)
    assert "filtered in two passes" in (tmp_path / "streamed" / "fsite5_strip_dtm.log").read_text()
    monkeypatch.setattr(dtm, "streamable", lambda *args: False)
    run_dtm([strip], tmp_path / "whole", cell=1.0)
    assert "filtered in two passes" not in (tmp_path / "whole" / "fsite5_strip_dtm.log").read_text()
    with rasterio.open(tmp_path / "streamed" / "fsite5_strip_dtm.tif") as a, \
            rasterio.open(tmp_path / "whole" / "fsite5_strip_dtm.tif") as b:
        assert a.transform == b.transform
        np.testing.assert_array_equal(a.read(1), b.read(1))
PIT = Path(__file__).resolve().parents[1] / "data" / "fsite5_pit.laz"  # 80 m of FSite5 round a low point
PIT_XY = (493801.0, 5420487.0)  # one point there lies 106 m below the ground around it


def test_no_default_dtm_carries_a_pit_from_a_single_low_point(tmp_path):
    """In a fresh ``aldpat`` process: the default DTM of real points holding one point 106 m
    under the ground has no pit there; with the low-outlier test off (``--low-outliers none``)
    it has, 106 m deep."""
    from tests.cli.fresh import aldpat

    depths = {}
    for label, extra in (("default", []), ("off", ["--low-outliers", "none"])):
        aldpat("dtm", PIT, "--odir", tmp_path / label, *extra).ok()
        with rasterio.open(tmp_path / label / "fsite5_pit_dtm.tif") as grid:
            z = grid.read(1, masked=True)
            r, c = grid.index(*PIT_XY)
        ring = np.ma.concatenate([z[r - 3, c - 3:c + 4], z[r + 3, c - 3:c + 4], z[r - 2:r + 3, c - 3], z[r - 2:r + 3, c + 3]])
        depths[label] = float(np.ma.median(ring) - z[r - 1:r + 2, c - 1:c + 2].min())
    assert depths["default"] < 1.0, depths  # the ground's own relief over 3 m
    assert depths["off"] > 100.0, depths


def test_a_neighbouring_input_of_another_crs_is_no_buffer(tmp_path):
    """``dtm strip.laz other.laz`` took the other input's points within --buffer into the strip's
    DTM whatever its CRS: coordinates of another system, as if they were the strip's. Such a
    neighbour is left out of the buffer with a warning naming both CRSs (merge refuses them)."""
    import laspy
    import pyproj

    from tests.cli.fresh import TEST_DATA, aldpat

    strip = TEST_DATA / "fsite5_strip.laz"
    las = laspy.read(strip)
    header = laspy.LasHeader(point_format=las.header.point_format, version=las.header.version)
    header.scales, header.offsets = las.header.scales, las.header.offsets
    header.add_crs(pyproj.CRS.from_epsg(2056))
    points = las.points.copy()
    points["Z"] = points["Z"] + round(50 / las.header.scales[2])  # were it taken, the strip's edges would rise
    other = laspy.LasData(header, points)
    other.write(tmp_path / "swiss.laz")
    done = aldpat("dtm", strip, tmp_path / "swiss.laz", "--cell", "5", "--odir", tmp_path / "both", cwd=tmp_path).ok()
    assert ("fsite5_strip.laz: the buffer leaves out the neighbouring input swiss.laz, whose CRS (EPSG:2056) is not "
            "this input's (EPSG:32632)") in done.stderr
    aldpat("dtm", strip, "--cell", "5", "--odir", tmp_path / "alone", cwd=tmp_path).ok()
    with rasterio.open(tmp_path / "both" / "fsite5_strip_dtm.tif") as a, \
            rasterio.open(tmp_path / "alone" / "fsite5_strip_dtm.tif") as b:
        np.testing.assert_array_equal(a.read(1), b.read(1))


def test_a_mosaic_of_grids_of_two_crss_is_not_written(tmp_path):
    """``dtm utm.laz swiss.laz --mosaic m.vrt`` wrote a VRT holding both DTMs under the first one's
    CRS, the second drawn where it is not (gdalbuildvrt leaves such a grid out). As for a grid
    that failed, the mosaic is not written: one line naming both grids and their CRSs."""
    import laspy
    import pyproj

    from tests.cli.fresh import TEST_DATA, aldpat

    las = laspy.read(TEST_DATA / "fsite5_strip.laz")
    header = laspy.LasHeader(point_format=las.header.point_format, version=las.header.version)
    header.scales, header.offsets = las.header.scales, las.header.offsets
    header.add_crs(pyproj.CRS.from_epsg(2056))
    laspy.LasData(header, las.points.copy()).write(tmp_path / "swiss.laz")
    done = aldpat("dtm", TEST_DATA / "fsite5_strip.laz", tmp_path / "swiss.laz", "--cell", "10", "--odir",
                  tmp_path / "dtm", "--mosaic", tmp_path / "dtm" / "m.vrt", cwd=tmp_path)
    assert done.returncode == 1
    assert ("m.vrt: mosaic not written: swiss_dtm.tif is in EPSG:2056, fsite5_strip_dtm.tif in EPSG:32632; a mosaic "
            "holds grids of one CRS") in done.stderr, done.stderr
    assert not (tmp_path / "dtm" / "m.vrt").exists() and (tmp_path / "dtm" / "swiss_dtm.tif").exists()
