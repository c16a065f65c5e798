"""``aldpat grid``: tile grids share their last/first row and column (manual task 9, Fig. 7), bit
for bit; GDAL finds every input point at the centre of its node, every Surfer format, names that
say the method, CLI errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rasterio  # test-only dependency: GDAL as the real client

from aldpat.io.surfer import FORMATS, read_surfer
from aldpat.tasks import get_task

DRIVERS = {"surfer7": "GS7BG", "surfer6": "GSBG", "surfer6-ascii": "GSAG"}


def terrain(x, y):
    return 100.0 + 0.05 * (x - 500000) + 3.0 * np.sin((y - 4000000) / 6.0)


def write_points(path, x, y, z, fmt="%.3f"):
    np.savetxt(path, np.column_stack([x, y, z]), fmt=fmt)
    return path


def make_tiles(tmp_path, width=40.0, buffer=5.0, n=9000):
    """Two tiles side by side (x 500000..500040..500080), each with its buffer points."""
    rng = np.random.default_rng(7)
    x = rng.uniform(500000 - buffer, 500000 + 2 * width + buffer, n)
    y = rng.uniform(4000000 - buffer, 4000000 + width + buffer, n)
    z = terrain(x, y)
    rows = []
    for k in range(2):
        lo, hi = 500000 + k * width, 500000 + (k + 1) * width
        keep = (x >= lo - buffer) & (x <= hi + buffer)
        name = f"tile_{lo:.0f}_4000000.txt"
        write_points(tmp_path / name, x[keep], y[keep], z[keep])
        rows.append(f"{tmp_path / name} {lo:.0f} {hi:.0f} 4000000 {4000000 + width:.0f} {width:.0f} {width:.0f} "
                    f"{buffer:.0f}")
    (tmp_path / "tile_parameter.txt").write_text("\n".join(rows) + "\n")
    return [tmp_path / "tile_500000_4000000.txt", tmp_path / "tile_500040_4000000.txt"]


@pytest.mark.parametrize("method", ["nearest", "linear"])
def test_adjacent_tile_grids_share_the_boundary_column(tmp_path, method):
    """Tiles cut by hand with their buffers and listed in tile_parameter.txt, as ALDPAT cut them."""
    tiles = make_tiles(tmp_path)
    report = get_task("grid")(tiles, tile_params=str(tmp_path / "tile_parameter.txt"), method=method,
                              odir=str(tmp_path / "grids"))
    assert report.exit_code == 0, report.results[0].error
    (west, ws), (east, es) = (read_surfer(tmp_path / "grids" / f"{t.stem}_{method}.grd") for t in tiles)
    assert (ws.nx, ws.ny, es.nx) == (41, 41, 41)
    assert ws.xmin == 500000 and ws.xmax == es.xmin == 500040 and es.xmax == 500080
    np.testing.assert_array_equal(west[:, -1], east[:, 0])
    # points in no tile's core (the hand-cut buffers reach beyond the project) take no part: the
    # project's outermost nodes may lie outside the points' hull
    assert not np.isnan(west[1:-1, 1:]).any() and not np.isnan(east[1:-1, :-1]).any()


def project(tmp_path) -> Path:
    """3 x 2 tiles of 20 m with a 5 m buffer, cut by 'aldpat tile' from a terrain sampled on an
    exact 1 m lattice (cocircular points everywhere: a TIN has many equally good triangulations)
    and at random, with a hole near one tile edge."""
    rng = np.random.default_rng(11)
    gx, gy = np.meshgrid(np.arange(700000.0, 700060.0, 1.0), np.arange(5000000.0, 5000040.0, 1.0))
    x = np.r_[gx.ravel(), rng.uniform(700000, 700060, 800)]
    y = np.r_[gy.ravel(), rng.uniform(5000000, 5000040, 800)]
    hole = (np.hypot(x - 700020, y - 5000010) < 3)
    x, y = x[~hole], y[~hole]
    src = write_points(tmp_path / "site.txt", x, y, np.round(terrain(x, y), 3))
    tiles = tmp_path / "tiles"
    assert get_task("tile")([src], width=20.0, height=20.0, buffer=5.0, odir=str(tiles)).exit_code == 0
    return tiles


def shared_values(grids: dict) -> tuple[int, int]:
    """(nodes held by two tiles or more, of them those whose values differ in any bit)."""
    seen: dict[tuple[int, int], list[float]] = {}
    for values, spec in grids.values():
        cols, rows = np.round(spec.x_nodes()).astype(int), np.round(spec.y_nodes()).astype(int)
        for r, yv in enumerate(rows):
            for c, xv in enumerate(cols):
                seen.setdefault((xv, yv), []).append(values[r, c])
    shared = [v for v in seen.values() if len(v) > 1]
    differ = sum(len({np.float64(a).tobytes() for a in v}) > 1 for v in shared)
    return len(shared), differ


@pytest.mark.parametrize("method", ["linear", "nearest", "idw", "mean", "kriging"])
def test_tile_grids_cover_their_cores_on_one_lattice_and_agree_bit_for_bit_on_shared_nodes(tmp_path, method):
    tiles = project(tmp_path)
    # tile_parameter.txt beside the tiles says they are tiles; the points of each tile's
    # neighbours within 4 m take part, each point once
    report = get_task("grid")([tiles], method=method, buffer=4.0, odir=str(tmp_path / "grids"))
    assert report.exit_code == 0, [r.error for r in report.results]
    grids = {p.name: read_surfer(p) for p in sorted((tmp_path / "grids").glob(f"tile_*_{method}.grd"))}
    assert len(grids) == 6
    for name, (_values, spec) in grids.items():
        x0, y0 = (float(v) for v in name.split("_")[1:3])
        assert (spec.xmin, spec.ymin, spec.xmax, spec.ymax, spec.nx) == (x0, y0, x0 + 20, y0 + 20, 21)
    shared, differ = shared_values(grids)
    assert (shared, differ) == (2 * 41 + 61 - 2, 0)  # the edges x = 20, x = 40 and y = 20
    log = (tmp_path / "grids" / "tile_700020_5000000_linear.log").read_text() if method == "linear" else ""
    assert method != "linear" or "of 5 neighbouring tiles within 4 m of its core" in log


def test_tile_grids_match_the_grid_of_the_whole_site(tmp_path):
    tiles = project(tmp_path)
    assert get_task("grid")([tiles], odir=str(tmp_path / "grids"), mosaic=str(tmp_path / "all.vrt"),
                            grid_format="geotiff").exit_code == 0
    assert get_task("grid")([tmp_path / "site.txt"], odir=str(tmp_path / "whole"), grid_format="geotiff",
                            bounds=(700000, 5000000, 700060, 5000040)).exit_code == 0
    with rasterio.open(tmp_path / "all.vrt") as a, rasterio.open(tmp_path / "whole" / "site_linear.tif") as b:
        assert (a.bounds, a.shape) == (b.bounds, b.shape)
        tiled, whole = (ds.read(1, masked=True).filled(np.nan) for ds in (a, b))
    both = np.isfinite(tiled) & np.isfinite(whole)
    assert both.mean() > 0.95 and np.array_equal(np.isfinite(tiled), np.isfinite(whole))
    # the same points, each once; nodes on the 1 m lattice of points agree, and in the hole, where
    # cocircular points leave a TIN free to choose its triangles, by the terrain's curvature
    diff = np.abs(tiled[both] - whole[both])
    assert (diff < 1e-3).mean() > 0.99 and diff.max() < 0.5


def test_output_names_say_the_method(tmp_path):
    src = write_points(tmp_path / "p.txt", [10.2, 10.4, 13.9, 25.0], [20.1, 19.8, 22.0, 25.0], [1.0, 3.0, 7.0, 9.0])
    for method in ("mean", "max"):
        assert get_task("grid")([src], cell=2.0, method=method, odir=str(tmp_path)).exit_code == 0
    assert sorted(p.name for p in tmp_path.glob("*.grd")) == ["p_max.grd", "p_mean.grd"]
    assert read_surfer(tmp_path / "p_max.grd")[0][1, 0] == 3.0 and read_surfer(tmp_path / "p_mean.grd")[0][1, 0] == 2.0


@pytest.mark.parametrize("fmt", FORMATS)
def test_gdal_finds_each_input_point_at_its_node(tmp_path, fmt):
    # points exactly on the nodes of a 2 m lattice (one missing): every method must give them back
    gx, gy = np.meshgrid(np.arange(300000.0, 300021.0, 2.0), np.arange(4500000.0, 4500015.0, 2.0))
    x, y = gx.ravel(), gy.ravel()
    z = terrain(x, y)
    keep = np.ones(len(x), bool)
    keep[17] = False
    src = write_points(tmp_path / "pts.txt", x[keep], y[keep], z[keep])
    report = get_task("grid")([src], cell=2.0, method="min", grid_format=fmt, odir=str(tmp_path))
    assert report.exit_code == 0, report.results[0].error
    with rasterio.open(tmp_path / "pts_min.grd") as ds:
        assert ds.driver == DRIVERS[fmt]
        assert (ds.width, ds.height) == (11, 8)
        band = ds.read(1, masked=True)
        for px, py, pz in zip(x[keep], y[keep], z[keep], strict=False):
            row, col = ds.index(px, py)
            assert ds.xy(row, col) == pytest.approx((px, py))
            assert band[row, col] == pytest.approx(pz, abs=1e-3)
        row, col = ds.index(x[17], y[17])
        assert band.mask[row, col]  # the node without a point is blank
    assert "blank" in " ".join(report.results[0].warnings)


def test_bounds_binning_streams_and_data_extent_snaps(tmp_path):
    src = write_points(tmp_path / "p.txt", [10.2, 10.4, 13.9, 25.0], [20.1, 19.8, 22.0, 25.0], [1.0, 3.0, 7.0, 9.0])
    report = get_task("grid")([src], cell=2.0, method="mean", bounds=(10.0, 20.0, 14.0, 22.0), odir=str(tmp_path))
    assert report.exit_code == 0, report.results[0].error
    vals, spec = read_surfer(tmp_path / "p_mean.grd")
    assert (spec.xmin, spec.ymin, spec.nx, spec.ny) == (10.0, 20.0, 3, 2)
    assert vals[0, 0] == 2.0 and vals[1, 2] == 7.0 and np.isnan(vals).sum() == 4
    report = get_task("grid")([src], cell=2.0, method="nearest", odir=str(tmp_path), suffix="_data")
    vals, spec = read_surfer(tmp_path / "p_data.grd")
    assert (spec.xmin, spec.ymin, spec.xmax, spec.ymax) == (10.0, 18.0, 26.0, 26.0)


def test_kriging_and_idw_through_the_cli_with_a_log(tmp_path, runner, cli):
    rng = np.random.default_rng(3)
    x, y = rng.uniform(0, 30, (2, 1500))
    src = write_points(tmp_path / "k.txt", x, y, 5 + 0.2 * x - 0.1 * y, fmt="%.9f")
    for method, extra in (("kriging", ["--drift", "linear"]), ("idw", ["--power", "3", "--max-points", "8"])):
        res = runner.invoke(cli, ["grid", str(src), "--cell", "1", "--method", method, *extra, "--bounds", "2", "2",
                                  "28", "28", "--odir", str(tmp_path / method)])
        assert res.exit_code == 0, res.output
        vals, spec = read_surfer(tmp_path / method / f"k_{method}.grd")
        gx, gy = np.meshgrid(spec.x_nodes(), spec.y_nodes())
        tol = 1e-6 if method == "kriging" else 0.3
        np.testing.assert_allclose(vals, 5 + 0.2 * gx - 0.1 * gy, atol=tol)
        log = (tmp_path / method / f"k_{method}.log").read_text()
        assert "method" in log and method in log and f"k_{method}.grd" in log


def test_errors_name_the_file(tmp_path, runner, cli):
    tiles = make_tiles(tmp_path)
    other = write_points(tmp_path / "elsewhere.txt", [1.0, 2.0, 3.0], [1.0, 2.0, 1.0], [1.0, 1.0, 1.0])
    res = runner.invoke(cli, ["grid", str(tiles[0]), str(other), "--tile-params", str(tmp_path / "tile_parameter.txt"),
                              "--odir", str(tmp_path / "out")])
    assert res.exit_code == 1
    assert "elsewhere.txt" in res.output and "Traceback" not in res.output
    assert (tmp_path / "out" / "tile_500000_4000000_linear.grd").exists()
    assert not (tmp_path / "out" / "elsewhere_linear.grd").exists()
    res = runner.invoke(cli, ["grid", str(tiles[0]), "--tile-params", str(tmp_path / "tile_parameter.txt"),
                              "--bounds", "0", "0", "1", "1", "--odir", str(tmp_path / "out2")])
    assert res.exit_code != 0 and "not both" in res.output
    res = runner.invoke(cli, ["grid", str(other), "--bounds", "100", "100", "110", "110", "--method", "nearest",
                              "--max-distance", "2", "--odir", str(tmp_path / "out3")])
    assert res.exit_code == 1 and "is blank: no node lies where its" in res.output and "--max-distance" in res.output


def test_tiles_of_a_real_sample_grid_seamlessly(tmp_path, samp24):
    """ISPRS sample 24 cut by 'aldpat tile' into two tiles; the pattern would match
    tile_parameter.txt, which is no input."""
    tiles = tmp_path / "tiles"
    report = get_task("tile")([samp24], width=60.0, height=80.0, buffer=5.0, origin=(513750.0, 5403120.0),
                              bounds=(513750.0, 5403120.0, 513870.0, 5403200.0), odir=str(tiles))
    assert report.exit_code == 0, report.results[0].error
    report = get_task("grid")([str(tiles / "tile_*.txt")], tile_params=str(tiles / "tile_parameter.txt"),
                              odir=str(tmp_path / "grids"))
    assert report.exit_code == 0, [r.error for r in report.results]
    assert len(report.results) == 2
    west, ws = read_surfer(tmp_path / "grids" / "tile_513750_5403120_linear.grd")
    east, es = read_surfer(tmp_path / "grids" / "tile_513810_5403120_linear.grd")
    assert ws.xmax == es.xmin == 513810.0 and (ws.ny, es.ny) == (81, 81)
    assert np.isfinite(west[:, -1]).sum() >= 70
    # one column, blank at the same nodes, the same values to the last bit
    np.testing.assert_array_equal(west[:, -1], east[:, 0])
    assert sorted(p.name for p in (tmp_path / "grids").glob("*.grd")) == [
        "tile_513750_5403120_linear.grd", "tile_513810_5403120_linear.grd"]


def test_a_cog_of_a_las_strip_carries_the_strips_crs_unless_crs_is_given(tmp_path):
    strip = Path(__file__).resolve().parents[1] / "data" / "fsite5_strip.laz"  # EPSG:32632
    assert get_task("grid")([strip], cell=2.0, grid_format="cog", odir=str(tmp_path / "a")).exit_code == 0
    with rasterio.open(tmp_path / "a" / "fsite5_strip_linear.tif") as ds:
        assert ds.crs.to_epsg() == 32632 and ds.tags(ns="IMAGE_STRUCTURE")["LAYOUT"] == "COG"
        band = ds.read(1, masked=True)
        assert band.count() > 0.5 * band.size and ds.res == (2.0, 2.0)
    assert get_task("grid")([strip], cell=2.0, grid_format="geotiff", crs="EPSG:25832",
                            odir=str(tmp_path / "b")).exit_code == 0
    with rasterio.open(tmp_path / "b" / "fsite5_strip_linear.tif") as ds:
        assert ds.crs.to_epsg() == 25832


@pytest.mark.parametrize("grid_format", ["surfer7", "geotiff"])
def test_a_mosaic_opens_the_tile_grids_as_one_raster(tmp_path, samp24, grid_format):
    """Two tiles of sample 24 gridded with --mosaic: GDAL reads the VRT as one raster whose every
    node holds the value of the tile grid that covers it, the shared column included."""
    tiles = tmp_path / "tiles"
    get_task("tile")([samp24], width=60.0, height=80.0, buffer=5.0, origin=(513750.0, 5403120.0),
                     bounds=(513750.0, 5403120.0, 513870.0, 5403200.0), odir=str(tiles))
    report = get_task("grid")([str(tiles / "tile_*.txt")], tile_params=str(tiles / "tile_parameter.txt"),
                              grid_format=grid_format, crs="EPSG:32632", mosaic=str(tmp_path / "g" / "dtm.vrt"),
                              odir=str(tmp_path / "g"))
    assert report.exit_code == 0, [r.error for r in report.results]
    ext = ".tif" if grid_format == "geotiff" else ".grd"
    with rasterio.open(tmp_path / "g" / "dtm.vrt") as vrt:
        assert (vrt.width, vrt.height) == (121, 81) and vrt.crs.to_epsg() == 32632
        mosaic = vrt.read(1, masked=True)
        covered = np.zeros(mosaic.shape, bool)
        for name in ("tile_513750_5403120_linear", "tile_513810_5403120_linear"):
            with rasterio.open(tmp_path / "g" / f"{name}{ext}") as tile:
                part = tile.read(1, masked=True)
                row, col = vrt.index(*tile.xy(0, 0))
                window = mosaic[row:row + tile.height, col:col + tile.width]
                assert window.shape == part.shape
                valid = ~part.mask
                np.testing.assert_allclose(window[valid], part[valid], atol=1e-4)
                covered[row:row + tile.height, col:col + tile.width] |= valid
        # a node is blank in the mosaic exactly where no tile has a value (a blank node of one
        # tile does not cover its neighbour's value on the shared column)
        assert np.array_equal(~mosaic.mask, covered) and covered.sum() > 8000
    assert (tmp_path / "g" / "dtm.vrt").read_text().count("<ComplexSource>") == 2
    # the mosaic previews as one picture, one pixel per node, transparent where it is blank
    assert get_task("preview")([tmp_path / "g" / "dtm.vrt"]).exit_code == 0
    from PIL import Image

    shade = np.asarray(Image.open(tmp_path / "g" / "dtm_hillshade.png"))
    assert shade.shape == (81, 121, 4) and np.array_equal(shade[..., 3] == 255, covered)


@pytest.mark.parametrize("method", ["linear", "nearest", "idw", "kriging"])
def test_chunked_grid_agrees_with_the_whole(tmp_path, method):
    """``--chunk 20``: 24 squares of nodes, each from its points and a 10 m buffer (the default
    for these methods), written into one grid with the whole run's nodes."""
    sample = Path(__file__).resolve().parents[2] / "jobs" / "data" / "samp24.txt"
    for odir, options in (("whole", {}), ("chunks", {"chunk": 20.0, "jobs": 2})):
        report = get_task("grid")([sample], cell=1.0, method=method, odir=str(tmp_path / odir), **options)
        assert report.exit_code == 0, [r.error for r in report.results]
    with rasterio.open(tmp_path / "whole" / f"samp24_{method}.grd") as a, \
            rasterio.open(tmp_path / "chunks" / f"samp24_{method}.grd") as b:
        assert (a.bounds, a.shape) == (b.bounds, b.shape)
        whole, chunks = (ds.read(1, masked=True).filled(np.nan) for ds in (a, b))
    same = np.isclose(whole, chunks, atol=1e-3) | (np.isnan(whole) & np.isnan(chunks))
    # measured: idw and kriging 100 %, linear and nearest 99.95 % (5 nodes at the data's edge,
    # whose nearest points lie farther than the buffer)
    assert same.mean() >= 0.999
    assert "chunks of 20 m" in (tmp_path / "chunks" / f"samp24_{method}.log").read_text()
    assert not list(tmp_path.rglob(".aldpat-scratch-*"))


def test_chunks_take_a_buffer_of_point_spacings_not_only_of_cells(tmp_path):
    """``--chunk``'s auto buffer was ten cells: at 0.05 m cells over points a metre apart each
    chunk saw too few points, and half the nodes of a plane came out blank (52.2 % against 3.3 %).
    It reaches 16 mean point spacings now; the chunked grid holds the whole grid's nodes."""
    rng = np.random.default_rng(1)
    x, y = rng.uniform(0, 20, 300), rng.uniform(0, 20, 300)
    source = write_points(tmp_path / "plane.txt", x, y, 2 * x + 3 * y + 1, fmt="%.6f")
    grids = []
    for odir, options in (("whole", {}), ("chunks", {"chunk": 2.0})):
        report = get_task("grid")([source], cell=0.05, method="linear", grid_format="geotiff",
                                  odir=str(tmp_path / odir), **options)
        assert report.exit_code == 0, [r.error for r in report.results]
        with rasterio.open(tmp_path / odir / "plane_linear.tif") as ds:
            grids.append(ds.read(1, masked=True).filled(np.nan))
    whole, chunks = grids
    both = np.isfinite(whole) & np.isfinite(chunks)
    assert np.abs(whole[both] - chunks[both]).max() < 1e-4
    assert np.isnan(chunks).mean() - np.isnan(whole).mean() < 0.01  # measured: 3.37 % against 3.31 %


def test_chunks_of_a_classified_las_grid_its_ground_on_the_whole_grids_nodes(tmp_path):
    """A classified LAS grids its ground (class 2). With ``--chunk`` the grid's extent came from the
    header (every point's, one node wider where objects reach past the ground) and the buffer from
    the count of every point (too small for the sparser ground); both come from the ground now, so
    the chunked grid has the whole grid's nodes, and its log says the ground's count."""
    import laspy

    rng = np.random.default_rng(4)
    x, y = rng.uniform(0, 60, 4000), rng.uniform(0, 60, 4000)
    las = laspy.LasData(laspy.LasHeader(point_format=1, version="1.2"))
    las.header.scales, las.header.offsets = np.array([0.001] * 3), np.zeros(3)
    las.x, las.y, las.z = x, y, 0.2 * x + 0.1 * y + 50
    las.classification = np.where((x > 1.5) & (y > 1.5) & (rng.random(4000) < 0.25), 2, 1).astype(np.uint8)
    las.write(tmp_path / "site.las")
    grids = []
    for odir, options in (("whole", {}), ("chunks", {"chunk": 15.0})):
        report = get_task("grid")([tmp_path / "site.las"], cell=1.0, grid_format="geotiff", odir=str(tmp_path / odir),
                                  **options)
        assert report.exit_code == 0, [r.error for r in report.results]
        with rasterio.open(tmp_path / odir / "site_linear.tif") as ds:
            grids.append((ds.bounds, ds.read(1, masked=True).filled(np.nan)))
    (whole_bounds, whole), (chunk_bounds, chunks) = grids
    assert whole_bounds == chunk_bounds and whole_bounds.left == 0.5  # the ground's extent: from node 1
    assert np.array_equal(np.isnan(whole), np.isnan(chunks))
    assert np.nanmax(np.abs(whole - chunks)) < 1e-4
    ground = int((las.classification == 2).sum())
    assert f"buffers, {ground} points" in (tmp_path / "chunks" / "site_linear.log").read_text()


def test_a_surfer7_node_holding_the_nodata_value_is_refused_as_in_a_geotiff(tmp_path):
    """``--nodata 5`` and a node whose mean is 5: the GeoTIFF was refused, the Surfer 7 grid written,
    and GDAL and grd2bin then read that node as blank. Both refuse it now, in fresh processes."""
    from tests.cli.fresh import aldpat

    (tmp_path / "bin.txt").write_text("0.2 0.2 10\n0.4 0.1 20\n0.9 0.3 30\n1.2 1.1 5\n2.0 2.0 7\n")
    for fmt in ("surfer7", "geotiff"):
        done = aldpat("grid", "bin.txt", "--cell", "1", "--method", "mean", "--nodata", "5", "--grid-format", fmt,
                      "--odir", fmt, cwd=tmp_path)
        assert done.returncode == 1 and "a node holds the nodata value 5 itself" in done.stderr, done.stderr
        assert not any(p.suffix in (".grd", ".tif") for p in (tmp_path / fmt).glob("*"))
    aldpat("grid", "bin.txt", "--cell", "1", "--method", "mean", "--nodata", "-9999", "--odir", "ok", cwd=tmp_path).ok()


def test_a_cell_wider_than_the_points_says_so(tmp_path):
    """``--cell 100`` over 20 m of points: the one node lies outside the points' triangles, and the
    refusal said "none of the 300 points lies near the grid range" of points all inside it."""
    from tests.cli.fresh import aldpat

    rng = np.random.default_rng(1)
    x, y = rng.uniform(0, 20, 300), rng.uniform(0, 20, 300)
    write_points(tmp_path / "plane.txt", x, y, 2 * x + 3 * y + 1, fmt="%.6f")
    done = aldpat("grid", "plane.txt", "--cell", "100", "--method", "linear", cwd=tmp_path)
    assert done.returncode == 1
    assert "inside their triangles; with cells wider than the points' extent, a smaller --cell" in done.stderr


def test_bounds_off_the_cell_lattice_are_said_once(tmp_path):
    """``--bounds`` that are not a whole number of cells were warned twice (once "of 1 m cells",
    once "of 1 cells"); once now, naming the range and where the grid ends."""
    from tests.cli.fresh import aldpat

    rng = np.random.default_rng(1)
    x, y = rng.uniform(0, 10, 200), rng.uniform(0, 10, 200)
    write_points(tmp_path / "p.txt", x, y, x + y)
    done = aldpat("grid", "p.txt", "--cell", "1", "--bounds", "0", "0", "10.5", "10", cwd=tmp_path).ok()
    said = [ln for ln in done.stderr.splitlines() if "not a whole number" in ln]
    assert said == [("aldpat: x range 0..10.5 is not a whole number of 1-unit cells; the grid is extended to 11 to "
                    "cover it")]
