"""Byte-for-byte copying of text records in step with the parser (aldpat.io.rawtext)."""

import numpy as np

from aldpat.io.rawtext import RawLines, passthrough_ok
from aldpat.io.text import TextReader
from aldpat.tasks import get_task

TEXT = "x y z\r\n1.5 2 3\r\n\r\n   \r\n 4 5 6.25\r\n7 8 9\r\n\t\r\n10 11 12"


def test_lines_skip_header_and_blank_lines_like_the_parser(tmp_path):
    path = tmp_path / "p.txt"
    path.write_bytes(TEXT.encode())
    reader = TextReader(path)
    chunks = list(reader.chunks(size=2))
    with RawLines(path, reader.header_lines) as raw:
        got = [raw.take(len(c)) for c in chunks]
    assert [len(g) for g in got] == [2, 2]
    assert all(g.in_step_with(c.x) for g, c in zip(got, chunks, strict=False))
    assert got[0].gather(np.array([True, True])) == b"1.5 2 3\r\n 4 5 6.25\r\n"
    assert got[0].gather(np.array([1])) == b" 4 5 6.25\r\n"
    assert got[1].gather(np.array([False, True])) == b"10 11 12\n"  # a newline ends the last line
    # consecutive lines as they are (a blank line between them may stay or go: it holds nothing)
    assert got[1].gather(slice(0, 2)) in (b"7 8 9\r\n\t\r\n10 11 12\n", b"7 8 9\r\n10 11 12\n")


def test_a_parser_mismatch_is_detected(tmp_path):
    path = tmp_path / "p.txt"
    path.write_bytes(TEXT.encode())
    reader = TextReader(path)
    chunk = next(reader.chunks(size=2))
    with RawLines(path, 0) as raw:  # wrong header count: the header line comes out as data
        assert not raw.take(2).in_step_with(chunk.x)


def test_passthrough_only_when_nothing_would_change(tmp_path):
    path = tmp_path / "p.txt"
    path.write_text("1 2 3 4\n5 6 7 8\n")
    reader = TextReader(path)
    assert passthrough_ok(reader, reader.names, "space", ".txt")
    assert not passthrough_ok(reader, ("x", "y", "z"), "space", ".txt")
    assert not passthrough_ok(reader, reader.names, "comma", ".txt")
    assert not passthrough_ok(reader, reader.names, "space", ".laz")


def test_copied_and_formatted_outputs_agree(tmp_path):
    rng = np.random.default_rng(4)
    pts = np.column_stack([rng.uniform(0, 100, 3000), rng.uniform(0, 100, 3000), rng.uniform(0, 9, 3000),
                           rng.integers(0, 9, 3000)])
    src = tmp_path / "p.txt"
    np.savetxt(src, pts, fmt="%.3f %.3f %.2f %d")
    poly = tmp_path / "tri.txt"
    poly.write_text("10,10\n90,20\n40,95\n")
    get_task("polygon-extract")([src], polygon=str(poly), odir=str(tmp_path / "a"))
    get_task("polygon-extract")([src], polygon=str(poly), odir=str(tmp_path / "b"), delimiter="comma")
    a = (tmp_path / "a" / "p_poly.txt").read_text()
    b = (tmp_path / "b" / "p_poly.txt").read_text()
    assert a.replace(" ", ",") == b  # copied lines (space) = formatted lines (comma), decimals kept
    get_task("tile")([src], width=30, height=30, buffer=3, odir=str(tmp_path / "ta"))
    get_task("tile")([src], width=30, height=30, buffer=3, odir=str(tmp_path / "tb"), delimiter="comma")
    for p in (tmp_path / "ta").glob("tile_*_*.txt"):
        assert p.read_text().replace(" ", ",") == (tmp_path / "tb" / p.name).read_text()
