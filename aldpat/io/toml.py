"""Reading TOML (worksheets and ``--params`` files) with one-line errors, and any small text
file aldpat reads whole (``@list`` files) with a bound on its size."""

from __future__ import annotations

import os
import stat
import tomllib
from pathlib import Path

from aldpat.errors import InputFormatError, InputMissingError, UsageError

#: the largest worksheet or parameter file read: a worksheet of 10,000 jobs is about 2 MB
MAX_TOML_BYTES = 32 << 20
#: the largest side file read whole (a polygon's vertices, a tile parameter file's rows): a
#: million vertices or tiles take tens of MB
MAX_SIDE_FILE_BYTES = 256 << 20


def read_limited(path: str | Path, limit: int, *, what: str, errors: str = "strict") -> str:
    """The UTF-8 text of ``path``, read with a bound: a file (or ``/dev/zero``, a pipe that never
    ends) longer than ``limit`` bytes is refused after reading ``limit`` bytes, never read on.
    ``errors="replace"`` keeps a byte that is not UTF-8 as one character. ``OSError`` (a missing
    file) is the caller's to word.

    A named pipe is opened without waiting for a writer (``open`` would wait for ever when nothing
    is to write to it: ``aldpat run fifo.toml`` hung) and then read to its end as any file, so
    that ``--params <(make-params)`` still reads what the command writes; one that nothing writes
    to is refused by name."""
    path = Path(path)
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    pipe = stat.S_ISFIFO(os.fstat(fd).st_mode)
    os.set_blocking(fd, True)
    with os.fdopen(fd, "rb") as fh:
        data = fh.read(limit + 1)
    if pipe and not data:
        raise InputFormatError(f"{what} is a named pipe that nothing writes to", path=path)
    if len(data) > limit:
        raise InputFormatError(f"{what} larger than {limit >> 20} MB; is it the right file?", path=path)
    try:
        return data.decode("utf-8-sig", errors=errors)
    except UnicodeDecodeError as exc:
        raise InputFormatError(f"{what} is not UTF-8 text (byte {exc.start + 1})", path=path) from None


def load_toml(path: str | Path) -> dict:
    path = Path(path)
    try:
        text = read_limited(path, MAX_TOML_BYTES, what="TOML file")
    except FileNotFoundError:
        raise InputMissingError("no such file", path=path) from None
    except IsADirectoryError:
        raise UsageError("is a folder, not a TOML file", path=path) from None
    except InputFormatError as exc:
        raise UsageError(exc.message, path=path) from None
    except OSError as exc:
        raise UsageError(f"cannot read: {(exc.strerror or str(exc)).lower()}", path=path) from None
    try:
        return tomllib.loads(text)
    except RecursionError:  # arrays or tables nested thousands deep: the parser recurses once a level
        raise UsageError("TOML nested too deep to read (arrays or inline tables within each other); "
                         "is it the right file?", path=path) from None
    except tomllib.TOMLDecodeError as exc:
        # tomllib says "... (at line 3, column 7)": keep the line as ours
        message = str(exc)
        line = None
        if "(at line " in message:
            try:
                line = int(message.split("(at line ", 1)[1].split(",", 1)[0])
                message = message.split(" (at line ", 1)[0]
            except ValueError:
                pass
        elif "(at end of document)" in message:
            line = max(1, len(text.splitlines()))
            message = message.replace(" (at end of document)", " at the end of the file")
        raise UsageError(f"TOML syntax error: {message}", path=path, line=line) from None
