"""Domain errors.

Every error a user can cause is an :class:`AldpatError` carrying a one-line message that
names the file (and line, where there is one). The library raises them; only ``aldpat.cli``
turns them into exit codes. Each also subclasses the matching builtin, as rasterio does
(``RasterioIOError(RasterioError, OSError)``), so callers can catch either.
"""

from __future__ import annotations

from pathlib import Path

#: C0 controls, DEL, C1 controls and the Unicode line and paragraph separators: what could end a
#: line of a message or a log, or hide text from the reader, is shown as an escape instead
_ESCAPES = {c: f"\\x{c:02x}" for c in (*range(0x20), 0x7F, *range(0x80, 0xA0))}
_ESCAPES.update({0x0A: "\\n", 0x0D: "\\r", 0x09: "\\t", 0x2028: "\\u2028", 0x2029: "\\u2029"})


#: the longest line a message or a log record is: room for a few paths of the longest a system
#: allows, not for a megabyte token of a broken file echoed whole
LONGEST_LINE = 10_000
#: the most of one value (a token of a file, a parameter's value) a message quotes
SHOWN = 60


def one_line(text: object) -> str:
    """``text`` on one line, every control character written as its escape (``\\n``, ``\\x1b``):
    a file name holding a newline cannot start a new line of a message, a log or a worksheet
    log's comment, so what is written reads back as itself. A line longer than
    :data:`LONGEST_LINE` keeps its start and end, with how much was left out between."""
    line = str(text).translate(_ESCAPES)
    if len(line) > LONGEST_LINE:
        keep = LONGEST_LINE // 2
        line = f"{line[:keep]} ...[{len(line) - 2 * keep:,} characters]... {line[-keep:]}"
    return line


def shown(value: object, *, quoted: bool = True) -> str:
    """A value as a message quotes it (``repr`` of text unless not ``quoted``): its first
    :data:`SHOWN` characters and its length when it is longer, so a megabyte token of a broken
    file is not echoed whole."""
    text = repr(value) if isinstance(value, str) and quoted else str(value)
    if len(text) <= SHOWN:
        return text
    return f"{text[:SHOWN]}... ({len(text):,} characters)"


class AldpatError(Exception):
    """Base of every error aldpat reports to a user as one line."""

    def __init__(self, message: str, *, path: str | Path | None = None, line: int | None = None):
        self.path = str(path) if path is not None else None
        self.line = line
        self.message = message
        super().__init__(self.__str__())

    def __str__(self) -> str:
        where = ""
        if self.path is not None:
            where = self.path + (f":{self.line}" if self.line is not None else "") + ": "
        return one_line(where + self.message)


class UsageError(AldpatError, ValueError):
    """The command, worksheet or parameters are wrong (exit status 2)."""


class ParamError(UsageError):
    """A parameter has an unknown key, a wrong type or an out-of-range value."""


class InputFormatError(AldpatError, ValueError):
    """An input file cannot be read as the format it claims (bad line, truncated LAS...)."""


class InputMissingError(AldpatError, FileNotFoundError):
    """An input file, list or glob names nothing that exists."""


class NoSuchFile(InputMissingError):
    """A file named as an input (itself, or by a line of an ``@list``) that does not exist -- not a
    pattern matching nothing nor a folder without points: what it holds is missing from what the
    run makes of all its inputs (:func:`aldpat.jobs.run.run_task`)."""


class OutputExistsError(AldpatError, FileExistsError):
    """An output exists and ``--overwrite`` was not given."""

    HINT = "use --overwrite to replace it"

    def named_after_input(self) -> OutputExistsError:
        """The same refusal of an output named after its input: a second product of that input
        (another method, algorithm or colouring) is written beside the first with ``--suffix``."""
        message = self.message.replace(self.HINT, self.HINT + ", or --suffix to name a second one apart", 1)
        return OutputExistsError(message, path=self.path)


class OutputError(AldpatError, OSError):
    """An output cannot be written (directory not writable, disk full...)."""


class DataError(AldpatError, ValueError):
    """The data are readable but unusable for the task (e.g. outside the geoid grid)."""


class UnstorableValue(DataError):
    """A point's ``value`` of ``column`` that the output cannot hold (a LAS file's intensity of
    0.35). Raised where the points are written, which no longer know their lines; the job finds
    the first line of a text input holding it (:meth:`aldpat.io.text.TextReader.line_holding`)."""

    def __init__(self, message: str, *, column: str, value: float, path: str | Path | None = None,
                 line: int | None = None):
        self.column = column
        self.value = value
        super().__init__(message, path=path, line=line)
