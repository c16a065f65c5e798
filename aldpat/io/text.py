"""ASCII point files: ``x y z [intensity]`` and the ALTM 9-column tape layout.

Reading uses pandas' C tokenizer in chunks: about ten times the pace of ``numpy.loadtxt`` and
flat memory whatever the file size (see bench/bench_io.py). The delimiter (space, tab, comma)
is detected per file from its first data line; CRLF endings, leading non-numeric header lines and
the point count that opens a Leica PTS file (``.pts``) are accepted. A bad line stops that file with a message naming the file and its line number.

Writing formats each chunk with one C-level ``%`` operation and keeps the number of decimals
the input had (detected from its first lines), so a round trip does not change coordinates.
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from aldpat.core import units
from aldpat.errors import InputFormatError, shown
from aldpat.io.table import PointTable
from aldpat.io.textfmt import BLOCK_ROWS, COORDINATE_DECIMALS, column_formats, decimal_places, format_block, whole_at

#: The ALTM tape / strip layout in the manual's default order (last return first).
ALTM_LAST_FIRST = ("t", "x2", "y2", "z2", "i2", "x1", "y1", "z1", "i1")
ALTM_FIRST_LAST = ("t", "x1", "y1", "z1", "i1", "x2", "y2", "z2", "i2")
POINT_NAMES = ("x", "y", "z", "intensity")

DEFAULT_CHUNK = 2_000_000
#: Largest magnitude accepted for a coordinate (x, y, z of any return). Real coordinates in any
#: projected or geographic CRS are below 1e8; a value like 1e300 is a corrupt line, and taken
#: for a coordinate it would ask for grids of more cells than any machine holds.
MAX_COORDINATE = 1e12
COORDINATE_COLUMNS = frozenset({"x", "y", "z", "x1", "y1", "z1", "x2", "y2", "z2"})
_SNIFF_BYTES = 1 << 16
#: The first line of a Leica PTS file (``.pts``): the number of points that follow, alone.
_COUNT_LINE = re.compile(r"\s*\d+\s*")
#: The longest line read (bytes): a point line is tens of characters, a header line hundreds; a
#: longer one (a file of one 4 MB line) is not a point file, and reading it whole as a line
#: would hold it all in memory, and as a point all its numbers as columns.
LONGEST_LINE = _SNIFF_BYTES
#: The most columns a point line has (x y z and every attribute a LAS point holds, with room).
MOST_COLUMNS = 256
#: A number as the file's reader (pandas' C tokenizer) takes it: ASCII digits only. Python's
#: ``float`` also takes ``1_000`` and other scripts' digits (Arabic-Indic, full-width), which the
#: reader does not: a line of them was found by neither, and the message was pandas' own ("cannot
#: safely convert passed user dtype of float64 for object dtyped data in column 2"), without a line.
_NUMBER = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$|^[+-]?(nan|inf|infinity)$",
                     re.IGNORECASE | re.ASCII)
_DELIMS = {"comma": ",", "tab": "\t", "space": " "}
#: A UTF-8 byte-order mark, which some Windows editors put at the start of a text file.
UTF8_BOM = b"\xef\xbb\xbf"
#: How point text is decoded: a BOM is dropped, and a byte that is not UTF-8 (a Latin-1 degree
#: sign in a header line) stays one character, so line and column counts are kept.
TEXT_ENCODING = "utf-8-sig"
TEXT_ERRORS = "replace"


def altm_names(order: str) -> tuple[str, ...]:
    return ALTM_FIRST_LAST if order == "first-last" else ALTM_LAST_FIRST


class PulseDecimals(Mapping[str, int]):
    """The decimals of the points of a tape's pulses (x, y, z, intensity, t) from its reader's
    columns: a coordinate takes the more of its two returns' (x1 and x2 ...), an intensity none.
    A live view, read at every write: the reader widens its own decimals as it reads further
    down the tape, and a copy taken at the start would round what comes after."""

    NAMES = ("x", "y", "z", "intensity", "t")

    def __init__(self, columns: Mapping[str, int]) -> None:
        self._columns = columns

    def _value(self, name: str) -> int | None:
        if name == "intensity":
            return 0
        if name == "t":
            return self._columns.get("t")
        found = [self._columns[f"{name}{k}"] for k in (1, 2) if f"{name}{k}" in self._columns]
        return max(found) if found else None

    def __getitem__(self, name: str) -> int:
        value = self._value(name) if name in self.NAMES else None
        if value is None:
            raise KeyError(name)
        return value

    def __iter__(self) -> Iterator[str]:
        return (n for n in self.NAMES if self._value(n) is not None)

    def __len__(self) -> int:
        return sum(1 for _ in self)


def _split(line: str, delimiter: str) -> list[str]:
    if delimiter == ",":
        # one comma closing the line (spreadsheets and some vendors' exports write it) ends the
        # line's values, as pandas reads it; an empty value inside a line is still refused
        return [t.strip() for t in line.strip().removesuffix(",").split(",")]
    return line.split()


def _is_data(line: str, delimiter: str) -> bool:
    tokens = _split(line, delimiter)
    return bool(tokens) and all(_NUMBER.match(t) for t in tokens)


def _decimals(token: str) -> int:
    """The decimals a value's text has (kept when points are written again); for a number in
    exponent form, those its value needs: numpy's savetxt writes 300.789 as
    3.007889999999999873e+02, which counted as no decimals wrote every point to whole metres."""
    token = token.lower()
    if "e" in token:
        try:
            return decimal_places(float(token), COORDINATE_DECIMALS)
        except ValueError:
            return 0
    if "." not in token:
        return 0
    return len(token.split(".", 1)[1])


class TextReader:
    """Chunked reader of a delimited numeric text file.

    ``layout`` is ``"points"`` (columns named x y z intensity, further ones ``col5``...) or
    ``"altm9"`` (exactly nine columns named by ``order``).
    """

    format = "text"

    def __init__(self, path: str | Path, *, layout: str = "points", order: str = "last-first"):
        self.path = Path(path)
        self.layout = layout
        self.crs = None
        self.count = None  # unknown without reading
        self._sniff()
        if layout == "altm9":
            if self.ncols != 9:
                raise InputFormatError(
                    f"expected 9 columns (t x y z i x y z i), found {self.ncols}",
                    path=self.path, line=self.first_data_line)
            self.names = altm_names(order)
        else:
            if self.ncols < 3:
                raise InputFormatError(
                    f"expected at least 3 columns (x y z), found {self.ncols}",
                    path=self.path, line=self.first_data_line)
            self.names = tuple(POINT_NAMES[: min(self.ncols, 4)]) + tuple(
                f"col{k + 1}" for k in range(4, self.ncols))
        self.decimals = {n: d for n, d in zip(self.names, self._decimals, strict=False)}

    # -------------------------------------------------------------------------- sniffing
    def _sniff(self) -> None:
        try:
            with open(self.path, "rb") as fh:
                head = fh.read(_SNIFF_BYTES)
        except OSError as exc:
            from aldpat.errors import InputMissingError

            raise InputMissingError(f"cannot read: {exc.strerror or exc}", path=self.path) from None
        head = head.removeprefix(UTF8_BOM)  # not part of the first line: it would read as a header
        if not head.strip():
            raise InputFormatError("file is empty", path=self.path)
        if b"\x00" in head:
            raise InputFormatError(_binary_kind(head), path=self.path)
        text = head.decode("latin-1")
        lines = text.splitlines()
        if len(head) == _SNIFF_BYTES:
            if len(lines) <= 1:
                raise InputFormatError(f"line 1 is longer than {LONGEST_LINE:,} bytes: not a point file",
                                       path=self.path)
            lines = lines[:-1]  # the last one may be cut in the middle
        header = 0
        delimiter = None
        pts = self.path.suffix.lower() == ".pts"
        for number, line in enumerate(lines, start=1):
            if not line.strip():
                header += 1
                continue
            if pts and header == number - 1 and _COUNT_LINE.fullmatch(line):
                header += 1  # a Leica PTS file's first line: its number of points
                continue
            delimiter = "," if "," in line else ("\t" if "\t" in line and " " not in line.strip() else " ")
            if _is_data(line, delimiter):
                self.first_data_line: int = number
                break
            first = _split(line, delimiter)[0] if _split(line, delimiter) else ""
            if _DECIMAL_COMMAS.fullmatch(line.strip()):
                raise InputFormatError(f"decimal commas ({shown(line.split()[0].split(';')[0])}): aldpat reads '.' as "
                                       "the decimal mark; export the points with decimal points", path=self.path,
                                       line=number)
            if _NUMBER.match(first):
                # starts like a point but is not one: a bad line, not a header
                bad = next(t for t in _split(line, delimiter) if not _NUMBER.match(t))
                raise InputFormatError(f"not a number: {shown(bad)}", path=self.path, line=number)
            header += 1
            if header > 100:
                raise InputFormatError("no numeric point lines in the first 100 lines" + _semicolons(lines),
                                       path=self.path)
        else:
            raise InputFormatError("no numeric point lines found" + _semicolons(lines), path=self.path)
        self.header_lines = header
        self.delimiter = delimiter
        sample = [ln for ln in lines[header: header + 200] if ln.strip()]
        tokens = [_split(ln, delimiter) for ln in sample]
        self.ncols = len(tokens[0])
        if self.ncols > MOST_COLUMNS:
            raise InputFormatError(f"{self.ncols:,} columns: a point line has at most {MOST_COLUMNS}",
                                   path=self.path, line=self.first_data_line)
        # one plain space between values (the common case) parses twice as fast as any-whitespace
        # a comma closing the lines: pandas reads one more, empty, column, checked and dropped
        self._closing_comma = delimiter == "," and any(ln.rstrip().endswith(",") for ln in sample)
        self._single_space = delimiter == " " and all(
            ln == ln.strip() and "  " not in ln and "\t" not in ln for ln in sample)
        self._decimals = [
            max((_decimals(t[k]) for t in tokens if len(t) > k), default=0) for k in range(self.ncols)]

    def _widen_decimals(self, cols: dict[str, np.ndarray]) -> None:
        """Raise (in place: writers share the dict) a column's decimals where this chunk holds
        values that need more than the first lines showed, up to :data:`COORDINATE_DECIMALS`:
        Python's ``print`` writes 100.5 and, further down, 100.25, which was written again as
        100.2."""
        for name, col in cols.items():
            places = self.decimals.get(name, 0)
            while places < COORDINATE_DECIMALS and len(col) and not whole_at(col, places):
                places += 1
            if places > self.decimals.get(name, 0):
                self.decimals[name] = places

    # -------------------------------------------------------------------------- reading
    def chunks(self, size: int = DEFAULT_CHUNK) -> Iterator[PointTable]:
        """Yield :class:`PointTable` chunks of at most ``size`` rows, in file order."""
        import pandas as pd  # here, not at import: it costs a second of start-up to every command
        sep = "," if self.delimiter == "," else (" " if self._single_space else r"\s+")
        skip = self.header_lines
        rows_done = 0
        while True:
            try:
                for frame in self._frames(sep, skip, size):
                    # column by column: no interleaved copy of the whole frame
                    cols = {name: frame[k].to_numpy(dtype=np.float64) for k, name in enumerate(self.names)}
                    if self._closing_comma and frame[self.ncols].notna().any():
                        self._raise_at(rows_done + int(np.flatnonzero(frame[self.ncols].notna().to_numpy())[0]))
                    finite = np.ones(len(frame), dtype=bool)
                    for name, col in cols.items():
                        finite &= (np.abs(col) <= MAX_COORDINATE) if name in COORDINATE_COLUMNS \
                            else np.isfinite(col)
                    if not finite.all():
                        self._raise_at(rows_done + int(np.flatnonzero(~finite)[0]))
                    rows_done += len(frame)
                    self._widen_decimals(cols)
                    yield PointTable(cols, meta={"decimals": self.decimals})
                break
            except InputFormatError:
                raise
            except (ValueError, pd.errors.ParserError) as exc:
                if sep == " ":
                    # not single-spaced after all (a double space, a tab): go on from the same row
                    # with any-whitespace splitting
                    sep, skip = r"\s+", self._raw_lines_before(rows_done)
                    continue
                self._raise_at(rows_done, fallback=str(exc))
            except UnicodeDecodeError:
                self._raise_at(rows_done, fallback="not a text file")
        if rows_done == 0:
            raise InputFormatError("no points in file", path=self.path)

    def _frames(self, sep: str, skip: int, size: int) -> Iterator[Any]:
        """The numbers of the file in pandas frames of ``size`` rows (pandas' chunked reader)."""
        import pandas as pd

        nan = ["nan", "NaN", "NAN"]
        names = list(range(self.ncols + self._closing_comma))
        na_values = {k: nan if k < self.ncols else [""] for k in names}
        return pd.read_csv(
            self.path, sep=sep, header=None, names=names, dtype=np.float64,
            skiprows=skip, chunksize=size, engine="c", skip_blank_lines=True,
            na_filter=True, keep_default_na=False, na_values=na_values, index_col=False,
            encoding=TEXT_ENCODING, encoding_errors=TEXT_ERRORS,
        )

    def line_holding(self, column: str, value: float) -> int | None:
        """The number of the first line whose ``column`` is ``value`` (None: none is), for a
        message of a value found unusable after the points left this reader."""
        if column not in self.names:
            return None
        rows = 0
        for chunk in self.chunks():
            at = np.flatnonzero(chunk[column] == value)
            if at.size:
                return self._raw_lines_before(rows + int(at[0])) + 1
            rows += len(chunk)
        return None

    def _raw_lines_before(self, data_row: int) -> int:
        """How many raw lines precede data row ``data_row`` (header and blank lines included)."""
        seen = number = 0
        with open(self.path, encoding=TEXT_ENCODING, errors=TEXT_ERRORS, newline=None) as fh:
            for number, line in self._lines(fh):
                if number <= self.header_lines or not line.strip():
                    continue
                if seen == data_row:
                    return number - 1
                seen += 1
        return number

    def _lines(self, fh: TextIO) -> Iterator[tuple[int, str]]:
        """``(number, line)`` of each line of ``fh`` from 1, none read longer than
        :data:`LONGEST_LINE` (a longer one is refused, naming it)."""
        number = 0
        while line := fh.readline(LONGEST_LINE + 1):
            number += 1
            if len(line) > LONGEST_LINE and not line.endswith("\n"):
                raise InputFormatError(f"longer than {LONGEST_LINE:,} characters: not a point line",
                                       path=self.path, line=number)
            yield number, line

    def read(self) -> PointTable:
        """The whole file as one table, told chunk by chunk as the job's read pass
        (:mod:`aldpat.core.units`)."""
        return PointTable.concat(list(units.counted(self.chunks(), "read")))

    # -------------------------------------------------------------------------- errors
    def _raise_at(self, data_row: int, fallback: str | None = None) -> None:
        """Find the first bad line at or after data row ``data_row`` and raise naming it.

        Runs only on the error path, so a plain line-by-line scan is fine here.
        """
        seen = 0
        with open(self.path, encoding=TEXT_ENCODING, errors=TEXT_ERRORS, newline=None) as fh:
            for number, line in self._lines(fh):
                if number <= self.header_lines or not line.strip():
                    continue
                if seen >= data_row:
                    tokens = _split(line.strip(), self.delimiter)
                    if len(tokens) != self.ncols:
                        raise InputFormatError(
                            f"expected {self.ncols} columns, found {len(tokens)}", path=self.path, line=number)
                    for name, tok in zip(self.names, tokens, strict=False):
                        try:
                            if not _NUMBER.match(tok):
                                raise ValueError(tok)
                            value = float(tok)
                        except ValueError:
                            raise InputFormatError(f"not a number: {shown(tok)}", path=self.path,
                                                   line=number) from None
                        if not np.isfinite(value):
                            raise InputFormatError(f"non-finite value {shown(tok)}", path=self.path, line=number)
                        if name in COORDINATE_COLUMNS and abs(value) > MAX_COORDINATE:
                            raise InputFormatError(f"{name} = {shown(tok, quoted=False)} is not a plausible coordinate "
                                                   f"(larger than {MAX_COORDINATE:g} in magnitude)",
                                                   path=self.path, line=number)
                seen += 1
        raise InputFormatError(fallback or "unreadable line", path=self.path)


# ------------------------------------------------------------------------------ writing


def format_rows(table: PointTable, names: tuple[str, ...], delimiter: str = " ",
                decimals: Mapping[str, int] | None = None) -> str:
    """The rows of ``table`` as text lines (one C-level formatting call per chunk)."""
    n = len(table)
    if n == 0:
        return ""
    fmts = column_formats(table, names, decimals)
    line = _DELIMS.get(delimiter, delimiter).join(fmts) + "\n"
    # '%d' formats a float64 too, so one float matrix serves every column
    stacked = np.empty((n, len(names)), dtype=np.float64)
    for k, name in enumerate(names):
        stacked[:, k] = table.columns[name]
    return (line * n) % tuple(stacked.ravel().tolist())


class TextWriter:
    """Appends chunks of a table to an open text file (the caller handles atomic rename).

    Chunks are formatted in blocks by array arithmetic (:func:`aldpat.io.textfmt.format_block`),
    which writes the same text as :func:`format_rows` several times faster.
    """

    def __init__(self, path: Path, names: tuple[str, ...], *, delimiter: str = "space",
                 decimals: Mapping[str, int] | None = None):
        self.path = Path(path)
        self.names = tuple(names)
        self.delimiter = _DELIMS.get(delimiter, delimiter)
        self.decimals = decimals
        self.count = 0
        self._fh = open(self.path, "wb", buffering=1 << 20)  # noqa: SIM115  (closed by close())

    def write(self, table: PointTable) -> None:
        n = len(table)
        for start in range(0, n, BLOCK_ROWS):
            part = table.take(slice(start, start + BLOCK_ROWS)) if n > BLOCK_ROWS else table
            self._fh.write(format_block(part, self.names, self.delimiter, self.decimals).data)
        self.count += n

    def close(self) -> None:
        self._fh.close()


def _binary_kind(head: bytes) -> str:
    """Why a file with NUL bytes is not a text point file, in the words that help: a LAS file
    under a text name, or UTF-16 text (what Windows PowerShell's ``>`` writes)."""
    if head.startswith(b"LASF"):
        return "a LAS/LAZ file with a text file's name: name it .las or .laz, or give --format las"
    if head.startswith((b"\xff\xfe", b"\xfe\xff")) or head[1:200:2].count(0) > 80 or head[0:200:2].count(0) > 80:
        return "UTF-16 text (as Windows PowerShell's > writes): save it as ASCII or UTF-8"
    return "not a text file (binary bytes); use --format las if it is LAS"


#: a line of values with decimal commas, separated by whitespace or semicolons (a spreadsheet's
#: export in a locale writing 513866,46): at least three values, each whole or with one comma
_DECIMAL_COMMAS = re.compile(r"[+-]?\d+(,\d+)?([\s;]+[+-]?\d+(,\d+)?){2,}[\s;]*")


def _semicolons(lines: list[str]) -> str:
    """The hint for values separated by semicolons (a spreadsheet's CSV in some locales)."""
    if any(";" in line for line in lines[:100]):
        return " (fields separated by ';': aldpat reads spaces, tabs or commas)"
    return ""
