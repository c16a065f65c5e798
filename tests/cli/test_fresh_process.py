"""Every command, every filter algorithm, every grid method and every output format, each in a
fresh ``aldpat`` process on small real data, and each output opened by its real client:
laspy for LAS/LAZ, GDAL (through rasterio) for grids, pyshp and GDAL/OGR (pyogrio) for
shapefiles.

The loops run over the registries, so a new task, algorithm, method or format is run here the
moment it is registered.
"""

from __future__ import annotations

import json
import shutil
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import laspy
import numpy as np
import pyproj
import pytest
import rasterio
import shapefile as pyshp

from aldpat.core.interpolate import METHODS
from aldpat.filters.registry import FILTERS
from aldpat.io.geotiff import FORMATS as GEOTIFF_FORMATS
from aldpat.io.registry import OUT_EXTENSIONS
from aldpat.io.surfer import FORMATS as SURFER_FORMATS
from aldpat.tasks import TASKS
from tests.cli.fresh import DATA, TEST_DATA, aldpat, aldpat_batch, count_points, leftovers

GDAL_DRIVERS = {"surfer7": "GS7BG", "surfer6": "GSBG", "surfer6-ascii": "GSAG", "geotiff": "GTiff", "cog": "GTiff"}
GRID_FORMATS = SURFER_FORMATS + tuple(GEOTIFF_FORMATS)
NGA_LAT, NGA_LON, NGA_N = 38.6281550, 269.7791550 - 360.0, -31.628  # EGM96 test point in egm96_15_nga1.gtx


@pytest.fixture(scope="module")
def work(tmp_path_factory) -> Path:
    """A copy of the small real samples: a tile of ISPRS sample 24, the FSite5 tape, a LAZ strip."""
    root = tmp_path_factory.mktemp("fresh")
    # a 120 m x 120 m corner of sample 24 keeps every filter and grid method fast
    rows = np.loadtxt(DATA / "samp24.txt")
    x0, y0 = rows[:, 0].min(), rows[:, 1].min()
    part = rows[(rows[:, 0] < x0 + 120) & (rows[:, 1] < y0 + 120)]
    np.savetxt(root / "samp.txt", part, fmt=["%.2f", "%.2f", "%.2f", "%d"], delimiter="\t")
    shutil.copy(DATA / "fsite5_tape.txt", root / "tape.txt")
    shutil.copy(DATA / "demo_polygon.txt", root / "polygon.txt")
    shutil.copy(TEST_DATA / "fsite5_strip.laz", root / "strip.laz")
    shutil.copy(TEST_DATA / "egm96_15_nga1.gtx", root / "geoid.gtx")
    to_utm = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32615", always_xy=True)
    e, n = to_utm.transform(NGA_LON, NGA_LAT)
    np.savetxt(root / "ellipsoidal.txt", [[e, n, 180.25, 12], [e + 20, n + 10, 181.5, 40]],
               fmt=["%.2f", "%.2f", "%.2f", "%d"])
    return root


def text_rows(path: Path) -> np.ndarray:
    return np.atleast_2d(np.loadtxt(path, delimiter="," if path.suffix == ".csv" else None))


def test_every_task_is_run_by_this_file():
    covered = {"convert", "dtm", "evaluate", "grd2bin", "grid", "info", "merge", "merge-boundary", "ortho-height",
               "polygon-extract", "preview", "separate-returns", "shapefile", "split-tape", "strip-boundary", "thin", "tile"}
    covered |= {f"filter {name}" for name in FILTERS}
    assert set(TASKS) <= covered, sorted(set(TASKS) - covered)


def test_help_of_every_command():
    # each in its own process, two at a time (the processes are independent; the machine has 2 cores)
    commands = [["--help"]] + [[*key.split(), "--help"] for key in TASKS]
    with ThreadPoolExecutor(max_workers=2) as pool:
        done = list(pool.map(lambda words: aldpat(*words), commands))
    assert len(done) == len(TASKS) + 1
    for each in done:
        assert "Usage" in each.ok().stdout, each.args


def test_info_text_and_laz(work):
    done = aldpat("info", work / "samp.txt", work / "strip.laz", "--json").ok()
    records = [json.loads(line) for line in done.stdout.splitlines() if line.strip()]
    assert [r["count"] for r in records] == [count_points(work / "samp.txt"), count_points(work / "strip.laz")]
    assert "points" in aldpat("info", work / "strip.laz").ok().stdout


@pytest.mark.parametrize("out_format", sorted(OUT_EXTENSIONS))
@pytest.mark.parametrize("source", ["samp.txt", "strip.laz"])
def test_convert_to_every_output_format(work, tmp_path, source, out_format):
    src = work / source
    aldpat("convert", src, "--out-format", out_format, "--odir", tmp_path).ok()
    out = tmp_path / (src.stem + OUT_EXTENSIONS[out_format])
    assert count_points(out) == count_points(src)
    if out_format in ("las", "laz"):
        las = laspy.read(out)
        if source == "samp.txt":
            np.testing.assert_allclose(np.c_[las.x, las.y, las.z], text_rows(src)[:, :3], atol=0.005)
        else:
            assert las.header.parse_crs() is not None  # the CRS went along
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("algorithm", sorted(FILTERS))
def test_every_filter_writes_terrain_and_classified_las(work, tmp_path, algorithm):
    src = work / "samp.txt"
    n = count_points(src)
    # the three commands in one process, the filter first (so in a fresh one): each start-up is
    # most of a second
    runs = aldpat_batch([{"args": args, "cwd": tmp_path} for args in (
        ["filter", algorithm, src, "--result", "both", "--odir", tmp_path / "t"],
        ["filter", algorithm, src, "--result", "classified", "--out-format", "laz", "--marks", "--odir", tmp_path / "c"],
        ["evaluate", tmp_path / "t" / f"samp_{algorithm}.txt", "--reference", src, "--json", "--map",
         tmp_path / "calls.png"])])
    for run in runs:
        assert run["status"] == 0 and "Traceback" not in run["stderr"], run
    ground = count_points(tmp_path / "t" / f"samp_{algorithm}.txt")
    objects = count_points(tmp_path / "t" / f"samp_{algorithm}_nt.txt")
    assert ground + objects == n and 0 < ground  # nothing dropped, nothing invented
    las = laspy.read(tmp_path / "c" / f"samp_{algorithm}.laz")
    assert len(las.points) == n
    # ASPRS low noise: the low outliers every filter sets aside (and the outlier filter's noise,
    # high noise too in point format 0)
    classes = np.asarray(las.classification)
    assert set(np.unique(classes)) <= {1, 2, 7}
    if algorithm == "outlier":  # noise only: the points it keeps are unclassified, never class 2
        assert not (classes == 2).any() and int((classes == 1).sum()) >= ground  # its terrain kept, and more
    else:
        assert int((classes == 2).sum()) == ground
        assert np.array_equal(classes == 7, np.asarray(las["mark"]) == -9000)
    assert "mark" in las.point_format.extra_dimension_names
    scores = json.loads(runs[2]["stdout"])
    assert 0 <= scores["total"] < 50  # a ground filter, not a coin
    assert scores["map"] == str(tmp_path / "calls.png") and (tmp_path / "calls.png").stat().st_size > 0
    assert leftovers(tmp_path) == []


def test_filter_keeps_las_attributes(work, tmp_path):
    src = work / "strip.laz"
    aldpat("filter", "pm", src, "--result", "classified", "--odir", tmp_path).ok()
    before, after = laspy.read(src), laspy.read(tmp_path / "strip_pm.laz")
    assert len(after.points) == len(before.points)
    for dim in before.point_format.dimension_names:
        if dim == "classification":
            continue
        np.testing.assert_array_equal(after[dim], before[dim])
    assert after.header.parse_crs() == before.header.parse_crs()


@pytest.mark.parametrize("grid_format", sorted(GRID_FORMATS))
@pytest.mark.parametrize("method", sorted(METHODS))
def test_every_grid_method_and_format_opens_in_gdal(work, tmp_path, method, grid_format):
    src = work / "samp.txt"
    aldpat("grid", src, "--cell", "4", "--method", method, "--grid-format", grid_format, "--odir", tmp_path).ok()
    rows = text_rows(src)
    name = f"samp_{method}" + (".tif" if grid_format in GEOTIFF_FORMATS else ".grd")
    with rasterio.open(tmp_path / name) as ds:
        assert ds.driver == GDAL_DRIVERS[grid_format]
        band = ds.read(1, masked=True)
        assert band.count() > 0.5 * band.size
        # nodes at whole multiples of the cell (grid alignment), inside the data's range
        x0, y0 = ds.xy(ds.height - 1, 0)
        assert x0 % 4 == pytest.approx(0, abs=1e-6) and y0 % 4 == pytest.approx(0, abs=1e-6)
        assert rows[:, 0].min() - 4 < x0 <= rows[:, 0].min() + 4
        assert float(band.min()) >= rows[:, 2].min() - 1 and float(band.max()) <= rows[:, 2].max() + 1
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("to", ["flt", "asc", "tif", "cog"])
def test_grd2bin_opens_in_gdal_at_the_same_place(work, tmp_path, to):
    aldpat("grid", work / "samp.txt", "--cell", "4", "--odir", tmp_path).ok()
    aldpat("grd2bin", tmp_path / "samp_linear.grd", "--to", to, "--crs", "EPSG:32632").ok()
    name = "samp_linear.tif" if to in ("tif", "cog") else f"samp_linear.{to}"
    with rasterio.open(tmp_path / "samp_linear.grd") as surfer, rasterio.open(tmp_path / name) as esri:
        assert esri.crs.to_epsg() == 32632
        assert (esri.width, esri.height) == (surfer.width, surfer.height)
        assert esri.xy(0, 0) == pytest.approx(surfer.xy(0, 0))
        np.testing.assert_allclose(esri.read(1, masked=True).filled(np.nan), surfer.read(1, masked=True).filled(np.nan),
                                   atol=1e-3)


def test_dtm_of_laz_tiles_is_a_cog_in_the_las_crs(work, tmp_path):
    strip = laspy.read(work / "strip.laz")
    middle = float(np.median(strip.x))
    for name, keep in (("west", strip.x < middle), ("east", strip.x >= middle)):
        part = laspy.LasData(strip.header)
        part.points = strip.points[np.asarray(keep)]
        part.write(tmp_path / f"{name}.laz")
    aldpat("dtm", tmp_path / "west.laz", tmp_path / "east.laz", "--cell", "2", "--algorithm", "gapm",
           "--odir", tmp_path / "dtm", "--mosaic", tmp_path / "dtm" / "strip.vrt").ok()
    with rasterio.open(tmp_path / "dtm" / "strip.vrt") as ds:
        assert ds.crs.to_epsg() == 32632 and ds.res == (2.0, 2.0)
        band = ds.read(1, masked=True)
        assert band.count() > 0.9 * band.size
        assert strip.z.min() - 1 < band.min() and band.max() < strip.z.max()
    with rasterio.open(tmp_path / "dtm" / "west_dtm.tif") as ds:
        assert ds.tags(ns="IMAGE_STRUCTURE").get("LAYOUT") == "COG"
    assert leftovers(tmp_path) == []


def test_preview_pictures_of_a_grid_and_of_points(work, tmp_path):
    from PIL import Image

    aldpat("grid", work / "samp.txt", "--cell", "2", "--grid-format", "cog", "--odir", tmp_path).ok()
    aldpat("preview", tmp_path / "samp_linear.tif", work / "samp.txt", "--odir", tmp_path, "--size", "300").ok()
    with Image.open(tmp_path / "samp_linear_hillshade.png") as shade, \
            rasterio.open(tmp_path / "samp_linear.tif") as grid:
        assert shade.mode == "RGBA" and shade.size == (grid.width, grid.height)
    with Image.open(tmp_path / "samp_plan.png") as plan:
        assert plan.mode == "RGBA" and max(plan.size) <= 300
        assert len(np.unique(np.asarray(plan).reshape(-1, 4), axis=0)) > 20  # elevations in many colours
    assert leftovers(tmp_path) == []


def test_preparation_chain_to_a_shapefile_and_tiles(work, tmp_path):
    aldpat("split-tape", work / "tape.txt", "--odir", tmp_path / "strips").ok()
    strips = sorted((tmp_path / "strips").glob("tape_strip*.txt"))
    assert sum(count_points(p) for p in strips) == count_points(work / "tape.txt") == 7444
    aldpat("separate-returns", *strips, "--odir", tmp_path / "returns").ok()
    firsts = sorted((tmp_path / "returns").glob("*_1.txt"))
    lasts = sorted((tmp_path / "returns").glob("*_2.txt"))
    assert [count_points(p) for p in firsts] == [count_points(p) for p in strips] == [count_points(p) for p in lasts]
    aldpat("strip-boundary", *firsts, "--cell-width", "2", "--cell-height", "2", "--odir", tmp_path / "bounds").ok()
    bounds = sorted((tmp_path / "bounds").glob("*_Bound.txt"))
    assert len(bounds) == 3
    aldpat("merge-boundary", *bounds, "--output", tmp_path / "merged.txt").ok()
    aldpat("shapefile", tmp_path / "merged.txt", "--output", tmp_path / "strips.shp", "--crs", "EPSG:32632").ok()
    with pyshp.Reader(str(tmp_path / "strips.shp")) as shp:
        assert len(shp) == 3 and shp.shapeType == pyshp.POLYGON
    pyogrio = pytest.importorskip("pyogrio")
    info = pyogrio.read_info(tmp_path / "strips.shp")
    assert info["features"] == 3 and pyproj.CRS.from_user_input(info["crs"]).to_epsg() == 32632
    aldpat("tile", *lasts, "--width", "100", "--height", "100", "--buffer", "10", "--odir", tmp_path / "tiles").ok()
    tiles = sorted((tmp_path / "tiles").glob("tile_*_*.txt"))
    assert tiles and (tmp_path / "tiles" / "tile_parameter.txt").exists()
    aldpat("thin", *tiles, "--cell-width", "5", "--cell-height", "5", "--odir", tmp_path / "thin").ok()
    assert len(list((tmp_path / "thin").glob("*_thin.txt"))) == len(tiles)
    aldpat("polygon-extract", *lasts, "--polygon", work / "polygon.txt", "--odir", tmp_path / "in").ok()
    aldpat("polygon-extract", *lasts, "--polygon", work / "polygon.txt", "--outside", "--suffix", "_out",
           "--odir", tmp_path / "out").ok()
    for last in lasts:  # inside + outside = all: nothing dropped, nothing invented
        inside = count_points(tmp_path / "in" / f"{last.stem}_poly.txt")
        outside = count_points(tmp_path / "out" / f"{last.stem}_out.txt")
        assert inside + outside == count_points(last)
    aldpat("grid", *sorted(tiles)[:2], "--cell", "2", "--tile-params", tmp_path / "tiles" / "tile_parameter.txt",
           "--odir", tmp_path / "grids").ok()
    assert len(list((tmp_path / "grids").glob("*.grd"))) == 2
    assert leftovers(tmp_path) == []


def test_ortho_height(work, tmp_path):
    aldpat("ortho-height", work / "ellipsoidal.txt", "--crs", "15N", "--geoid", work / "geoid.gtx",
           "--odir", tmp_path).ok()
    rows = text_rows(tmp_path / "ellipsoidal_Ortho.txt")
    assert rows[0, 2] == pytest.approx(180.25 - NGA_N, abs=0.1)


def test_demo_worksheet(tmp_path):
    work = tmp_path / "jobs"
    shutil.copytree(DATA, work / "data")
    shutil.copytree(DATA.parent / "params", work / "params")
    shutil.copy(DATA.parent / "demo.toml", work / "demo.toml")
    done = aldpat("run", work / "demo.toml", cwd=tmp_path).ok()
    assert "Failed" not in done.stderr and "Blocked" not in done.stderr
    assert len(list((work / "demo-out" / "grids").glob("*.flt"))) == 6
    # it ends with a COG DTM of every tile, their mosaic, its hillshade and the run report
    tiles = sorted((work / "demo-out" / "dtm").glob("tile_*_dtm.tif"))
    assert len(tiles) == 6
    with rasterio.open(tiles[0]) as ds:
        assert ds.tags(ns="IMAGE_STRUCTURE").get("LAYOUT") == "COG" and ds.crs.to_epsg() == 32632
    assert (work / "demo-out" / "dtm_hillshade.png").exists() and (work / "demo-out" / "samp24_calls.png").exists()
    page = (work / "demo.html").read_text(encoding="utf-8")
    assert page.count('<section class="job"') == (work / "demo.toml").read_text().count("[[job]]")
    jobs = page.count('<section class="job"')
    assert page.count("data:image/png;base64,") == 2 and page.count("state Done") == 2 * jobs  # summary + section
    assert leftovers(work) == []


def test_gapm_auto_records_what_it_derived(work, tmp_path):
    aldpat("filter", "gapm", work / "samp.txt", "--auto", "--odir", tmp_path).ok()
    log = (tmp_path / "samp_gapm.log").read_text()
    assert "derived from the data:" in log and "--auto: cell = 0.75 m" in log
    assert "auto" in log and count_points(tmp_path / "samp_gapm.txt") > 0


def test_worksheet_runs_the_manuals_point_filters_with_their_parameter_files(tmp_path):
    """slope, ipf, poly2 and atin as worksheet jobs with jobs/params/<algo>.toml, then evaluated."""
    work = tmp_path / "jobs"
    shutil.copytree(DATA, work / "data")
    shutil.copytree(DATA.parent / "params", work / "params")
    jobs = "".join(
        f'[[job]]\ntask = "filter"\nalgorithm = "{algo}"\ninputs = ["data/samp24.txt"]\n'
        f'odir = "out"\nparams = "params/{algo}.toml"\nresult = "classified"\nmarks = true\n\n'
        for algo in ("slope", "ipf", "poly2", "atin")
    )
    (work / "points.toml").write_text(jobs)
    done = aldpat("run", work / "points.toml", cwd=tmp_path).ok()
    assert "Failed" not in done.stderr
    n = count_points(work / "data" / "samp24.txt")
    for algo in ("slope", "ipf", "poly2", "atin"):
        out = work / "out" / f"samp24_{algo}.txt"
        assert count_points(out) == n
        table = np.loadtxt(out)
        mark, cls = table[:, -2], table[:, -1]
        assert {1.0, 2.0} <= set(np.unique(cls)) <= {1.0, 2.0, 7.0} and np.array_equal(mark == 0, cls == 2)
        assert np.array_equal(cls == 7, mark == -9000)  # low outliers: ASPRS low noise
        log = (work / "out" / f"samp24_{algo}.log").read_text()
        assert "(params file)" in log
