"""Domain errors.

Every error a user can cause is an :class:`AldpatError` carrying a one-line message that
names the file (and line, where there is one). The library raises them; only ``aldpat.cli``
turns them into exit codes. Each also subclasses the matching builtin, as rasterio does
(``RasterioIOError(RasterioError, OSError)``), so callers can catch either.
"""

from __future__ import annotations

from pathlib import Path


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
        return where + self.message


class UsageError(AldpatError, ValueError):
    """The command, worksheet or parameters are wrong (exit status 2)."""


class ParamError(UsageError):
    """A parameter has an unknown key, a wrong type or an out-of-range value."""


class InputFormatError(AldpatError, ValueError):
    """An input file cannot be read as the format it claims (bad line, truncated LAS...)."""


class InputMissingError(AldpatError, FileNotFoundError):
    """An input file, list or glob names nothing that exists."""


class OutputExistsError(AldpatError, FileExistsError):
    """An output exists and ``--overwrite`` was not given."""


class OutputError(AldpatError, OSError):
    """An output cannot be written (directory not writable, disk full...)."""


class DataError(AldpatError, ValueError):
    """The data are readable but unusable for the task (e.g. outside the geoid grid)."""
