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
