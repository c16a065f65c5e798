import json

import laspy
import numpy as np
import pyproj
import pytest

from aldpat.errors import InputFormatError
from aldpat.io.registry import open_points, write_points


def make_las(path, n=1000, crs="EPSG:32617", point_format=3):
    rng = np.random.default_rng(1)
    header = laspy.LasHeader(point_format=point_format, version="1.2")
    header.scales = np.array([0.01, 0.01, 0.001])
    header.offsets = np.array([500000.0, 4000000.0, 0.0])
    header.add_crs(pyproj.CRS.from_user_input(crs))
    las = laspy.LasData(header)
    las.x = 500000 + rng.uniform(0, 100, n)
    las.y = 4000000 + rng.uniform(0, 100, n)
    las.z = rng.uniform(0, 30, n)
    las.intensity = rng.integers(0, 4000, n)
    las.classification = rng.integers(0, 10, n)
    las.gps_time = np.arange(n, dtype=float)
    las.write(path)
    return laspy.read(path)


@pytest.mark.parametrize("ext", [".las", ".laz"])
def test_round_trip_keeps_attributes_scale_offset_and_crs(tmp_path, ext):
    src = tmp_path / f"in{ext}"
    original = make_las(src)
    reader = open_points(src)
    assert reader.count == 1000 and reader.crs.to_epsg() == 32617
    out = tmp_path / f"out{ext}"
    with write_points(out, reader.names, like=reader) as w:
        for chunk in reader.chunks(size=300):
            w.write(chunk)
    back = laspy.read(out)
    assert back.header.point_format.id == 3
    np.testing.assert_allclose(back.header.scales, [0.01, 0.01, 0.001])
    np.testing.assert_allclose(back.header.offsets, [500000.0, 4000000.0, 0.0])
    assert back.header.parse_crs().to_epsg() == 32617
    for dim in ("X", "Y", "Z", "intensity", "classification", "gps_time"):
        np.testing.assert_array_equal(back[dim], original[dim])


def test_subset_and_reclassify_keep_other_attributes(tmp_path):
    src = tmp_path / "in.las"
    original = make_las(src)
    reader = open_points(src)
    table = reader.read()
    keep = table.z > 15
    sub = table.take(keep).with_columns(classification=np.full(int(keep.sum()), 2, dtype=np.uint8))
    out = tmp_path / "out.laz"
    with write_points(out, reader.names, like=reader) as w:
        w.write(sub)
    back = laspy.read(out)
    assert len(back) == keep.sum() and (back.classification == 2).all()
    np.testing.assert_array_equal(back.gps_time, original.gps_time[keep])
    np.testing.assert_array_equal(back.intensity, original.intensity[keep])


def test_extra_column_becomes_an_extra_byte_dimension(tmp_path):
    src = tmp_path / "in.las"
    make_las(src, n=10)
    reader = open_points(src)
    table = reader.read().with_columns(mark=np.arange(10, dtype=np.int32))
    out = tmp_path / "marks.las"
    with write_points(out, reader.names + ("mark",), like=reader) as w:
        w.write(table)
    np.testing.assert_array_equal(laspy.read(out)["mark"], np.arange(10))


def test_text_to_laz_derives_scale_from_decimals(tmp_path, samp24):
    reader = open_points(samp24)
    out = tmp_path / "s.laz"
    with write_points(out, ("x", "y", "z", "intensity"), like=reader, crs=pyproj.CRS("EPSG:32632")) as w:
        for c in reader.chunks():
            w.write(c)
    back = laspy.read(out)
    np.testing.assert_allclose(back.header.scales, [0.01, 0.01, 0.01])
    assert back.header.parse_crs().to_epsg() == 32632
    t = reader.read()
    np.testing.assert_allclose(back.x, t.x, atol=1e-9)
    np.testing.assert_allclose(back.z, t.z, atol=1e-9)


def test_a_coordinate_the_files_integers_cannot_hold_is_refused_in_one_line(tmp_path):
    """A LAS file stores x as a 32-bit integer at its scale from its offset: about 2,147 km either
    side at millimetres. A text file with one stray point 10,700 km from the others, after the
    points the header is made from (its first chunk: here a point), was laspy's OverflowError, an
    internal error."""
    from aldpat.errors import DataError

    src = tmp_path / "stray.txt"
    src.write_text("-10000000.123 5403000.456 300.789\n512000.123 5403000.456 300.789\n")
    reader = open_points(src)
    out = tmp_path / "stray.las"
    refused = (r"^x = 512000\.123 cannot be stored in this LAS file: at its scale 0\.001 and offset -10001000 its "
               r"32-bit integers hold x from -12148483\.65 to -7853516\.353 \(a stray point")
    with pytest.raises(DataError, match=refused), write_points(out, ("x", "y", "z"), like=reader) as w:
        for c in reader.chunks(1):
            w.write(c)
    # at the edge of the integers' range: stored exactly
    edge = tmp_path / "edge.txt"
    edge.write_text("1000.000 0 0\n2148483.647 0 0\n")
    reader = open_points(edge)
    with write_points(tmp_path / "edge.las", ("x", "y", "z"), like=reader) as w:
        for c in reader.chunks(1):
            w.write(c)
    assert laspy.read(tmp_path / "edge.las").X.max() == 2 ** 31 - 1


@pytest.mark.parametrize("fmt, lows, highs, scales, offsets", [
    # UTM metres printed to 1e-6 over 10 km: 1e10 steps of 1e-6; 1e-5 holds them
    ("%.6f", (500000, 5400000, 0), (510000, 5410000, 100), (1e-5, 1e-5, 1e-6), (500000, 5400000, 0)),
    # degrees to 1e-8 (a millimetre): whole degrees as offsets leave the room kilometres would not
    ("%.8f", (-80.3, 26.0, 0), (-80.1, 26.2, 100), (1e-8, 1e-8, 1e-7), (-81, 26, 0)),
    ("%.2f", (500000, 5400000, 0), (510000, 5410000, 100), (0.01, 0.01, 0.01), (500000, 5400000, 0)),
])
def test_text_to_las_keeps_the_decimals_the_integers_can_hold(tmp_path, fmt, lows, highs, scales, offsets):
    """A header made for text points takes the text's decimals (up to 8) as far as the 32-bit
    integers hold the points from the offset: 6 decimals of UTM metres over 10 km made laspy's
    OverflowError, and degrees lost every decimal past the sixth (0.1 m of latitude)."""
    rng = np.random.default_rng(4)
    points = np.stack([rng.uniform(lo, hi, 500) for lo, hi in zip(lows, highs, strict=True)], axis=1)
    src = tmp_path / "p.txt"
    np.savetxt(src, points, fmt=fmt)
    reader = open_points(src)
    with write_points(tmp_path / "p.las", ("x", "y", "z"), like=reader) as w:
        for c in reader.chunks():
            w.write(c)
    back = laspy.read(tmp_path / "p.las")
    np.testing.assert_allclose(back.header.scales, scales)
    np.testing.assert_allclose(back.header.offsets, offsets)
    text = np.loadtxt(src)
    for k, axis in enumerate("xyz"):
        assert np.abs(np.asarray(back[axis]) - text[:, k]).max() <= scales[k] / 2 + 1e-9 * abs(highs[k])


@pytest.mark.parametrize("column, values, refused", [
    ("intensity", "70000 12", ("intensity = 70000 cannot be stored in this LAS file, whose intensity holds whole "
                              "numbers from 0 to 65,535")),
    ("intensity", "-5 12", "intensity = -5 cannot"),
    ("intensity", "0.35 0.5", "intensity = 0.35 cannot"),  # reflectances: all would have been 0
    ("intensity", "35 65535", None),
    ("intensity", "35.0 500.0", None),
])
def test_a_text_column_las_cannot_hold_is_refused_not_wrapped(tmp_path, column, values, refused):
    """LAS intensity is a whole number from 0 to 65,535: 70,000 was stored as 4,464, -5 as 65,531
    and 0.35 as 0, without a word."""
    from aldpat.errors import DataError

    first, second = values.split()
    src = tmp_path / "a.txt"
    src.write_text(f"x y z {column}\n1 2 3 {first}\n2 3 4 {second}\n")
    reader = open_points(src)
    out = tmp_path / "a.laz"
    if refused:
        with pytest.raises(DataError, match=refused), write_points(out, ("x", "y", "z", column), like=reader) as w:
            for c in reader.chunks():
                w.write(c)
    else:
        with write_points(out, ("x", "y", "z", column), like=reader) as w:
            for c in reader.chunks():
                w.write(c)
        assert laspy.read(out)[column].tolist() == [round(float(first)), round(float(second))]


@pytest.mark.parametrize("ext", [".las", ".laz"])
def test_truncated_files_are_reported_not_crashed(tmp_path, ext):
    src = tmp_path / f"in{ext}"
    make_las(src, n=5000)
    data = src.read_bytes()
    cut = tmp_path / f"cut{ext}"
    cut.write_bytes(data[: len(data) * 2 // 3])
    with pytest.raises(InputFormatError, match="truncated"):
        open_points(cut).read()
    stub = tmp_path / f"stub{ext}"
    stub.write_bytes(data[:100])
    with pytest.raises(InputFormatError, match="truncated or corrupt"):
        open_points(stub).read()


def test_writing_a_reclassified_table_leaves_the_source_table_untouched(tmp_path):
    src = tmp_path / "in.las"
    make_las(src, n=50)
    reader = open_points(src)
    table = reader.read()
    before = table.record.array.copy()
    changed = table.with_columns(classification=np.full(50, 2, dtype=np.uint8), z=table.z + 1.0)
    assert changed.meta["in_record"] == frozenset(table.names) - {"classification", "z"}
    with write_points(tmp_path / "out.las", reader.names, like=reader) as w:
        w.write(changed)
    np.testing.assert_array_equal(table.record.array, before)
    back = laspy.read(tmp_path / "out.las")
    assert (back.classification == 2).all()
    np.testing.assert_allclose(back.z, table.z + 1.0, atol=0.0006)
    np.testing.assert_array_equal(back.X, before["X"])


@pytest.mark.parametrize("scales, offsets, decimals", [
    ((0.025, 0.025, 0.0025), (0.0, 0.0, 0.0), (3, 3, 4)),  # 0.075 was written 0.08
    ((0.01, 0.01, 0.01), (512000.123, 0.0, 0.0), (3, 2, 2)),  # an offset's own decimals count
    ((1e-7, 1e-7, 0.001), (-81.0, 26.0, 0.0), (7, 7, 3)),
])
def test_las_to_text_writes_every_stored_digit(tmp_path, scales, offsets, decimals):
    """A LAS coordinate is ``X * scale + offset``: the text written from it takes the decimals both
    need, not the scale's power of ten rounded."""
    header = laspy.LasHeader(point_format=0, version="1.2")
    header.scales, header.offsets = np.array(scales), np.array(offsets)
    las = laspy.LasData(header)
    las.X = las.Y = las.Z = np.array([1, 2, 3, 40001])
    las.write(tmp_path / "s.las")
    reader = open_points(tmp_path / "s.las")
    assert [reader.decimals[n] for n in "xyz"] == list(decimals)
    with write_points(tmp_path / "s.txt", ("x", "y", "z"), like=reader) as w:
        for c in reader.chunks():
            w.write(c)
    back = np.loadtxt(tmp_path / "s.txt", usecols=(0, 1, 2))
    for k, axis in enumerate("xyz"):
        assert np.allclose(back[:, k], np.asarray(las[axis]), rtol=0, atol=scales[k] / 100), axis


def test_a_class_a_las_12_file_cannot_hold_names_the_point_formats_that_can():
    from aldpat.errors import DataError
    from aldpat.io.las import _check_whole

    with pytest.raises(DataError, match=r"^class = 40 cannot be stored .* from 0 to 31 \(point formats 6-10 of LAS "
                                        r"1\.4 hold up to 255\)$"):
        _check_whole(np.array([2, 40], np.uint8), "class", "classification", las14=False)
    with pytest.raises(DataError, match=r"from 0 to 255 \(write text, or scale the column\)$"):
        _check_whole(np.array([2.0, 256.0]), "class", "classification", las14=True)
    _check_whole(np.array([2, 40], np.uint8), "class", "classification", las14=True)
    _check_whole(np.array([0, 65535], np.uint16), "intensity", "intensity", las14=False)


@pytest.mark.parametrize("ext", [".las", ".laz"])
def test_text_points_with_more_decimals_further_down_keep_them_in_las(tmp_path, ext):
    """The header's scales come from the first chunk; a chunk further down with more decimals
    (100.5 there, 512.125 later) was stored at the first chunk's scale: rounded, silently. The
    points written before are now copied into a file of the finer scale, exactly."""
    src = tmp_path / "mixed.txt"
    src.write_text("".join(f"{512000 + k * 0.5} {5400000 + k * 0.5} {10 + k * 0.5}\n" for k in range(250))
                   + "512999.125 5400999.0625 12.3456\n" + "513000.5 5401000.5 13.5\n" * 3)
    reader = open_points(src)
    out = tmp_path / f"again{ext}"
    with write_points(out, reader.names, like=reader) as w:
        for chunk in reader.chunks(size=100):
            w.write(chunk)
    las = laspy.read(out)
    expected = np.loadtxt(src)
    assert list(las.header.scales) == pytest.approx([0.001, 0.0001, 0.0001])
    assert list(las.header.offsets) == [512000, 5400000, 0]
    for k, axis in enumerate("xyz"):
        assert np.array_equal(np.round(np.asarray(las[axis]), 4), expected[:, k]), axis
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["mixed.txt", f"again{ext}"])  # no temporaries


def test_more_decimals_further_down_than_the_integers_hold_are_kept_as_far_as_they_can(tmp_path):
    """Over 20 km the 32-bit integers hold four decimals of a metre, not the sixth a later line
    asks for: the scale becomes 1e-4, no point overflows, every point within its rounding."""
    rows = [f"{500000 + k * 100.0:.2f} 4000000.00 10.00\n" for k in range(201)]
    rows.append("510000.123456 4000000.00 10.00\n")
    src = tmp_path / "wide.txt"
    src.write_text("".join(rows))
    reader = open_points(src)
    out = tmp_path / "wide.las"
    with write_points(out, reader.names, like=reader) as w:
        for chunk in reader.chunks(size=100):
            w.write(chunk)
    las = laspy.read(out)
    assert las.header.scales[0] == pytest.approx(1e-4)
    np.testing.assert_allclose(np.asarray(las.x), np.loadtxt(src)[:, 0], rtol=0, atol=0.5e-4 + 1e-9)


def test_a_stray_point_is_refused_for_las_and_a_coarser_scale_is_said(tmp_path):
    """One point with a lost decimal point (51386646 among 513866.46) made a LAZ that aldpat's own
    reader refuses (x over more than the Earth's circumference), every x of it stored at 0.1 m
    without a word. The writer now refuses it, in a fresh ``aldpat convert``, in one line naming
    the input and the stray point's line; a point far enough to cost a decimal but not that far is written, and said."""
    from tests.cli.fresh import aldpat, leftovers

    rows = [f"{513748.11 + 0.37 * k:.2f} {5403124.79 + 0.21 * k:.2f} {310.77 + 0.01 * k:.2f}\n" for k in range(300)]
    (tmp_path / "stray.txt").write_text("".join(rows) + "51386646.00 5403124.79 310.77\n")
    (tmp_path / "far.txt").write_text("".join(rows) + "30386646.00 5403124.79 310.77\n")
    done = aldpat("convert", "stray.txt", "far.txt", "--out-format", "laz", "--odir", "o", cwd=tmp_path)
    assert done.returncode == 1
    lines = done.stderr.splitlines()
    assert [ln for ln in lines if "stray." in ln] == [
        ("aldpat: stray.txt:301: x reaches from 513748.11 to 51386646, more than the Earth's circumference: "
         "a LAS file of these points could not be read back (a stray point at x = 51386646? aldpat info shows the "
         "bounds)")]
    assert "aldpat: far.laz: x stored at 0.1, coarser than the 2 decimals of the text: LAS integers cannot hold " \
           "them over the points' extent (a stray point far from the others?)" in lines
    assert sorted(p.name for p in (tmp_path / "o").iterdir()) == ["far.laz", "far.log"]
    assert leftovers(tmp_path) == []
    aldpat("info", tmp_path / "o" / "far.laz").ok()


def test_extended_records_are_kept_and_a_copc_input_is_written_as_plain_laz(tmp_path):
    """A CRS a vendor stored in an extended VLR (LAS 1.4 R15, section 2.5) was lost in every
    LAS/LAZ output (laspy writes EVLRs only when asked), and a COPC input failed every command
    writing LAS ("Writing COPC is not supported": its info record copied into the output). Both
    in one fresh ``aldpat`` process: the EVLR is kept (and replaced by ``--crs``), the COPC
    records are dropped and the points written as a plain LAZ."""
    import pyproj
    from laspy.vlrs.known import WktCoordinateSystemVlr
    from laspy.vlrs.vlr import VLR
    from laspy.vlrs.vlrlist import VLRList

    from tests.cli.fresh import TEST_DATA, aldpat_batch

    strip = laspy.convert(laspy.read(TEST_DATA / "fsite5_strip.laz"), point_format_id=6, file_version="1.4")
    strip.header.vlrs.clear()
    wkt = pyproj.CRS.from_epsg(32632).to_wkt(pyproj.enums.WktVersion.WKT1_GDAL)
    strip.header.evlrs = VLRList([WktCoordinateSystemVlr(wkt)])
    strip.header.global_encoding.wkt = True
    strip.write(tmp_path / "evlr.laz")
    copc = laspy.convert(laspy.read(TEST_DATA / "fsite5_strip.laz"), point_format_id=6, file_version="1.4")
    copc.header.vlrs.append(VLR(user_id="copc", record_id=1, description="copc info", record_data=bytes(160)))
    copc.write(tmp_path / "site.copc.laz")
    commands = [["info", "evlr.laz", "--json"],
                *([*command, "evlr.laz", "--odir", command[0]] for command in
                  (["filter", "pm"], ["thin"], ["convert", "--out-format", "las"])),
                ["filter", "pm", "evlr.laz", "--crs", "EPSG:25832", "--odir", "other"],
                ["filter", "pm", "site.copc.laz", "--odir", "fromcopc"]]
    runs = aldpat_batch([{"args": command, "cwd": tmp_path} for command in commands])
    assert [run["status"] for run in runs] == [0] * len(commands), [run["stderr"] for run in runs]
    assert json.loads(runs[0]["stdout"])["crs"] == "EPSG:32632"
    for written in [*(tmp_path / "filter").glob("*.laz"), *(tmp_path / "thin").glob("*.laz"),
                    tmp_path / "convert" / "evlr.las"]:
        with laspy.open(written) as f:
            assert f.header.parse_crs().to_epsg() == 32632 and len(f.header.evlrs) == 1, written
    with laspy.open(tmp_path / "other" / "evlr_pm.laz") as f:
        assert f.header.parse_crs().to_epsg() == 25832 and len(f.header.evlrs) == 0
    written = laspy.read(tmp_path / "fromcopc" / "site.copc_pm.laz")
    assert len(written.points) == len(copc.points)
    assert not any(str(v.user_id).rstrip("\0") == "copc" for v in written.header.vlrs)


@pytest.mark.parametrize("claimed, refused", [
    (40_000, "header says 40,000 points, its compressed chunks hold at least 100,001: the others would be lost"),
    (100_000_000, ("truncated or a corrupt header: header says 100,000,000 points, its compressed chunks hold at "
                  "most 150,000")),
    (120_000, None),
])
def test_a_laz_header_count_the_chunks_cannot_hold_is_refused(tmp_path, claimed, refused):
    """A LAZ header's point count was bounded only by the file's size: a count too large had the
    points allocated (3 GB from a 116 kB file) before the reader found the file short, and one
    too small lost the points after it without a word. Its chunk table (three chunks of 50,000
    points here) now bounds it both ways, in a fresh ``aldpat info``."""
    import struct

    from tests.cli.fresh import aldpat

    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales, header.offsets = np.array([0.01] * 3), np.array([500000.0, 4000000.0, 0.0])
    las = laspy.LasData(header)
    rng = np.random.default_rng(3)
    las.x, las.y, las.z = rng.uniform(500000, 500300, 120_000), rng.uniform(4000000, 4000300, 120_000), \
        rng.uniform(0, 10, 120_000)
    las.write(tmp_path / "site.laz")
    data = bytearray((tmp_path / "site.laz").read_bytes())
    struct.pack_into("<Q", data, 247, claimed)  # LAS 1.4: the 64-bit point count
    (tmp_path / "site.laz").write_bytes(bytes(data))
    done = aldpat("info", "site.laz", "--json", cwd=tmp_path)
    if refused is None:
        assert done.returncode == 0 and json.loads(done.stdout)["count"] == 120_000
    else:
        assert done.returncode == 1 and done.stderr.splitlines()[0] == f"aldpat: site.laz: {refused}"


def test_a_text_value_las_cannot_hold_is_told_with_its_file_and_line(tmp_path):
    """A text line whose intensity a LAS file cannot hold was told with its file
    alone ("a.txt: intensity = 0.35 cannot be stored"): the points are written far from where they
    were read. The message now names the line, in ``convert``, a filter and a ``merge`` whose
    second input holds it."""
    from tests.cli.fresh import aldpat

    lines = [f"{512000 + i}.25 5403000.50 {300 + i % 7}.10 {i % 200}" for i in range(400)]
    good = tmp_path / "good.txt"
    good.write_text("x y z intensity\n" + "\n".join(lines) + "\n")
    bad = lines.copy()
    bad[250] = "512250.25 5403000.50 301.10 0.35"
    (tmp_path / "bad.txt").write_text("x y z intensity\n\n" + "\n".join(bad) + "\n")  # a blank line too
    for args in (["convert", "bad.txt", "--out-format", "laz"], ["filter", "pm", "bad.txt", "--out-format", "las"],
                 ["merge", "good.txt", "bad.txt", "-o", "m.laz"]):
        done = aldpat(*args, "--odir", "out", cwd=tmp_path) if args[0] != "merge" else aldpat(*args, cwd=tmp_path)
        assert done.returncode == 1
        assert "bad.txt:253: intensity = 0.35 cannot be stored in this LAS file" in done.stderr, done.stderr


def _extra_bytes_file(path, patch=None):
    """A LAS 1.4 point format 6 file with one ``conf`` extra-bytes dimension and a CRS, its Extra
    Bytes record (the first VLR) patched by ``patch(data, at)``."""
    import struct

    header = laspy.LasHeader(point_format=6, version="1.4")
    header.add_extra_dim(laspy.ExtraBytesParams(name="conf", type=np.uint8))
    header.add_crs(pyproj.CRS.from_epsg(32632))
    las = laspy.LasData(header)
    las.x, las.y, las.z = np.array([500000.0, 500001.0]), np.array([5e6, 5e6 + 1]), np.array([10.0, 11.0])
    las.conf = np.array([3, 4], np.uint8)
    las.write(path)
    data = bytearray(path.read_bytes())
    at = struct.unpack_from("<H", data, 94)[0]
    assert data[at + 2:at + 11] == b"LASF_Spec" and struct.unpack_from("<H", data, at + 18)[0] == 4
    if patch is not None:
        patch(data, at)
        path.write_bytes(bytes(data))
    return path


@pytest.mark.parametrize("patch, refused", [
    (lambda d, at: d.__setitem__(at + 54 + 2, 99), "gives its dimension 1 the reserved data type 99"),
    (lambda d, at: d.__setitem__(slice(at + 56, at + 58), b"\0\0"), "gives its dimension 1 undocumented extra bytes of no size"),
    (lambda d, at: d.__setitem__(slice(at + 20, at + 22), (100).to_bytes(2, "little")),
     "is 100 bytes long, not a whole number of 192-byte dimension descriptions"),
])
def test_a_malformed_extra_bytes_record_is_refused_in_one_line(tmp_path, patch, refused):
    """A reserved data type gave "truncated or corrupt LAS/LAZ (99)", a type 0 of no size laspy's
    "integer division or modulo by zero"; a record 100 bytes long was read on, every record after
    it shifted: the CRS lost without a word, and a filter's output held two Extra Bytes records."""
    path = _extra_bytes_file(tmp_path / "bad.las", patch)
    with pytest.raises(InputFormatError, match=f"variable length record 1, the Extra Bytes record, {refused}"):
        open_points(path)
    sound = open_points(_extra_bytes_file(tmp_path / "ok.las"))
    assert "conf" in sound.header.point_format.extra_dimension_names and sound.crs.to_epsg() == 32632
    # undocumented bytes of a size (type 0, options 1) are a dimension laspy lays out
    one = open_points(_extra_bytes_file(tmp_path / "one.las", lambda d, at: d.__setitem__(slice(at + 56, at + 58),
                                                                                          b"\0\1")))
    assert len(one.read()) == 2
