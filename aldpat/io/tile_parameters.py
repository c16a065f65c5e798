"""``tile_parameter.txt``: the tile index ALDPAT task 7 writes and task 9 reads.

ALDPAT 1.0 user manual (2007), task 7 "Tile Strips" (Fig. 8): one row per tile, ``path min_x
max_x min_y max_y width height buffer``, space or comma separated; the core of each tile (without
its buffer). One reader and one writer, with one set of rules: a path may hold spaces (comma or
tab rows split on that delimiter, others on the last seven runs of white space), header lines
before the first row are skipped, any other line that is not a row is an error naming it.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from aldpat.core.grid_extent import GridSpec, from_bounds
from aldpat.errors import DataError, InputFormatError, InputMissingError
from aldpat.io.atomic import atomic_output
from aldpat.io.text import MAX_COORDINATE
from aldpat.io.toml import MAX_SIDE_FILE_BYTES, read_limited

#: The file's name in the tile folder.
PARAMETER_FILE = "tile_parameter.txt"


def number_text(v: float) -> str:
    """A coordinate for a file name or the parameter file: no trailing zeros (512000, 512000.5),
    and exact -- read back, it is ``v`` itself -- so that a tile's core read from the file holds
    exactly the points ``aldpat tile`` put in it."""
    text = f"{v:.3f}"
    if float(text) != v:
        text = repr(float(v))
    if "." in text and "e" not in text:
        text = text.rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text



@dataclass(frozen=True)
class TileRow:
    """One row of ``tile_parameter.txt`` (manual task 7, Fig. 8)."""

    path: Path
    minx: float
    maxx: float
    miny: float
    maxy: float
    width: float
    height: float
    buffer: float
    line: int

    def grid(self, cell: float) -> GridSpec:
        return from_bounds(self.minx, self.miny, self.maxx, self.maxy, cell)


def _parse_row(text: str) -> tuple[str, list[float]] | None:
    """Split a row into its path and seven numbers; None for a header line.

    The path may hold spaces: comma- or tab-separated rows split on that delimiter, others on
    the last seven runs of white space.
    """
    if "," in text:
        parts = [p.strip() for p in text.rsplit(",", 7)]
    elif "\t" in text:
        parts = [p.strip() for p in text.rsplit("\t", 7)]
    else:
        parts = text.rsplit(None, 7)
    if len(parts) != 8:
        return None
    try:
        numbers = [float(p) for p in parts[1:]]
    except ValueError:
        return None
    return parts[0].strip().strip('"'), numbers


def _rows(path: Path) -> Iterator[tuple[str, list[float], int]]:
    """(path as written, seven numbers, line number) of every row; header lines before the first
    row are skipped, any other line that is not a row is an error naming it."""
    if not path.is_file():
        raise InputMissingError("no such tile parameter file", path=path)
    seen = False
    try:
        lines = read_limited(path, MAX_SIDE_FILE_BYTES, what="tile parameter file", errors="replace").splitlines()
    except OSError as exc:
        raise InputMissingError(f"cannot read: {(exc.strerror or str(exc)).lower()}", path=path) from None
    for number, raw in enumerate(lines, start=1):
        text = raw.strip()
        if not text or text.startswith("#"):
            continue
        parsed = _parse_row(text)
        if parsed is None:
            if seen:
                raise InputFormatError(
                    "expected: path, min x, max x, min y, max y, width, height, buffer", path=path, line=number)
            continue  # header line
        seen = True
        yield parsed[0], parsed[1], number




def read_tile_parameters(path: str | Path) -> list[TileRow]:
    """All tile rows; relative tile paths are taken from the parameter file's folder."""
    path = Path(path)
    rows: list[TileRow] = []
    for name, numbers, number in _rows(path):
        minx, maxx, miny, maxy, width, height, buffer = numbers
        if not all(abs(v) <= MAX_COORDINATE for v in numbers):  # NaN too
            raise InputFormatError("a number of the row is not a coordinate or a size (NaN, infinite, or beyond "
                                   f"+-{MAX_COORDINATE:g})", path=path, line=number)
        if not (width > 0 and height > 0 and buffer >= 0):
            raise InputFormatError(f"tile width {width:g} and height {height:g} must be positive, buffer {buffer:g} "
                                   "at least 0", path=path, line=number)
        if maxx <= minx or maxy <= miny:
            raise InputFormatError(f"tile range is empty ({minx:g}..{maxx:g}, {miny:g}..{maxy:g})",
                                   path=path, line=number)
        tile = Path(name.replace("\\", "/"))
        if not tile.is_absolute():
            tile = path.parent / tile
        rows.append(TileRow(tile, minx, maxx, miny, maxy, width, height, buffer, number))
    if not rows:
        raise InputFormatError("no tile rows", path=path)
    return rows


def read_parameter_rows(path: Path) -> dict[str, tuple[float, ...]]:
    """The rows as written (tile path as text -> its seven numbers), for ``aldpat tile --append``,
    which rewrites the file with its own rows added."""
    return {name: tuple(numbers) for name, numbers, _ in _rows(Path(path))}


def write_parameter_file(path: Path, rows: dict[str, tuple], *, delimiter: str, overwrite: bool) -> None:
    """Rows sorted by min y, then min x (the manual's Fig. 8 order), written whole or not at all."""
    delim = " " if delimiter == "space" else ","
    order = sorted(rows, key=lambda p: (rows[p][2], rows[p][0], p))
    with atomic_output(path, overwrite=overwrite) as tmp, open(tmp, "w", encoding="utf-8", newline="\n") as fh:
        fh.writelines(delim.join([name] + [number_text(v) for v in rows[name]]) + "\n" for name in order)


def tile_row_for(params_path: str | Path, input_path: str | Path) -> TileRow:
    """The row of ``params_path`` describing ``input_path``.

    Matched by path, then by file name, then by stem; a filtered tile (``tile_1_2_gapm.txt``)
    matches its tile (``tile_1_2.txt``) through the longest row stem it starts with followed by
    ``_``, because task 9 grids the filter's output of task 8.
    """
    return row_for(read_tile_parameters(params_path), input_path, params_path)


def row_for(rows: list[TileRow], input_path: str | Path, params_path: str | Path) -> TileRow:
    """The row of ``rows`` (read from ``params_path``) describing ``input_path`` (see
    :func:`tile_row_for`)."""
    input_path = Path(input_path)
    target = input_path.resolve()
    for row in rows:
        if row.path.resolve() == target:
            return row
    for key in (lambda p: p.name.lower(), lambda p: p.stem.lower()):
        hits = [r for r in rows if key(r.path) == key(input_path)]
        if hits:
            return hits[0]
    stem = input_path.stem.lower()
    prefixed = [r for r in rows if stem.startswith(r.path.stem.lower() + "_")]
    if prefixed:
        return max(prefixed, key=lambda r: len(r.path.stem))
    raise DataError(f"no row for {input_path.name} in tile parameter file {params_path}", path=input_path)
