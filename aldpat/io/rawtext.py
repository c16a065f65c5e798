"""The raw bytes of a text point file's data lines, in step with its parsed chunks.

Tasks that keep or drop whole records (split-tape, tile, polygon-extract) can copy the selected
lines byte for byte instead of formatting numbers again: the records stay exactly as they were
(decimals, delimiters, CRLF) and the write costs a memory copy instead of a ``%`` formatting of
every value, which is several times slower than parsing. :class:`RawLines` reads the file a
second time, alongside the reader's chunks, and hands out the lines of the next ``n`` data rows
(blank lines skipped exactly as the parser skips them); selection is a vectorized gather.

Used only when the output would hold the same columns with the same delimiter as the input;
each batch of lines is checked against the parsed values (first and last line) before use.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator
from pathlib import Path
from typing import Any, BinaryIO, Self

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from aldpat.io.text import UTF8_BOM

BLOCK = 1 << 26  # bytes read at a time
_GATHER_LINES = 262_144  # lines gathered at a time (a matrix of about 40 bytes a line)
_NEWLINE = np.array([10], dtype=np.uint8)
_WHITE = np.zeros(256, dtype=bool)
_WHITE[[9, 10, 13, 32]] = True


def passthrough_ok(reader: Any, names: tuple[str, ...], delimiter: str, out_suffix: str) -> bool:
    """True when copying input lines gives exactly what the formatted output would hold."""
    if getattr(reader, "format", None) != "text" or out_suffix.lower() in (".las", ".laz"):
        return False
    if tuple(names) != tuple(reader.names):
        return False
    wanted = "," if (delimiter == "comma" or out_suffix.lower() == ".csv") else " "
    return reader.delimiter == wanted


class Lines:
    """``n`` data lines, in one or more segments of the file's bytes: in segment ``g``,
    ``buf[starts[k]:ends[k]]`` is a line without its newline."""

    def __init__(self, segments: list[tuple[np.ndarray, np.ndarray, np.ndarray]]):
        self.segments = segments
        self.offsets = np.cumsum([0] + [len(s) for _, s, _ in segments])

    def __len__(self) -> int:
        return int(self.offsets[-1])

    def _line(self, k: int) -> str:
        g = int(np.searchsorted(self.offsets, k, side="right")) - 1
        buf, starts, ends = self.segments[g]
        j = k - int(self.offsets[g])
        return buf[starts[j]:ends[j]].tobytes().decode("latin-1")

    def in_step_with(self, first_column: np.ndarray) -> bool:
        """Whether the first value of the first and last lines is what the parser read."""
        if len(self) != len(first_column):
            return False
        for k in {0, len(self) - 1} if len(self) else ():
            tokens = self._line(k).replace(",", " ").split()
            try:
                if not tokens or float(tokens[0]) != first_column[k]:
                    return False
            except ValueError:
                return False
        return True

    def pieces(self, rows: np.ndarray | slice) -> Iterator[np.ndarray]:
        """The selected lines (a boolean mask, ascending indices or a slice) as byte arrays to
        write one after the other, each line ended by a newline. A slice copies its stretch of
        the file as it is (blank lines within a block of the file included), without a copy."""
        if isinstance(rows, slice):
            a, b, step = rows.indices(len(self))
            if step != 1:
                yield from self.pieces(np.arange(a, b, step))
                return
            for g, (buf, starts, ends) in enumerate(self.segments):
                lo = max(a - int(self.offsets[g]), 0)
                hi = min(b - int(self.offsets[g]), len(starts))
                if hi > lo:
                    yield buf[starts[lo]:ends[hi - 1]]
                    yield _NEWLINE
            return
        rows = np.asarray(rows)
        if rows.dtype == bool:
            rows = np.flatnonzero(rows)
        cuts = np.searchsorted(rows, self.offsets)
        for g, (buf, starts, ends) in enumerate(self.segments):
            sel = rows[cuts[g]:cuts[g + 1]] - int(self.offsets[g])
            for a in range(0, len(sel), _GATHER_LINES):
                yield _gather(buf, starts[sel[a:a + _GATHER_LINES]], ends[sel[a:a + _GATHER_LINES]])

    def write(self, fh: BinaryIO, rows: np.ndarray | slice) -> None:
        """Write the selected lines to a binary file."""
        for piece in self.pieces(rows):
            if len(piece):
                fh.write(piece.data)

    def gather(self, rows: np.ndarray | slice) -> bytes:
        """The selected lines as one bytes object (see :meth:`pieces`)."""
        return b"".join(p.tobytes() for p in self.pieces(rows))


def _gather(buf: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """Lines ``buf[starts[k]:ends[k]]`` (ascending starts) joined, each followed by a newline.

    Each line is copied as one row of a sliding-window view of the buffer (a row copy, not a
    byte-by-byte index), padded rows are blanked and the blanks dropped; lines too close to the
    end of the buffer for a full window go through a byte index.
    """
    if len(starts) == 0:
        return _NEWLINE[:0]
    lens = ends - starts
    width = int(lens.max()) + 1
    n_win = int(np.searchsorted(starts, len(buf) - width, side="right"))
    parts = []
    if n_win:
        rows = sliding_window_view(buf, width)[starts[:n_win]]  # (n, width) copy
        short = lens[:n_win]
        rows[np.arange(width)[None, :] > short[:, None]] = 0
        rows[np.arange(n_win), short] = 10
        parts.append(rows[rows != 0])  # text holds no NUL bytes
    if n_win < len(starts):
        s, e = starts[n_win:], ends[n_win:]
        out_len = e - s + 1
        pos = np.cumsum(out_len) - out_len
        idx = np.arange(int(out_len.sum()), dtype=np.int64)
        idx += np.repeat(s - pos, out_len)
        np.minimum(idx, len(buf) - 1, out=idx)  # the newline slot of a last line without one
        out = buf[idx]
        out[pos + out_len - 1] = 10
        parts.append(out)
    return parts[0] if len(parts) == 1 else np.concatenate(parts)


def _line_bounds(buf: np.ndarray, final: bool) -> tuple[np.ndarray, np.ndarray, int]:
    """Starts and ends of the data lines of ``buf`` (blank lines dropped) and the number of bytes
    they use up (the rest is an unfinished line, unless ``final``)."""
    nl = np.flatnonzero(buf == 10)
    used = int(nl[-1]) + 1 if len(nl) else 0
    ends = nl
    if final and used < len(buf):
        ends = np.append(nl, len(buf))
        used = len(buf)
    starts = np.empty(len(ends), dtype=np.int64)
    if len(ends):
        starts[0] = 0
        starts[1:] = ends[:-1] + 1
    data = np.ones(len(ends), dtype=bool)
    # a blank line is all whitespace; only lines that are empty or start with whitespace can be
    # (data lines usually start with a digit or a sign), so only those are checked byte by byte
    lens = ends - starts
    if len(buf):
        maybe = np.flatnonzero((lens == 0) | _WHITE[buf[np.minimum(starts, len(buf) - 1)]])
    else:
        maybe = np.zeros(0, dtype=np.int64)
    if len(maybe):
        s, width = starts[maybe], lens[maybe]
        pos = np.cumsum(width) - width
        idx = np.arange(int(width.sum()), dtype=np.int64) + np.repeat(s - pos, width)
        solid = (~_WHITE[buf[idx]]).astype(np.int64)
        has = np.zeros(len(maybe), dtype=bool)
        if len(idx):
            nz = width > 0
            has[nz] = np.add.reduceat(solid, pos[nz]) > 0
        data[maybe] = has
    return starts[data], ends[data], used


class RawLines:
    """Reads the data lines of a text file in order, ``take(n)`` at a time.

    The file is read in blocks; each block's line boundaries are found once, and a ``take`` hands
    out views into the blocks, so memory stays near one chunk of lines plus one block.
    """

    def __init__(self, path: str | Path, header_lines: int):
        self._fh = open(path, "rb")  # noqa: SIM115  (closed by close() / the with block)
        if self._fh.read(len(UTF8_BOM)) != UTF8_BOM:  # a byte-order mark is not part of line 1
            self._fh.seek(0)
        for _ in range(header_lines):
            self._fh.readline()
        self._segments: deque = deque()
        self._available = 0
        self._tail = b""
        self._eof = False

    def _read_block(self) -> None:
        block = self._fh.read(BLOCK)
        if not block:
            self._eof = True
        data = self._tail + block if self._tail else block
        if not data:
            return
        buf = np.frombuffer(data, dtype=np.uint8)
        starts, ends, used = _line_bounds(buf, final=self._eof)
        self._tail = data[used:]
        if len(starts):
            self._segments.append([buf, starts, ends])
            self._available += len(starts)

    def take(self, n: int) -> Lines:
        while self._available < n and not self._eof:
            self._read_block()
        if self._available < n:
            raise ValueError(f"expected {n} more data lines, found {self._available}")
        parts = []
        need = n
        while need:
            seg = self._segments[0]
            k = min(need, len(seg[1]))
            parts.append((seg[0], seg[1][:k], seg[2][:k]))
            if k == len(seg[1]):
                self._segments.popleft()
            else:
                seg[1], seg[2] = seg[1][k:], seg[2][k:]
            need -= k
        self._available -= n
        return Lines(parts)

    def close(self) -> None:
        self._fh.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
