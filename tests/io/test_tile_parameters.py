"""tile_parameter.txt: one reader and one writer with one set of rules, for ``tile --append``
(which rewrites the file) and for ``grid --tile-params`` (which looks a tile up in it)."""

from __future__ import annotations

import pytest

from aldpat.errors import InputFormatError
from aldpat.io.tile_parameters import read_parameter_rows, read_tile_parameters, write_parameter_file

ROWS = {
    "tiles/tile_0_0.txt": (0.0, 100.0, 0.0, 100.0, 100.0, 100.0, 5.0),
    "my tiles/tile_100_0.txt": (100.0, 200.0, 0.0, 100.0, 100.0, 100.0, 5.0),
    "tiles/tile_0_100.txt": (0.0, 100.0, 100.0, 200.0, 100.0, 100.0, 5.0),
}


@pytest.mark.parametrize("delimiter", ["space", "comma"])
def test_written_rows_read_back_alike_by_both_readers(tmp_path, delimiter):
    path = tmp_path / "tile_parameter.txt"
    write_parameter_file(path, ROWS, delimiter=delimiter, overwrite=False)
    lines = path.read_text().splitlines()
    assert [ln.split("tile_")[1][:5] for ln in lines] == ["0_0.t", "100_0", "0_100"]  # by min y, then min x
    assert read_parameter_rows(path) == ROWS  # a path with a space survives either delimiter
    rows = read_tile_parameters(path)
    assert [(r.path, r.minx, r.miny, r.buffer) for r in rows] == [  # ROWS is in file order already
        (tmp_path / name, numbers[0], numbers[2], numbers[6]) for name, numbers in ROWS.items()]


def test_append_refuses_a_damaged_file_instead_of_dropping_its_rows(tmp_path):
    path = tmp_path / "tile_parameter.txt"
    path.write_text("path minx maxx miny maxy width height buffer\n"  # a header line is skipped
                    "tiles/a.txt 0 100 0 100 100 100 5\n"
                    "tiles/b.txt 100 200 0 100 100 100\n")
    with pytest.raises(InputFormatError) as err:
        read_parameter_rows(path)
    assert err.value.line == 3 and "expected: path, min x" in str(err.value)
