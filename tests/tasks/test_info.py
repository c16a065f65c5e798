import json

import numpy as np


def test_info_json_reports_count_bounds_and_format(runner, cli, samp24):
    out = runner.invoke(cli, ["info", str(samp24), "--json"])
    assert out.exit_code == 0, out.output
    rec = json.loads(out.output)
    data = np.loadtxt(samp24)
    assert rec["path"] == str(samp24) and rec["count"] == len(data) and rec["format"] == "text"
    assert rec["bounds"] == [data[:, 0].min(), data[:, 1].min(), data[:, 0].max(), data[:, 1].max()]
    assert rec["z_range"] == [data[:, 2].min(), data[:, 2].max()]
    assert rec["crs"] is None


def test_info_reads_the_crs_of_a_laz(runner, cli, samp24, tmp_path):
    assert runner.invoke(cli, ["convert", str(samp24), "--out-format", "laz", "--crs", "EPSG:32632",
                               "--odir", str(tmp_path)]).exit_code == 0
    out = runner.invoke(cli, ["info", str(tmp_path / "samp24.laz"), "--json"])
    rec = json.loads(out.output)
    assert rec["crs"] == "EPSG:32632" and rec["format"] == "laz" and rec["count"] == 7492


def test_info_reports_an_empty_las_and_reads_a_laz_named_las(tmp_path):
    """A LAS 1.4 LAZ of no points (an empty edge tile of a delivery) is a valid file: ``info``
    refused it ("no points in file", exit 1); it now reports its header, count 0, with a warning.
    A LAZ file named .las was refused as "truncated" (its compression told by the name, not by
    the header); it reads as the LAZ it is."""
    import shutil

    import laspy

    from tests.cli.fresh import TEST_DATA, aldpat

    las = laspy.read(TEST_DATA / "fsite5_strip.laz")
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.add_crs(las.header.parse_crs())
    laspy.LasData(header).write(tmp_path / "empty.laz")
    done = aldpat("info", "empty.laz", "--json", cwd=tmp_path).ok()
    record = json.loads(done.stdout)
    assert (record["count"], record["bounds"], record["density"]) == (0, None, None)
    assert record["crs"] == "EPSG:32632" and record["point_format"] == 6
    assert done.stderr == "aldpat: empty.laz: holds no points\n"
    assert "x range  -" in aldpat("info", "empty.laz", cwd=tmp_path).ok().stdout

    shutil.copy(TEST_DATA / "fsite5_strip.laz", tmp_path / "strip_named.las")
    record = json.loads(aldpat("info", "strip_named.las", "--json", cwd=tmp_path).ok().stdout)
    assert record["count"] == len(las.points)
    aldpat("filter", "pm", "strip_named.las", "--odir", "out", cwd=tmp_path).ok()
    assert len(laspy.read(tmp_path / "out" / "strip_named_pm.las").points) == len(las.points)
