"""polygon-extract (manual: Extract Points by Polygon): text and shapefile polygons, --outside."""

import numpy as np
import pytest

from aldpat.errors import ParamError
from aldpat.io.shapefile import Polygon, write_polygons
from aldpat.tasks import get_task

# U-shaped (concave) polygon; the notch 2 < x < 4, y > 2 is outside
U = [(0, 0), (6, 0), (6, 6), (4, 6), (4, 2), (2, 2), (2, 6), (0, 6)]
PTS = np.array([[1, 1, 10], [1, 5, 11], [3, 1, 12], [3, 4, 13], [5, 5, 14], [7, 3, 15], [-1, 3, 16]], float)
IN = [0, 1, 2, 4]


@pytest.fixture
def points(tmp_path):
    src = tmp_path / "p.txt"
    np.savetxt(src, PTS, fmt="%.2f")
    return src


@pytest.mark.parametrize("style", ["comma", "space-closed-reversed", "header-crlf"])
def test_text_polygons(tmp_path, points, style):
    verts = U
    if style == "space-closed-reversed":
        verts = U[::-1] + [U[::-1][0]]
    sep = ", " if style != "space-closed-reversed" else " "
    text = "\n".join(f"{x}{sep}{y}" for x, y in verts) + "\n"
    if style == "header-crlf":
        text = "x,y\r\n" + text.replace("\n", "\r\n")
    poly = tmp_path / "poly.txt"
    poly.write_bytes(text.encode())
    assert get_task("polygon-extract")([points], polygon=str(poly)).exit_code == 0
    assert np.array_equal(np.loadtxt(tmp_path / "p_poly.txt"), PTS[IN])
    assert get_task("polygon-extract")([points], polygon=str(poly), outside=True, overwrite=True).exit_code == 0
    assert np.array_equal(np.loadtxt(tmp_path / "p_poly.txt"), PTS[[3, 5, 6]])


def test_shapefile_with_several_polygons_and_a_hole(tmp_path):
    pts = np.array([[1, 1, 1], [5, 5, 2], [8, 8, 3], [25, 1, 4], [15, 5, 5]], float)
    src = tmp_path / "p.txt"
    np.savetxt(src, pts, fmt="%.2f")
    outer = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], float)
    hole = np.array([[3, 3], [7, 3], [7, 7], [3, 7]], float)
    tri = np.array([[20, 0], [30, 0], [30, 5]], float)
    write_polygons(tmp_path / "areas.shp", [Polygon([outer, hole], (1,)), Polygon([tri], (2,))],
                   [("id", "N", 5, 0)])
    assert get_task("polygon-extract")([src], polygon=str(tmp_path / "areas.shp")).exit_code == 0
    assert np.loadtxt(tmp_path / "p_poly.txt")[:, 2].tolist() == [1, 3, 4]


@pytest.mark.parametrize("field, value", [("parts", 2**31 - 1), ("points", 2**31 - 1)])
def test_a_shapefile_record_claiming_more_than_it_holds_is_named(tmp_path, points, field, value):
    """A polygon record's count of parts or points past its bytes: one line naming the file and
    the shape (pyshp's own error escaped as an internal error)."""
    import struct

    ring = np.array([[0, 0], [6, 0], [6, 6], [0, 6]], float)
    write_polygons(tmp_path / "a.shp", [Polygon([ring], (1,))], [("id", "N", 5, 0)])
    data = bytearray((tmp_path / "a.shp").read_bytes())
    # the first record: its 8-byte header at 100, shape type, 32 bytes of box, then parts and points
    struct.pack_into("<i", data, 100 + 8 + 4 + 32 + (4 if field == "points" else 0), value)
    (tmp_path / "a.shp").write_bytes(bytes(data))
    report = get_task("polygon-extract")([points], polygon=str(tmp_path / "a.shp"))
    assert report.exit_code == 1
    assert "a.shp: shape 1 is damaged: " in report.results[0].error, report.results[0].error


def test_bad_polygon_files(tmp_path, points):
    bad = tmp_path / "bad.txt"
    bad.write_text("0,0\n1,0\nfoo,bar\n")
    report = get_task("polygon-extract")([points], polygon=str(bad))
    assert report.exit_code == 1 and "bad.txt:3" in report.results[0].error
    two = tmp_path / "two.txt"
    two.write_text("0,0\n1,0\n0,0\n")
    assert "at least 3" in get_task("polygon-extract")([points], polygon=str(two)).results[0].error
    with pytest.raises(ParamError, match=r"polygon: required \(--polygon"):
        get_task("polygon-extract")([points])


@pytest.mark.parametrize("first, second, message", [
    # a first vertex with a typo was skipped as a header line: the polygon lost a corner, exit 0
    ("0,6O", "6,0", "bad.txt:1: expected x,y numbers, got '0,6O'"),
    ("0,0", "nan,0", "bad.txt:2: vertex nan,0 is not a plausible coordinate"),
    ("0,0", "1e300,0", "bad.txt:2: vertex 1e300,0 is not a plausible coordinate"),
])
def test_a_polygon_vertex_that_is_no_coordinate_is_named(tmp_path, points, first, second, message):
    bad = tmp_path / "bad.txt"
    bad.write_text(f"{first}\n{second}\n6,6\n0,6\n")
    report = get_task("polygon-extract")([points], polygon=str(bad))
    assert report.exit_code == 1 and message in report.results[0].error, report.results[0].error
    assert not (tmp_path / "p_poly.txt").exists()


def test_a_header_line_of_words_and_a_year_is_still_a_header(tmp_path, points):
    poly = tmp_path / "poly.txt"
    poly.write_text("# the survey of 2007\n" + "\n".join(f"{x},{y}" for x, y in U) + "\n")
    assert get_task("polygon-extract")([points], polygon=str(poly)).exit_code == 0
    assert np.array_equal(np.loadtxt(tmp_path / "p_poly.txt"), PTS[IN])


def test_streams_las_and_keeps_attributes(tmp_path):
    from pathlib import Path

    import laspy

    src = Path(__file__).resolve().parents[1] / "data" / "fsite5_strip.laz"
    poly = tmp_path / "square.txt"
    poly.write_text("494300,5420350\n494400,5420350\n494400,5420450\n494300,5420450\n")
    assert get_task("polygon-extract")([src], polygon=str(poly), odir=str(tmp_path)).exit_code == 0
    out = laspy.read(tmp_path / "fsite5_strip_poly.laz")
    full = laspy.read(src)
    x, y = np.asarray(full.x), np.asarray(full.y)
    expected = (x > 494300) & (x < 494400) & (y > 5420350) & (y < 5420450)
    assert len(out.points) == int(expected.sum())
    assert np.array_equal(np.asarray(out.intensity), np.asarray(full.intensity)[expected])
