"""LAS 1.4 point formats 6-10 go through the filters and convert with every attribute kept,
and classified output uses the ASPRS codes (2 ground, 1 unclassified; the outlier filter 7 low
noise and 18 high noise where the point format has that class, 7 for both where it has not)."""

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
    if point_format in (7, 8, 10):
        out.red = np.full(n, 1000, np.uint16)
    if point_format in (8, 10):
        out.nir = np.full(n, 2000, np.uint16)
    if point_format in (9, 10):  # waveform packets: their descriptors are kept as they are
        out.wavepacket_index = np.ones(n, np.uint8)
        out.wavepacket_offset = np.arange(n, dtype=np.uint64) * 256
        out.wavepacket_size = np.full(n, 256, np.uint32)
    out.write(path)
    return out


@pytest.mark.parametrize("point_format", [6, 7, 8, 9, 10])
def test_filter_keeps_the_format_and_every_attribute(tmp_path, point_format):
    src = las14(tmp_path / "s.laz", point_format)
    report = get_task("filter", "gapm")([tmp_path / "s.laz"], result="classified", odir=str(tmp_path / "out"))
    assert report.exit_code == 0, [r.error for r in report.results]
    got = laspy.read(tmp_path / "out" / "s_gapm.laz")
    assert (str(got.header.version), got.header.point_format.id) == ("1.4", point_format)
    assert got.header.parse_crs().to_epsg() == 32632
    # ASPRS: 2 ground, 1 unclassified, 7 the strip's own low outliers
    assert {1, 2} <= set(np.unique(got.classification)) <= {1, 2, 7}
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


#: the strip's points are 2.5 m apart and it holds a quarry face: 3 m cells, and thresholds above
#: its real relief within a cell's neighbours, so that only the planted points are noise
# the outlier filter's own test alone (the low-outlier test every filter runs first finds real
# low points of the strip too)
NOISE_TEST = {"cell": 3.0, "high_threshold": 20.0, "low_threshold": 20.0, "low_outliers": None}


def with_noise(points: laspy.LasData) -> tuple[int, int]:
    """Put a bird 40 m over one point and a multipath return 30 m under another, far apart."""
    x, y = np.asarray(points.x), np.asarray(points.y)
    high = int(np.argmin(np.hypot(x - np.percentile(x, 30), y - np.percentile(y, 30))))
    low = int(np.argmin(np.hypot(x - np.percentile(x, 70), y - np.percentile(y, 70))))
    z = np.asarray(points.z).copy()
    z[high] += 40.0
    z[low] -= 30.0
    points.z = z
    return high, low


@pytest.mark.parametrize(("point_format", "high_class"), [(6, 18), (1, 7)])
def test_outlier_writes_asprs_noise_classes(tmp_path, point_format, high_class):
    if point_format >= 6:
        src = las14(tmp_path / "s.laz", point_format)
    else:
        src = laspy.read(STRIP)
        src = laspy.convert(src, point_format_id=point_format)
    high, low = with_noise(src)
    src.write(tmp_path / "s.laz")
    report = get_task("filter", "outlier")([tmp_path / "s.laz"], result="classified", odir=str(tmp_path / "out"),
                                           **NOISE_TEST)
    assert report.exit_code == 0, [r.error for r in report.results]
    got = laspy.read(tmp_path / "out" / "s_outlier.laz")
    cls = np.asarray(got.classification)
    assert cls[high] == high_class and cls[low] == 7
    noise = np.flatnonzero(np.isin(cls, (7, 18)))
    assert set(noise) == {high, low}  # real terrain, trees and roofs are not noise


def test_outlier_noise_classes_in_text(tmp_path):
    src = laspy.read(STRIP)
    high, low = with_noise(src)
    np.savetxt(tmp_path / "s.txt", np.c_[src.x, src.y, src.z], fmt="%.3f")
    report = get_task("filter", "outlier")([tmp_path / "s.txt"], result="classified", odir=str(tmp_path / "out"),
                                           **NOISE_TEST)
    assert report.exit_code == 0, [r.error for r in report.results]
    cls = np.loadtxt(tmp_path / "out" / "s_outlier.txt")[:, 3]
    assert cls[high] == 18 and cls[low] == 7
    assert set(np.flatnonzero(np.isin(cls, (7, 18)))) == {high, low}
    # the outlier filter finds noise, not ground: every other point is unclassified, none class 2
    assert set(np.unique(cls)) == {1, 7, 18}


@pytest.mark.parametrize("where, value, message", [
    ("count", 2**32 - 1, r"4,294,967,295 extended variable length records from byte [\d,]+ cannot fit"),
    ("length", 2**60, r"variable length record 1 runs to byte [\d,]+, past byte [\d,]+ where it must end"),
])
def test_extended_records_the_file_cannot_hold_are_refused_before_laspy_reads_them(tmp_path, where, value, message):
    import struct

    from laspy.vlrs.vlrlist import VLRList

    from aldpat.errors import InputFormatError
    from aldpat.io.las import LasReader

    data = las14(tmp_path / "whole.las", 6)
    data.evlrs = VLRList([laspy.VLR("aldpat_test", 1, "a record after the points", b"x" * 100)])
    data.write(tmp_path / "with_evlr.las")
    raw = bytearray((tmp_path / "with_evlr.las").read_bytes())
    start, count = struct.unpack_from("<QI", raw, 235)
    assert count == 1 and LasReader(tmp_path / "with_evlr.las").count == len(data.x)
    if where == "count":
        struct.pack_into("<I", raw, 243, value)
    else:
        struct.pack_into("<Q", raw, start + 20, value)  # the length after the record's 60-byte header
    (tmp_path / "hostile.las").write_bytes(bytes(raw))
    with pytest.raises(InputFormatError, match=message):
        LasReader(tmp_path / "hostile.las")
