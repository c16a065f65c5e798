import numpy as np
import pytest

from aldpat.errors import InputFormatError
from aldpat.io.registry import open_points, write_points
from aldpat.io.text import ALTM_FIRST_LAST, ALTM_LAST_FIRST, TextReader
from tests.conftest import write_xyz

XYZI = np.array([[512203.97, 5403685.49, 336.41, 1], [512204.13, 5403685.25, 333.12, 0],
                 [512204.12, 5403684.39, 333.2, 7]])


@pytest.mark.parametrize("delimiter, name", [(" ", "space"), ("\t", "tab"), (",", "comma"), ("   ", "spaces")])
@pytest.mark.parametrize("newline", ["\n", "\r\n"])
def test_delimiters_and_line_endings_are_detected(tmp_path, delimiter, name, newline):
    p = write_xyz(tmp_path / "a.txt", XYZI, delimiter=delimiter, newline=newline)
    t = open_points(p).read()
    assert t.names == ("x", "y", "z", "intensity")
    np.testing.assert_array_equal(np.column_stack([t.x, t.y, t.z, t["intensity"]]), XYZI)


def test_header_lines_are_skipped_and_decimals_kept(tmp_path):
    p = write_xyz(tmp_path / "a.csv", XYZI, delimiter=",", header="X,Y,Z,Intensity")
    r = open_points(p)
    assert r.header_lines == 1 and r.decimals["x"] == 2
    out = tmp_path / "b.txt"
    with write_points(out, r.names, like=r) as w:
        for c in r.chunks(size=2):  # several chunks
            w.write(c)
    assert out.read_text().splitlines() == ["512203.97 5403685.49 336.41 1", "512204.13 5403685.25 333.12 0",
                                            "512204.12 5403684.39 333.20 7"]


def test_chunks_cover_the_file_in_order(tmp_path):
    xyz = np.column_stack([np.arange(1000.0), np.arange(1000.0) * 2, np.arange(1000.0) % 7])
    p = write_xyz(tmp_path / "a.xyz", xyz)
    chunks = list(open_points(p).chunks(size=300))
    assert [len(c) for c in chunks] == [300, 300, 300, 100]
    np.testing.assert_array_equal(np.concatenate([c.x for c in chunks]), xyz[:, 0])


@pytest.mark.parametrize("content, line, message", [
    ("1 2 3\n4 5 6\n7 8\n", 3, "expected 3 columns, found 2"),
    ("1 2 3\n4 5 6 7\n", 2, "expected 3 columns, found 4"),
    ("1 2 3\n4 abc 6\n", 2, "not a number: 'abc'"),
    ("x y z\n1 2 3\n\n4 5 nan\n", 4, "non-finite value 'nan'"),
    ("1 2 3\n4 5 inf\n", 2, "non-finite value 'inf'"),
    ("1 2 abc\n", 1, "not a number: 'abc'"),
    # Python's float takes these, pandas' reader does not: said by pandas, without the line
    ("1 2 3\n4 1_000 6\n", 2, "not a number: '1_000'"),
    ("1 2 3\n4 5 \u0666\n", 2, "not a number: '\u0666'"),
])
def test_bad_lines_are_reported_with_file_and_line(tmp_path, content, line, message):
    p = tmp_path / "bad.txt"
    p.write_text(content)
    with pytest.raises(InputFormatError) as err:
        open_points(p).read()
    assert err.value.line == line
    assert str(err.value) == f"{p}:{line}: {message}"


def test_bad_line_far_into_a_file_is_found_in_a_later_chunk(tmp_path):
    rows = "\n".join(f"{k} {k} {k}" for k in range(5000))
    p = tmp_path / "big.txt"
    p.write_text("x y z\n" + rows + "\n1 2 x\n")
    with pytest.raises(InputFormatError, match=r"big.txt:5002: not a number: 'x'"):
        for _ in open_points(p).chunks(size=1000):
            pass


@pytest.mark.parametrize("content, message", [("", "file is empty"), ("\n\n", "file is empty"),
                                              ("x y z\n", "no numeric point lines found")])
def test_empty_files(tmp_path, content, message):
    p = tmp_path / "e.txt"
    p.write_text(content)
    with pytest.raises(InputFormatError, match=message):
        open_points(p).read()


ROWS = "".join(f"{k}.5 {2 * k}.25 {k % 7}.1\n" for k in range(50))


@pytest.mark.parametrize("content, message", [
    (ROWS.encode("utf-16"), "UTF-16 text (as Windows PowerShell's > writes): save it as ASCII or UTF-8"),
    (ROWS.encode("utf-16-be"), "UTF-16 text"),
    (b"LASF" + bytes(300), "a LAS/LAZ file with a text file's name: name it .las or .laz, or give --format las"),
    (ROWS.replace(" ", ";").encode(), "no numeric point lines found (fields separated by ';': aldpat reads spaces"),
    (b"1 2 3\n\x00\x01\x02", "not a text file (binary bytes)"),
])
def test_files_that_are_not_text_points_say_what_they_are(tmp_path, content, message):
    p = tmp_path / "points.txt"
    p.write_bytes(content)
    with pytest.raises(InputFormatError) as err:
        open_points(p).read()
    assert message in str(err.value)


@pytest.mark.parametrize("order, names", [("last-first", ALTM_LAST_FIRST), ("first-last", ALTM_FIRST_LAST)])
def test_altm_nine_columns_in_both_orders(tmp_path, order, names):
    row = np.array([[100.5, 1.0, 2.0, 3.0, 4, 5.0, 6.0, 7.0, 8]])
    p = write_xyz(tmp_path / "tape.txt", row)
    t = open_points(p, layout="altm9", order=order).read()
    assert t.names == names
    assert t["t"][0] == 100.5
    first = [t[n][0] for n in ("x1", "y1", "z1", "i1")]
    assert first == ([5.0, 6.0, 7.0, 8] if order == "last-first" else [1.0, 2.0, 3.0, 4])


def test_altm_layout_needs_nine_columns(tmp_path):
    p = write_xyz(tmp_path / "tape.txt", XYZI)
    with pytest.raises(InputFormatError, match="expected 9 columns"):
        open_points(p, layout="altm9")


def test_irregular_spacing_after_the_sniffed_lines_is_still_read(tmp_path):
    clean = "\n".join(f"{k} {k + 1} {k + 2}" for k in range(5000))
    p = tmp_path / "late.txt"
    p.write_text(clean + "\n\n7  8\t9\n 10 11 12 \n13 14 15\n")
    r = open_points(p)
    assert r._single_space  # the sniffed head is plain single-spaced
    chunks = list(r.chunks(size=700))
    z = np.concatenate([c.z for c in chunks])
    assert len(z) == 5003 and list(z[-3:]) == [9.0, 12.0, 15.0]
    np.testing.assert_array_equal(z[:5000], np.arange(5000) + 2)


def test_a_byte_order_mark_is_not_a_header(tmp_path):
    path = tmp_path / "bom.txt"
    path.write_bytes(b"\xef\xbb\xbf1.5 2 3\n4 5 6\n7 8 10\n")
    table = TextReader(path).read()
    assert len(table) == 3 and table["x"][0] == 1.5


def test_latin1_header_and_tabs_mixed_with_spaces(tmp_path):
    path = tmp_path / "lat.txt"
    path.write_bytes(b"X Y Z (\xb0C)\n1 2\t3\n4\t 5  6\n")
    table = TextReader(path).read()
    assert table["z"].tolist() == [3.0, 6.0]


def test_an_implausible_coordinate_is_a_bad_line(tmp_path):
    path = tmp_path / "huge.txt"
    path.write_text("1 2 3\n4 5 1e300\n")
    with pytest.raises(InputFormatError, match=r"huge.txt:2: z = 1e300 is not a plausible coordinate"):
        TextReader(path).read()


def test_a_binary_file_named_txt(tmp_path):
    path = tmp_path / "points.txt"
    path.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(InputFormatError, match="not a text file"):
        TextReader(path).read()


def _written_again(src, tmp_path) -> str:
    reader = open_points(src)
    out = tmp_path / "again.txt"
    with write_points(out, reader.names, like=reader) as w:
        for chunk in reader.chunks():
            w.write(chunk)
    return out.read_text()


def test_numbers_in_exponent_form_are_written_again_with_the_decimals_their_values_need(tmp_path):
    """numpy's savetxt writes 300.789 as 3.007889999999999873e+02: counted as no decimals, every
    point was written again to whole metres (300.789 -> 301)."""
    src = tmp_path / "sci.txt"
    np.savetxt(src, np.array([[512000.123, 5403000.456, 300.789], [512001.5, 5403001.25, 301.125]]))
    assert _written_again(src, tmp_path) == ("512000.123 5403000.456 300.789\n"
                                             "512001.500 5403001.250 301.125\n")


def test_an_intensity_with_decimals_keeps_them(tmp_path):
    """A reflectance of 0.35 in the intensity column was written again as 0 ("%d")."""
    src = tmp_path / "refl.txt"
    src.write_text("1 2 3 0.35\n2 3 4 12.5\n")
    assert _written_again(src, tmp_path) == "1 2 3 0.35\n2 3 4 12.50\n"
    whole = tmp_path / "whole" / "whole.txt"
    whole.parent.mkdir()
    whole.write_text("1 2 3 35.00\n2 3 4 500\n")
    assert _written_again(whole, whole.parent) == "1 2 3 35\n2 3 4 500\n"  # whole numbers stay whole


def test_more_decimals_further_down_than_in_the_first_lines_are_kept(tmp_path):
    """The decimals are read from the first 200 lines; Python's ``print`` writes 100.5 there and
    512.125 further down, which was written again as 512.1."""
    src = tmp_path / "mixed.txt"
    src.write_text("".join(f"{100 + k * 0.5} {200 + k * 0.5} {10 + k * 0.5}\n" for k in range(250))
                   + "512.125 300.0625 12.3456\n")
    reader = open_points(src)
    assert [reader.decimals[n] for n in "xyz"] == [1, 1, 1]
    out = tmp_path / "again.txt"
    with write_points(out, reader.names, like=reader) as w:
        for chunk in reader.chunks(size=100):
            w.write(chunk)
    lines = out.read_text().splitlines()
    assert lines[0] == "100.0 200.0 10.0" and lines[-1] == "512.125 300.0625 12.3456"
    assert [reader.decimals[n] for n in "xyz"] == [3, 4, 4]


def test_a_leica_pts_files_point_count_line_is_not_a_point(tmp_path):
    """A Leica PTS file opens with its number of points alone on a line; it was read as a point of
    one column ("expected at least 3 columns"). In a ``.pts`` file that line is skipped; in any
    other text file a line of one number is still a bad point line, not a header."""
    rows = "512799.85 5403502.13 303.46 -1024 120 130 140\n512799.84 5403508.18 303.40 -1024 120 130 140\n"
    pts = tmp_path / "scan.pts"
    pts.write_text("2\n" + rows)
    reader = open_points(pts)
    table = reader.read()
    assert reader.header_lines == 1 and len(table) == 2 and table["z"].tolist() == [303.46, 303.40]
    other = tmp_path / "scan.txt"
    other.write_text("2\n" + rows)
    with pytest.raises(InputFormatError, match="found 1"):
        open_points(other).read()


def test_the_line_holding_a_value_counts_header_and_blank_lines(tmp_path):
    path = tmp_path / "a.txt"
    path.write_text("x y z i\n1 2 3 4\n\n5 6 7 0.35\n8 9 10 0.35\n")
    reader = TextReader(path)
    assert reader.line_holding("intensity", 0.35) == 4  # the first of two
    assert reader.line_holding("intensity", 0.5) is None  # a value computed on the way: no line holds it
    assert reader.line_holding("classification", 2.0) is None  # no such column


def test_a_comma_closing_each_line_ends_its_values(tmp_path):
    """A spreadsheet's or a vendor's CSV export that closes each line with a comma was refused at
    its first point ("not a number: ''"). One closing comma now ends a line's values, on lines
    that have it and lines that do not; an empty value inside a line and a value after the last
    column are still refused with their line."""
    path = tmp_path / "export.csv"
    path.write_text("x,y,z,intensity,\n512799.85,5403502.13,303.46,120,\n512799.84,5403508.18,303.40,130\n"
                    "512799.90,5403509.00,303.50,140 ,\n")
    table = open_points(path).read()
    assert table["z"].tolist() == [303.46, 303.40, 303.50] and table["intensity"].tolist() == [120, 130, 140]
    for body, line, said in (("1,2,3,4,\n5,,7,8,\n", 2, "not a number: ''"),
                             ("1,2,3,4,\n5,6,7,8,9\n", 2, "expected 4 columns, found 5")):
        bad = tmp_path / "bad.csv"
        bad.write_text(body)
        with pytest.raises(InputFormatError, match=said) as caught:
            open_points(bad).read()
        assert caught.value.line == line


@pytest.mark.parametrize("body", ["513866,46\t5403124,79\t310,77\t0\n", "513866,46;5403124,79;310,77;0\n",
                                  "X Y Z\n513866,46 5403124,79 310,77\n"])
def test_decimal_commas_are_named_as_such(tmp_path, body):
    """A locale's export writing 513866,46 was refused as "not a number: '46\\t5403124'", a value
    the file never holds; it is now named for what it is, with its line. Whole numbers separated
    by spaces and commas between values stay points."""
    path = tmp_path / "comma.txt"
    path.write_text(body * 3)
    with pytest.raises(InputFormatError, match=r"decimal commas \('513866,46'\): aldpat reads '\.' as") as caught:
        open_points(path).read()
    assert caught.value.line == (2 if body.startswith("X") else 1)
    for fine in ("513866 5403124 310\n" * 3, "513866,5403124,310\n" * 3):
        path.write_text(fine)
        assert open_points(path).read()["z"].tolist() == [310, 310, 310]
