"""``aldpat ortho-height``: H = h - N against the NGA EGM96 test values, LAS inputs keep their
attributes, re-projection, reverse, and a point outside the geoid named instead of written."""

from __future__ import annotations

from pathlib import Path

import laspy
import numpy as np
import pyproj
import pytest

from aldpat.tasks import get_task

DATA = Path(__file__).resolve().parents[1] / "data"
GEOID = DATA / "egm96_15_nga1.gtx"  # EGM96 window around the NGA point (38.6281550 N, 269.7791550 E)
LAT, LON, N = 38.6281550, 269.7791550 - 360.0, -31.628
TO_UTM = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32615", always_xy=True)


def utm_points(tmp_path, name="strip.txt", extra=()):
    e, n = TO_UTM.transform(LON, LAT)
    pts = np.array([[e, n, 180.25, 12], [e + 20.0, n + 10.0, 181.5, 40], *extra])
    path = tmp_path / name
    np.savetxt(path, pts, fmt=["%.2f", "%.2f", "%.2f", "%d"])
    return path


def test_text_strip_to_orthometric(tmp_path):
    src = utm_points(tmp_path)
    report = get_task("ortho-height")([src], crs="15N", geoid=str(GEOID))
    assert report.exit_code == 0, report.results[0].error
    out = tmp_path / "strip_Ortho.txt"
    rows = np.loadtxt(out)
    assert rows[0, 2] == pytest.approx(180.25 - N, abs=0.1)
    assert rows[1, 2] == pytest.approx(181.5 - N, abs=0.1)
    np.testing.assert_array_equal(rows[:, [0, 1, 3]], np.loadtxt(src)[:, [0, 1, 3]])
    first = out.read_text().splitlines()[0].split()
    assert [len(t.split(".")[1]) if "." in t else 0 for t in first] == [2, 2, 2, 0]  # decimals kept
    assert report.outputs[0].count == 2 and (tmp_path / "strip_Ortho.log").exists()
    back = get_task("ortho-height")([out], crs="15N", geoid=str(GEOID), reverse=True, suffix="_h")
    assert back.exit_code == 0
    np.testing.assert_allclose(np.loadtxt(tmp_path / "strip_Ortho_h.txt"), np.loadtxt(src), atol=0.01)  # two roundings to 2 decimals


def utm15_las() -> tuple[laspy.LasData, float, float]:
    """An empty UTM 15N (EPSG:32615) LAS of point format 1 (scale 1 cm) near the test
    point, and the test point's easting and northing."""
    e, n = TO_UTM.transform(LON, LAT)
    header = laspy.LasHeader(point_format=1, version="1.2")
    header.scales = np.array([0.01, 0.01, 0.01])
    header.offsets = np.array([700000.0, 4200000.0, 0.0])
    header.add_crs(pyproj.CRS.from_epsg(32615))
    return laspy.LasData(header), e, n


def test_las_uses_its_own_crs_and_keeps_attributes(tmp_path):
    las, e, n = utm15_las()
    las.x = np.array([e, e + 5.0, e + 9.0])
    las.y = np.array([n, n - 3.0, n + 1.0])
    las.z = np.array([150.0, 151.0, 152.0])
    las.intensity = np.array([5, 6, 7])
    las.gps_time = np.array([1.5, 2.5, 3.5])
    las.classification = np.array([2, 1, 2])
    las.write(tmp_path / "s.las")
    report = get_task("ortho-height")([tmp_path / "s.las"], geoid=str(GEOID))
    assert report.exit_code == 0, report.results[0].error
    out = laspy.read(tmp_path / "s_Ortho.las")
    np.testing.assert_allclose(out.z, [150.0 - N, 151.0 - N, 152.0 - N], atol=0.1)
    np.testing.assert_allclose(out.x, las.x, atol=0.005)
    np.testing.assert_array_equal(out.intensity, [5, 6, 7])
    np.testing.assert_array_equal(out.gps_time, [1.5, 2.5, 3.5])
    np.testing.assert_array_equal(out.classification, [2, 1, 2])


def test_reprojection_to_geographic_keeps_enough_decimals(tmp_path):
    src = utm_points(tmp_path)
    report = get_task("ortho-height")([src], crs="EPSG:32615", geoid=str(GEOID), to_crs="EPSG:4326")
    assert report.exit_code == 0, report.results[0].error
    rows = np.loadtxt(tmp_path / "strip_Ortho.txt")
    assert (rows[0, 0], rows[0, 1]) == pytest.approx((LON, LAT), abs=1e-7)
    assert rows[0, 2] == pytest.approx(180.25 - N, abs=0.1)


def test_reprojection_of_text_to_geographic_las_keeps_enough_decimals(tmp_path):
    """A LAS made for text points took the text's metre decimals for its scales: degrees were
    stored at 0.01 (about a kilometre)."""
    src = utm_points(tmp_path)
    report = get_task("ortho-height")([src], crs="EPSG:32615", geoid=str(GEOID), to_crs="EPSG:4326",
                                      out_format="las")
    assert report.exit_code == 0, report.results[0].error
    out = laspy.read(tmp_path / "strip_Ortho.las")
    assert list(out.header.scales[:2]) == pytest.approx([1e-8, 1e-8])
    assert (out.x[0], out.y[0]) == pytest.approx((LON, LAT), abs=2e-7)


def test_point_outside_the_geoid_is_named_and_nothing_written(tmp_path, runner, cli):
    far = TO_UTM.transform(LON + 2.0, LAT)
    src = utm_points(tmp_path, extra=[[far[0], far[1], 100.0, 1]])
    res = runner.invoke(cli, ["ortho-height", str(src), "--crs", "15N", "--geoid", str(GEOID)])
    assert res.exit_code == 1
    assert "strip.txt: point 3 " in res.output and "outside the geoid grid" in res.output
    assert "Traceback" not in res.output
    assert not (tmp_path / "strip_Ortho.txt").exists()


def test_missing_crs_or_geoid_is_reported(tmp_path, runner, cli):
    src = utm_points(tmp_path)
    res = runner.invoke(cli, ["ortho-height", str(src), "--geoid", str(GEOID)])
    assert res.exit_code != 0 and "--crs is required" in res.output
    res = runner.invoke(cli, ["ortho-height", str(src), "--crs", "15N"])
    assert res.exit_code == 2 and "geoid: required (--geoid on the command line)" in res.output
    res = runner.invoke(cli, ["ortho-height", str(src), "--crs", "15N", "--geoid", str(tmp_path / "x" / "g.gtx")])
    assert res.exit_code != 0 and "g.gtx" in res.output


def test_las_reprojected_gets_the_format_6_of_its_format_1_and_the_new_crs(tmp_path):
    las, e, n = utm15_las()
    las.x = np.array([e, e + 5.0])
    las.y = np.array([n, n - 3.0])
    las.z = np.array([150.0, 151.0])
    las.gps_time = np.array([1.5, 2.5])
    las.write(tmp_path / "s.las")
    report = get_task("ortho-height")([tmp_path / "s.las"], geoid=str(GEOID), to_crs="EPSG:4326")
    assert report.exit_code == 0, report.results[0].error
    out = laspy.read(tmp_path / "s_Ortho.las")
    crs = out.header.parse_crs()  # LAS 1.4 for the WKT of WGS 84 + EGM96 height (EPSG:4326+5773)
    assert out.header.point_format.id == 6 and [c.to_epsg() for c in crs.sub_crs_list] == [4326, 5773]
    assert (out.x[0], out.y[0]) == pytest.approx((LON, LAT), abs=2e-7)
    np.testing.assert_array_equal(out.gps_time, [1.5, 2.5])
    assert out.z[0] == pytest.approx(150.0 - N, abs=0.1)


def test_a_las_in_degrees_goes_back_to_utm(tmp_path):
    """UTM to degrees and back, LAS to LAS, in fresh processes: the way back kept the degrees'
    x, y step of 1e-7, whose 32-bit integers hold 214 m of UTM coordinates, and every point was
    refused ("cannot be stored in this LAS file"). The projected output now takes a millimetre;
    the round trip returns every point within the degrees' step (about a centimetre)."""
    from tests.cli.fresh import TEST_DATA, aldpat

    geoid = DATA / "egm96_15_isprs.gtx"  # the window over the ISPRS sites (UTM 32N)
    aldpat("ortho-height", TEST_DATA / "fsite5_strip.laz", "--geoid", geoid, "--to-crs", "EPSG:4326",
           "--odir", "deg", cwd=tmp_path).ok()
    aldpat("ortho-height", "deg/fsite5_strip_Ortho.laz", "--geoid", geoid, "--reverse", "--to-crs", "EPSG:32632",
           "--odir", "back", cwd=tmp_path).ok()
    source, back = laspy.read(TEST_DATA / "fsite5_strip.laz"), laspy.read(tmp_path / "back" / "fsite5_strip_Ortho_Ortho.laz")
    assert list(back.header.scales[:2]) == [0.001, 0.001]
    for axis in "xy":
        assert np.abs(np.asarray(source[axis]) - np.asarray(back[axis])).max() < 0.01
    assert np.abs(np.asarray(source.z) - np.asarray(back.z)).max() <= 0.011


def test_a_geoid_under_an_unknown_users_home_is_named_missing(tmp_path, runner, cli):
    # a shell leaves ~nosuchuser as written; Path.expanduser raised RuntimeError with a traceback
    src = utm_points(tmp_path)
    res = runner.invoke(cli, ["ortho-height", str(src), "--crs", "15N", "--geoid", "~nosuchuser-aldpat/g.gtx"])
    assert res.exit_code == 2, res.output
    assert "geoid: ~nosuchuser-aldpat/g.gtx: no such geoid grid file" in res.output
    assert "Traceback" not in res.output and not (tmp_path / "strip_Ortho.txt").exists()
