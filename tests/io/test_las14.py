"""LAS 1.4 point formats 6-8 go through the filters and convert with every attribute kept,
and classified output uses the ASPRS codes (2 ground, 1 unclassified)."""

from __future__ import annotations

from pathlib import Path

import laspy
import numpy as np
import pytest

from aldpat.tasks import get_task

STRIP = Path(__file__).resolve().parents[1] / "data" / "fsite5_strip.laz"  # real points, EPSG:32632


def las14(path: Path, point_format: int) -> laspy.LasData:
    src = laspy.read(STRIP)
    header = laspy.LasHeader(point_format=point_format, version="1.4")
    header.scales, header.offsets = src.header.scales, src.header.offsets
    header.add_crs(src.header.parse_crs())
    out = laspy.LasData(header)
    out.x, out.y, out.z = src.x, src.y, src.z
    out.intensity = src.intensity
    n = len(src.x)
    out.gps_time = np.arange(n) * 0.001
    out.return_number = np.ones(n, np.uint8)
    out.number_of_returns = np.ones(n, np.uint8)
    out.scan_angle = np.arange(n, dtype=np.int16) % 300 - 150  # a 1.4 attribute (0.006 degree units)
    if point_format >= 7:
        out.red = np.full(n, 1000, np.uint16)
    if point_format == 8:
        out.nir = np.full(n, 2000, np.uint16)
    out.write(path)
    return out


@pytest.mark.parametrize("point_format", [6, 7, 8])
def test_filter_keeps_the_format_and_every_attribute(tmp_path, point_format):
    src = las14(tmp_path / "s.laz", point_format)
    report = get_task("filter", "gapm")([tmp_path / "s.laz"], result="classified", odir=str(tmp_path / "out"))
    assert report.exit_code == 0, [r.error for r in report.results]
    got = laspy.read(tmp_path / "out" / "s_gapm.laz")
    assert (str(got.header.version), got.header.point_format.id) == ("1.4", point_format)
    assert got.header.parse_crs().to_epsg() == 32632
    assert set(np.unique(got.classification)) == {1, 2}  # ASPRS: 2 ground, 1 unclassified
    for dim in src.point_format.dimension_names:
        if dim != "classification":
            np.testing.assert_array_equal(np.asarray(got[dim]), np.asarray(src[dim]), err_msg=dim)


def test_convert_las14_to_las14(tmp_path):
    src = las14(tmp_path / "s.laz", 7)
    assert get_task("convert")([tmp_path / "s.laz"], out_format="las", odir=str(tmp_path / "c")).exit_code == 0
    got = laspy.read(tmp_path / "c" / "s.las")
    assert got.header.point_format.id == 7 and str(got.header.version) == "1.4"
    for dim in src.point_format.dimension_names:
        np.testing.assert_array_equal(np.asarray(got[dim]), np.asarray(src[dim]), err_msg=dim)
