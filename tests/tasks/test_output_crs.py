"""Every command that can turn text into LAS/LAZ, GeoTIFF, a shapefile or an ArcGIS grid takes
``--crs``; an output that could carry a CRS and will not says so in one warning line; ``--crs``
on a LAS input naming another CRS replaces it with a warning; an ALTM tape written to LAS gives
first returns 1 of 2 and last returns 2 of 2. Each command runs in a fresh ``aldpat`` process and
its outputs are opened with laspy, rasterio and pyshp."""

from __future__ import annotations

from pathlib import Path

import laspy
import numpy as np
import pyproj
import pytest
import shapefile

from tests.cli.fresh import TEST_DATA, aldpat

WITHOUT = "written without a CRS"
SLICE = TEST_DATA / "csite1_slice.laz"  # CSite1, EPSG:32632 in its header


def points_text(path: Path, n: int = 400) -> Path:
    """``n`` points ``x y z intensity`` scattered over a 40 m square of UTM 17N."""
    rng = np.random.default_rng(6)
    x = 500000 + rng.uniform(0, 40, n)
    y = 4000000 + rng.uniform(0, 40, n)
    z = 100 + 0.1 * (x - 500000) + rng.uniform(0, 0.2, n)
    np.savetxt(path, np.column_stack([x, y, z, rng.integers(1, 200, n)]), fmt="%.2f %.2f %.2f %d")
    return path


def tape_text(path: Path, n: int = 200) -> Path:
    """An ALTM 9-column tape ``t x2 y2 z2 i2 x1 y1 z1 i1`` (the manual's order): last returns 8 m
    under the first on even pulses, 1 m under on odd ones (within the 5 m stop gap)."""
    rng = np.random.default_rng(9)
    t = 1000 + 0.01 * np.arange(n)
    x1, y1 = 500000 + rng.uniform(0, 40, n), 4000000 + rng.uniform(0, 40, n)
    z1 = 120 + rng.uniform(0, 5, n)
    z2 = z1 - np.where(np.arange(n) % 2 == 0, 8.0, 1.0)
    rows = np.column_stack([t, x1 + 0.2, y1 + 0.2, z2, np.full(n, 20), x1, y1, z1, np.full(n, 30)])
    np.savetxt(path, rows, fmt="%.2f %.2f %.2f %.2f %d %.2f %.2f %.2f %d")
    return path


def las_epsg(path: Path) -> int | None:
    crs = laspy.read(path).header.parse_crs()
    return None if crs is None else crs.to_epsg()


def test_an_altm_tape_to_las_gives_first_1_of_2_and_last_2_of_2(tmp_path):
    tape = tape_text(tmp_path / "strip.txt")
    done = aldpat("separate-returns", tape, "--out-format", "laz", "--utm-zone", "none", "--crs", "17N").ok()
    assert WITHOUT not in done.stderr
    first, last = laspy.read(tmp_path / "strip_1.laz"), laspy.read(tmp_path / "strip_2.laz")
    for las, number in ((first, 1), (last, 2)):
        assert len(las.points) == 200
        assert set(np.asarray(las.return_number).tolist()) == {number}
        assert set(np.asarray(las.number_of_returns).tolist()) == {2}
        counts = list(las.header.number_of_points_by_return[:2])
        assert counts == ([200, 0] if number == 1 else [0, 200])
        assert las.header.parse_crs().to_epsg() == 32617
        assert las.header.generating_software.startswith("aldpat ")
    # the last return of an odd pulse (1 m gap) is replaced by the first, as the manual's stop gap says
    assert np.allclose(last.z[1::2], first.z[1::2]) and np.allclose(last.z[::2], first.z[::2] - 8.0)


def test_convert_of_an_altm_tape_writes_both_returns_of_each_pulse(tmp_path):
    tape = tape_text(tmp_path / "strip.txt")
    with open(tape, "a") as fh:  # a single return: the tape records it as first and last alike
        fh.write("1002.00 500010.00 4000010.00 110.00 25 500010.00 4000010.00 110.00 25\n")
    aldpat("convert", tape, "--tape", "--out-format", "las", "--crs", "17N").ok()
    las = laspy.read(tmp_path / "strip.las")
    assert len(las.points) == 2 * 200 + 1
    pairs = np.column_stack([las.return_number, las.number_of_returns])
    assert (pairs[:400:2] == [1, 2]).all() and (pairs[1:400:2] == [2, 2]).all() and (pairs[400] == [1, 1]).all()
    assert list(las.header.number_of_points_by_return[:3]) == [201, 200, 0]
    rows = np.loadtxt(tape)
    assert np.allclose(las.z[:400:2], rows[:200, 7]) and np.allclose(las.z[1:400:2], rows[:200, 3])  # z1, z2
    assert np.allclose(las.gps_time[:400:2], rows[:200, 0]) and np.array_equal(las.intensity[:2], [30, 20])
    assert las.header.parse_crs().to_epsg() == 32617
    # a tape to text is separate-returns' job
    refused = aldpat("convert", tape, "--tape", "--odir", tmp_path / "t")
    assert refused.returncode == 2 and "separate-returns" in refused.stderr


def test_an_altm_tape_to_text_keeps_the_manuals_columns_and_no_warning(tmp_path):
    tape = tape_text(tmp_path / "strip.txt")
    done = aldpat("separate-returns", tape, "--utm-zone", "none").ok()
    assert WITHOUT not in done.stderr
    assert len((tmp_path / "strip_1.txt").read_text().split("\n")[0].split()) == 4  # x y z i


# command, its extra arguments, the output it writes from points.txt (or from tape.txt)
TEXT_TO_LAS = [
    ("convert", (), "points.laz"),
    ("convert", ("--tape",), "tape.laz"),
    ("thin", ("--cell", "5"), "points_thin.laz"),
    ("polygon-extract", ("--polygon", "POLYGON"), "points_poly.laz"),
    ("strip-boundary", (), "points_Bound.laz"),
    ("merge", ("--output", "ODIR/merged.laz"), "merged.laz"),
    ("tile", ("--width", "20", "--height", "20", "--buffer", "0"), "tile_500000_4000000.laz"),
    ("separate-returns", ("--utm-zone", "none"), "tape_1.laz"),
]


@pytest.mark.parametrize(("command", "extra", "output"), TEXT_TO_LAS, ids=[" ".join((c[0], *c[1][:1])) for c in TEXT_TO_LAS])
def test_every_text_to_las_command_takes_crs_or_says_it_has_none(tmp_path, command, extra, output):
    tape = output.startswith("tape")
    source = tape_text(tmp_path / "tape.txt") if tape else points_text(tmp_path / "points.txt")
    polygon = tmp_path / "polygon.txt"
    polygon.write_text("500005,4000005\n500035,4000005\n500035,4000035\n500005,4000035\n")

    def args(odir: Path) -> list[str]:
        return [str(polygon) if a == "POLYGON" else a.replace("ODIR", str(odir)) for a in extra]

    from tests.cli.fresh import aldpat_batch

    with_crs, without = aldpat_batch([  # both in one fresh process
        {"args": [command, source, *args(tmp_path / "a"), "--out-format", "laz", "--crs", "EPSG:32617", "--odir",
                  tmp_path / "a"], "cwd": tmp_path},
        {"args": [command, source, *args(tmp_path / "b"), "--out-format", "laz", "--odir", tmp_path / "b"],
         "cwd": tmp_path}])
    for done in (with_crs, without):
        assert done["status"] == 0 and "Traceback" not in done["stderr"], done
    assert WITHOUT not in with_crs["stderr"]
    assert las_epsg(tmp_path / "a" / output) == 32617
    assert without["stderr"].count(WITHOUT) == 1, without["stderr"]
    assert las_epsg(tmp_path / "b" / output) is None


def test_text_outputs_carry_no_crs_and_say_nothing(tmp_path):
    source = points_text(tmp_path / "points.txt")
    done = aldpat("thin", source, "--cell", "5").ok()
    assert "CRS" not in done.stderr


def test_grid_of_text_to_geotiff_takes_crs_or_says_it_has_none(tmp_path):
    """In one fresh process: a GeoTIFF takes --crs or says it has none, a Surfer grid carries none
    and says nothing, an ArcGIS grid without .prj says so and one with --crs gets its .prj."""
    rasterio = pytest.importorskip("rasterio")
    from tests.cli.fresh import aldpat_batch

    source = points_text(tmp_path / "points.txt")
    grd = tmp_path / "c" / "points_linear.grd"
    commands = (["grid", source, "--cell", "5", "--grid-format", "geotiff", "--crs", "17N", "--odir", tmp_path / "a"],
                ["grid", source, "--cell", "5", "--grid-format", "geotiff", "--odir", tmp_path / "b"],
                ["grid", source, "--cell", "5", "--odir", tmp_path / "c"],  # Surfer grids carry none
                ["grd2bin", grd, "--odir", tmp_path / "d"],  # an ArcGIS grid without .prj says so
                ["grd2bin", grd, "--crs", "17N", "--odir", tmp_path / "e"])
    runs = aldpat_batch([{"args": args, "cwd": tmp_path} for args in commands])
    for done in runs:
        assert done["status"] == 0 and "Traceback" not in done["stderr"], done
    _, without, surfer, flt, _ = runs
    (tif,) = (tmp_path / "a").glob("*.tif")
    with rasterio.open(tif) as ds:
        assert ds.crs.to_epsg() == 32617
    assert without["stderr"].count(WITHOUT) == 1
    assert WITHOUT not in surfer["stderr"] and grd.exists()
    assert flt["stderr"].count(WITHOUT) == 1 and not list((tmp_path / "d").glob("*.prj"))
    assert pyproj.CRS.from_wkt(next((tmp_path / "e").glob("*.prj")).read_text()).to_epsg() == 32617


def test_a_shapefile_without_prj_says_so(tmp_path):
    merged = tmp_path / "merged.txt"
    ring = "500000 4000000 1 1 a.txt\n500040 4000000 1 1 a.txt\n500040 4000040 1 1 a.txt\n500000 4000000 1 1 a.txt\n"
    merged.write_text(ring)
    with_crs = aldpat("shapefile", merged, "--crs", "17N", "--output", tmp_path / "a.shp").ok()
    assert WITHOUT not in with_crs.stderr
    assert pyproj.CRS.from_wkt((tmp_path / "a.prj").read_text()).to_epsg() == 32617
    without = aldpat("shapefile", merged, "--output", tmp_path / "b.shp").ok()
    assert without.stderr.count(WITHOUT) == 1
    assert not (tmp_path / "b.prj").exists()
    with shapefile.Reader(str(tmp_path / "b.shp")) as shp:
        assert len(shp.shapes()) == 1


def test_crs_on_a_las_input_replaces_its_own_with_a_warning(tmp_path):
    kept = aldpat("thin", SLICE, "--cell", "10", "--odir", tmp_path / "kept").ok()
    assert "CRS" not in kept.stderr
    assert las_epsg(tmp_path / "kept" / "csite1_slice_thin.laz") == 32632
    same = aldpat("thin", SLICE, "--cell", "10", "--crs", "32632", "--odir", tmp_path / "same").ok()
    assert "CRS" not in same.stderr
    other = aldpat("thin", SLICE, "--cell", "10", "--crs", "EPSG:25832", "--odir", tmp_path / "other").ok()
    assert other.stderr.count("replaces the input's CRS EPSG:32632") == 1, other.stderr
    out = tmp_path / "other" / "csite1_slice_thin.laz"
    assert las_epsg(out) == 25832
    assert np.allclose(laspy.read(out).x, laspy.read(tmp_path / "kept" / "csite1_slice_thin.laz").x)  # not moved


def test_crs_on_a_las_12_input_that_geotiff_keys_cannot_hold_makes_it_las_14(tmp_path):
    compound = aldpat("thin", SLICE, "--cell", "10", "--crs", "EPSG:32632+5783", "--odir", tmp_path).ok()
    assert compound.stderr.count("replaces the input's CRS") == 1
    header = laspy.read(tmp_path / "csite1_slice_thin.laz").header
    assert (header.version.major, header.version.minor) == (1, 4)
    assert header.point_format.id >= 6 and header.global_encoding.wkt  # WKT: LAS 1.4 formats 6-10
    assert header.parse_crs().equals(pyproj.CRS("EPSG:32632+5783"))


def test_dtm_of_a_las_with_another_crs_writes_it_and_says_so(tmp_path):
    rasterio = pytest.importorskip("rasterio")
    done = aldpat("dtm", SLICE, "--cell", "5", "--crs", "EPSG:25832", "--odir", tmp_path).ok()
    assert done.stderr.count("replaces the input's CRS EPSG:32632") == 1
    with rasterio.open(tmp_path / "csite1_slice_dtm.tif") as ds:
        assert ds.crs.to_epsg() == 25832


def test_a_cell_in_metres_over_coordinates_in_degrees_is_said(tmp_path):
    """``--cell`` is in metres everywhere; over points in degrees (EPSG:4326) a cell of 1 made 1-degree
    cells, a grid of 2 x 2 nodes over points 0.02 degrees apart, without a word. In one fresh
    process, grid, dtm, a filter, thin and strip-boundary say so, and tile of its --width."""
    import numpy as np

    from tests.cli.fresh import aldpat, aldpat_batch

    rng = np.random.default_rng(2)
    lon, lat = -80 + rng.uniform(0, 0.02, 300), 40 + rng.uniform(0, 0.02, 300)
    np.savetxt(tmp_path / "deg.txt", np.column_stack([lon, lat, rng.uniform(100, 101, 300)]), fmt="%.8f")
    line = "deg.txt: the coordinates are in degrees (EPSG:4326): --cell 1 is 1 degrees (about 111 km), not metres"
    commands = (["grid", "--method", "nearest"], ["dtm"], ["filter", "pm"], ["thin"], ["strip-boundary"])
    done = aldpat_batch([{"args": [*command, "deg.txt", "--cell", "1", "--crs", "EPSG:4326", "--odir", command[0]],
                          "cwd": tmp_path} for command in commands]
                        + [{"args": ["tile", "deg.txt", "--width", "500", "--crs", "EPSG:4326", "--odir", "tile"],
                            "cwd": tmp_path}])
    for command, case in zip(commands, done, strict=False):
        assert line in case["stderr"], (command, case["stderr"])
    assert line.replace("--cell 1 is 1 degrees (about 111", "--width 500 is 500 degrees (about 5.57e+04") \
        in done[-1]["stderr"], done[-1]["stderr"]
    assert "degrees" not in aldpat("grid", "deg.txt", "--cell", "1", "--odir", "none", cwd=tmp_path).stderr  # no CRS
