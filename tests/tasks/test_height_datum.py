"""``aldpat ortho-height`` records the datum of the heights it writes: a compound CRS (horizontal +
EGM96 height, or the vertical CRS of a compound ``--to-crs``) as WKT in LAS 1.4, the horizontal CRS
alone after ``--reverse``; a target it cannot honour is refused in one line. Fresh ``aldpat``
processes on the CSite1 and FSite5 slices (LAS 1.2, UTM 32N) with the EGM96 window around them."""

from __future__ import annotations

from pathlib import Path

import laspy
import numpy as np
import pyproj
import pytest

from aldpat.core.heights import HeightConverter
from tests.cli.fresh import TEST_DATA, aldpat

GEOID = TEST_DATA / "egm96_15_isprs.gtx"
CSITE1 = TEST_DATA / "csite1_slice.laz"
FSITE5 = TEST_DATA / "fsite5_pit.laz"


def undulation(las: laspy.LasData) -> np.ndarray:
    return HeightConverter("EPSG:32632", GEOID).undulation(las.x, las.y)


def parts(path: Path) -> tuple[pyproj.CRS, laspy.LasHeader]:
    header = laspy.open(path).header
    return header.parse_crs(), header


def assert_compound(crs: pyproj.CRS, horizontal: int, vertical: int) -> None:
    assert crs.is_compound, crs.name
    h, v = crs.sub_crs_list
    assert not h.is_vertical and h.to_epsg() == horizontal
    assert v.is_vertical and v.to_epsg() == vertical


def test_las12_input_becomes_las14_with_egm96_height(tmp_path):
    done = aldpat("ortho-height", CSITE1, "--geoid", GEOID, "--odir", tmp_path).ok()
    out = tmp_path / "csite1_slice_Ortho.laz"
    crs, header = parts(out)
    assert (str(header.version), header.point_format.id, header.global_encoding.wkt) == ("1.4", 6, True)
    assert_compound(crs, 32632, 5773)
    assert crs.sub_crs_list[1].name == "EGM96 height"
    src, got = laspy.read(CSITE1), laspy.read(out)
    n = undulation(src)
    assert 48.4 < n.min() and n.max() < 48.6  # EGM96 under Stuttgart
    np.testing.assert_allclose(got.z, src.z - n, atol=0.006)  # 1 cm scale: half a unit + rounding
    np.testing.assert_array_equal(got.X, src.X)
    np.testing.assert_array_equal(got.Y, src.Y)
    for dim in ("intensity", "return_number", "number_of_returns", "classification", "point_source_id",
                "withheld", "synthetic", "key_point", "user_data"):
        np.testing.assert_array_equal(got[dim], src[dim], err_msg=dim)
    assert "CRS recorded: WGS 84 / UTM zone 32N + EGM96 height" in (tmp_path / "csite1_slice_Ortho.log").read_text()
    assert done.stderr.count("\n") <= 2  # the summary line, no warnings


def test_las14_input_keeps_its_format(tmp_path):
    src = laspy.convert(laspy.read(FSITE5), point_format_id=6, file_version="1.4")
    src.header.add_crs(pyproj.CRS.from_epsg(32632))
    src.gps_time = np.arange(len(src.points), dtype=np.float64) * 0.5
    src.scan_angle = np.full(len(src.points), -1500, np.int16)  # -9 degrees
    src.write(tmp_path / "f5.las")
    aldpat("ortho-height", tmp_path / "f5.las", "--geoid", GEOID).ok()
    crs, header = parts(tmp_path / "f5_Ortho.las")
    assert (str(header.version), header.point_format.id, header.global_encoding.wkt) == ("1.4", 6, True)
    assert_compound(crs, 32632, 5773)
    got = laspy.read(tmp_path / "f5_Ortho.las")
    np.testing.assert_allclose(got.z, src.z - undulation(src), atol=0.006)
    np.testing.assert_array_equal(got.gps_time, src.gps_time)
    np.testing.assert_array_equal(got.scan_angle, src.scan_angle)


def test_las12_colour_extra_bytes_and_scan_angle_carried_to_format_7(tmp_path):
    src = laspy.read(FSITE5)
    las = laspy.convert(src, point_format_id=3, file_version="1.2")
    las.add_extra_dim(laspy.ExtraBytesParams(name="strip", type=np.uint16))
    k = len(las.points)
    las.red, las.green, las.blue = (np.arange(k, dtype=np.uint16) * m for m in (1, 2, 3))
    las.strip = np.arange(k, dtype=np.uint16) % 7
    las.gps_time = np.arange(k, dtype=np.float64)
    las.scan_angle_rank = (np.arange(k) % 61 - 30).astype(np.int8)
    las.header.add_crs(pyproj.CRS.from_epsg(32632))
    las.write(tmp_path / "rgb.las")
    aldpat("ortho-height", tmp_path / "rgb.las", "--geoid", GEOID).ok()
    got = laspy.read(tmp_path / "rgb_Ortho.las")
    assert (str(got.header.version), got.header.point_format.id) == ("1.4", 7)
    assert_compound(got.header.parse_crs(), 32632, 5773)
    for dim in ("red", "green", "blue", "strip", "gps_time", "classification", "intensity"):
        np.testing.assert_array_equal(got[dim], las[dim], err_msg=dim)
    np.testing.assert_allclose(np.asarray(got.scan_angle) * 0.006, las.scan_angle_rank, atol=0.003)


@pytest.mark.parametrize(("target", "horizontal", "vertical"), [("EPSG:32632+5783", 32632, 5783),
                                                                 ("EPSG:32632+5773", 32632, 5773),
                                                                 ("EPSG:4326+5773", 4326, 5773)])
def test_compound_to_crs_on_las12(tmp_path, target, horizontal, vertical):
    aldpat("ortho-height", CSITE1, "--geoid", GEOID, "--to-crs", target, "--odir", tmp_path).ok()
    out = tmp_path / "csite1_slice_Ortho.laz"
    crs, header = parts(out)
    assert str(header.version) == "1.4" and header.global_encoding.wkt
    assert_compound(crs, horizontal, vertical)
    src, got = laspy.read(CSITE1), laspy.read(out)
    x, y = pyproj.Transformer.from_crs(32632, horizontal, always_xy=True).transform(src.x, src.y)
    tol = 2e-7 if horizontal == 4326 else 0.006
    np.testing.assert_allclose(got.x, x, atol=tol)
    np.testing.assert_allclose(got.y, y, atol=tol)
    np.testing.assert_allclose(got.z, src.z - undulation(src), atol=0.006)


def test_vertical_to_crs_names_the_height_datum_of_the_input_horizontal(tmp_path):
    aldpat("ortho-height", FSITE5, "--geoid", GEOID, "--to-crs", "EPSG:5783", "--odir", tmp_path).ok()
    crs, _ = parts(tmp_path / "fsite5_pit_Ortho.laz")
    assert_compound(crs, 32632, 5783)


def test_reverse_records_the_horizontal_crs(tmp_path):
    aldpat("ortho-height", CSITE1, "--geoid", GEOID, "--odir", tmp_path).ok()
    ortho = tmp_path / "csite1_slice_Ortho.laz"
    aldpat("ortho-height", ortho, "--geoid", GEOID, "--reverse", "--suffix", "_h").ok()
    back = tmp_path / "csite1_slice_Ortho_h.laz"
    crs, header = parts(back)
    assert not crs.is_compound and not crs.is_vertical and crs.to_epsg() == 32632
    assert header.point_format.id == 6  # the orthometric file's LAS 1.4, its CRS in WKT
    np.testing.assert_allclose(laspy.read(back).z, laspy.read(CSITE1).z, atol=0.011)
    # straight from the LAS 1.2 input: the horizontal CRS fits its GeoTIFF keys, nothing upgraded
    aldpat("ortho-height", CSITE1, "--geoid", GEOID, "--reverse", "--odir", tmp_path / "r").ok()
    crs, header = parts(tmp_path / "r" / "csite1_slice_Ortho.laz")
    assert (str(header.version), header.point_format.id, crs.to_epsg()) == ("1.2", 0, 32632)


def test_feet_record_egm96_height_in_feet(tmp_path):
    aldpat("ortho-height", FSITE5, "--geoid", GEOID, "--z-unit", "ft", "--odir", tmp_path).ok()
    crs, _ = parts(tmp_path / "fsite5_pit_Ortho.laz")
    vertical = crs.sub_crs_list[1]
    assert vertical.is_vertical and vertical.axis_info[0].unit_name == "foot"
    assert vertical.datum.name == "EGM96 geoid"


@pytest.mark.parametrize("args", [("--reverse", "--to-crs", "EPSG:32632+5773"),
                                  ("--reverse", "--to-crs", "EPSG:5773"),
                                  ("--z-unit", "ft", "--to-crs", "EPSG:32632+5783"),
                                  ("--to-crs", "EPSG:4978"),  # geocentric
                                  ("--to-crs", 'LOCAL_CS["site grid",UNIT["metre",1]]'),
                                  ("--to-crs", "IAU_2015:30100")])  # the Moon
def test_a_target_that_cannot_be_honoured_is_a_usage_error(tmp_path, args):
    done = aldpat("ortho-height", CSITE1, "--geoid", GEOID, *args, "--odir", tmp_path)
    assert done.returncode == 2
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "--to-crs" in lines[0], done.stderr
    assert not list(tmp_path.glob("*.laz"))


def test_text_to_las_records_the_compound_and_text_gets_no_prj(tmp_path):
    src = laspy.read(FSITE5)
    text = tmp_path / "pit.txt"
    np.savetxt(text, np.column_stack([src.x, src.y, src.z]), fmt="%.2f")
    aldpat("ortho-height", text, "--crs", "32632", "--geoid", GEOID, "--out-format", "las").ok()
    crs, header = parts(tmp_path / "pit_Ortho.las")
    assert header.point_format.id == 6 and header.global_encoding.wkt
    assert_compound(crs, 32632, 5773)
    aldpat("ortho-height", text, "--crs", "32632", "--geoid", GEOID, "--suffix", "_t").ok()
    assert (tmp_path / "pit_t.txt").exists() and not (tmp_path / "pit_t.prj").exists()


def test_convert_with_a_compound_or_custom_crs_writes_wkt(tmp_path):
    text = tmp_path / "p.txt"
    np.savetxt(text, [[493800.0, 5420480.0, 200.0], [493801.0, 5420481.0, 201.0]], fmt="%.2f")
    aldpat("convert", text, "--crs", "EPSG:32632+5773", "--out-format", "las").ok()
    crs, header = parts(tmp_path / "p.las")
    assert header.point_format.id == 6 and header.global_encoding.wkt
    assert_compound(crs, 32632, 5773)
    custom = "+proj=tmerc +lat_0=0 +lon_0=9.5 +k=1 +x_0=500000 +y_0=0 +ellps=GRS80 +units=m +no_defs"
    aldpat("convert", text, "--crs", custom, "--out-format", "las", "--suffix", "_c").ok()
    crs, header = parts(tmp_path / "p_c.las")
    assert header.global_encoding.wkt and crs.to_epsg() is None
    origin = {p.name: p.value for p in crs.coordinate_operation.params}["Longitude of natural origin"]
    assert origin == 9.5


def test_help_says_what_is_recorded():
    text = " ".join(aldpat("ortho-height", "--help").ok().stdout.split())
    assert "horizontal CRS + EGM96 height (EPSG:5773)" in text and "compound --to-crs" in text
    assert "LAS 1.4" in text and "--reverse records the horizontal CRS alone" in text
