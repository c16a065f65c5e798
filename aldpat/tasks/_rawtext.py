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

from pathlib import Path

import numpy as np

BLOCK = 1 << 26  # bytes read at a time
_GATHER_LINES = 262_144  # lines gathered at a time (the byte index is 8x the bytes)
_WHITE = np.zeros(256, dtype=bool)
_WHITE[[9, 10, 13, 32]] = True


def passthrough_ok(reader, names: tuple[str, ...], delimiter: str, out_suffix: str) -> bool:
    """True when copying input lines gives exactly what the formatted output would hold."""
    if getattr(reader, "format", None) != "text" or out_suffix.lower() in (".las", ".laz"):
        return False
    if tuple(names) != tuple(reader.names):
        return False
    wanted = "," if (delimiter == "comma" or out_suffix.lower() == ".csv") else " "
    return reader.delimiter == wanted


class Lines:
    """``n`` data lines: ``buf[starts[k]:ends[k]]`` is line k without its newline."""

    def __init__(self, buf: np.ndarray, starts: np.ndarray, ends: np.ndarray):
        self.buf, self.starts, self.ends = buf, starts, ends

    def __len__(self) -> int:
        return len(self.starts)

    def in_step_with(self, first_column: np.ndarray) -> bool:
        """Whether the first value of the first and last lines is what the parser read."""
        if len(self) != len(first_column):
            return False
        if len(self) == 0:
            return True
        for k in (0, len(self) - 1):
            text = self.buf[self.starts[k]:self.ends[k]].tobytes().decode("latin-1")
            token = text.replace(",", " ").split()[0]
            try:
                if float(token) != first_column[k]:
                    return False
            except ValueError:
                return False
        return True

    def gather(self, rows: np.ndarray | slice) -> bytes:
        """The selected lines (a boolean mask, indices or a slice), each ended by a newline."""
        starts, ends = self.starts[rows], self.ends[rows]
        if len(starts) == 0:
            return b""
        if isinstance(rows, slice) and (rows.step in (None, 1)):
            # consecutive lines: one slice of the buffer, newlines and blank lines included
            block = self.buf[starts[0]:ends[-1]].tobytes()
            return block + b"\n"
        parts = []
        for a in range(0, len(starts), _GATHER_LINES):
            s, e = starts[a:a + _GATHER_LINES], ends[a:a + _GATHER_LINES]
            lens = e - s
            out_len = lens + 1
            pos = np.cumsum(out_len) - out_len
            total = int(out_len.sum())
            idx = np.arange(total, dtype=np.int64)
            idx += np.repeat(s - pos, out_len)
            out = self.buf[np.minimum(idx, len(self.buf) - 1)]
            out[pos + lens] = 10
            parts.append(out.tobytes())
        return b"".join(parts)


class RawLines:
    """Reads the data lines of a text file in order, ``take(n)`` at a time."""

    def __init__(self, path: str | Path, header_lines: int):
        self._fh = open(path, "rb")
        for _ in range(header_lines):
            self._fh.readline()
        self._buf = np.zeros(0, dtype=np.uint8)
        self._eof = False

    def _lines(self, buf: np.ndarray, final: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Starts and ends of the complete lines in ``buf`` and whether each holds data."""
        nl = np.flatnonzero(buf == 10)
        ends = nl
        if final and (len(nl) == 0 or nl[-1] != len(buf) - 1) and len(buf):
            ends = np.append(nl, len(buf))  # a last line without newline
        starts = np.empty(len(ends), dtype=np.int64)
        if len(ends):
            starts[0] = 0
            starts[1:] = ends[:-1] + 1
        data = np.ones(len(ends), dtype=bool)
        # a blank line is all whitespace; only lines that are empty or start with whitespace can be
        # (data lines usually start with a digit or a sign), so only those are checked byte by byte
        lens = ends - starts
        first = buf[np.minimum(starts, max(len(buf) - 1, 0))] if len(buf) else np.zeros(0, np.uint8)
        maybe = np.flatnonzero((lens == 0) | _WHITE[first])
        if len(maybe):
            s, e = starts[maybe], ends[maybe]
            width = e - s
            pos = np.cumsum(width) - width
            idx = np.arange(int(width.sum()), dtype=np.int64) + np.repeat(s - pos, width)
            solid = (~_WHITE[buf[idx]]).astype(np.int64)
            counts = np.add.reduceat(solid, pos[width > 0]) if len(idx) else np.zeros(0, np.int64)
            has = np.zeros(len(maybe), dtype=bool)
            has[width > 0] = counts > 0
            data[maybe] = has
        return starts, ends, data

    def take(self, n: int) -> Lines:
        while True:
            starts, ends, data = self._lines(self._buf, self._eof)
            have = int(data.sum())
            if have >= n or self._eof:
                break
            block = self._fh.read(BLOCK)
            if not block:
                self._eof = True
            else:
                self._buf = np.concatenate([self._buf, np.frombuffer(block, dtype=np.uint8)])
        keep = np.flatnonzero(data)[:n]
        if len(keep) < n:
            raise ValueError(f"expected {n} more data lines, found {len(keep)}")
        buf = self._buf
        lines = Lines(buf, starts[keep], ends[keep])
        cut = int(ends[keep[-1]]) + 1 if len(keep) else 0
        self._buf = buf[cut:].copy() if cut < len(buf) else np.zeros(0, dtype=np.uint8)
        return lines

    def close(self) -> None:
        self._fh.close()

    def __enter__(self) -> "RawLines":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
