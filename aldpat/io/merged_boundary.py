"""The merged boundary file of ALDPAT task 5: ``x y z strip_index file_name`` per line, a line
``-1111`` between two strips (ALDPAT 1.0 user manual (2007), Task 5 "Merge Boundary Files").

``aldpat merge-boundary`` writes it; :func:`read_merged` reads it back (``aldpat shapefile``
turns it into polygons). A file name may hold the delimiter, as it is the last column.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aldpat.errors import InputFormatError, InputMissingError, shown
from aldpat.io.text import MAX_COORDINATE

#: The line between two strips.
SEPARATOR = "-1111"
#: The largest strip index: the shapefile's ``strip`` field holds ten characters, a sign and nine digits.
MOST_INDEX = 999_999_999


@dataclass
class Strip:
    index: int
    name: str
    xyz: np.ndarray  # (n, 3)


def read_merged(path: str | Path) -> list[Strip]:
    """The strips of a merged boundary file, in file order."""
    path = Path(path)
    try:
        fh = open(path, encoding="utf-8", errors="replace", newline=None)  # noqa: SIM115  (the with block below)
    except OSError as exc:
        raise InputMissingError(f"cannot read: {exc.strerror or exc}", path=path) from None
    strips: list[Strip] = []
    rows: list[tuple[float, float, float]] = []
    key: tuple[int, str] | None = None

    def close() -> None:
        if rows and key is not None:
            strips.append(Strip(key[0], key[1], np.asarray(rows, dtype=np.float64)))

    # a boundary file holds hundreds of points, not millions: a line loop is fine here
    with fh:
        for number, line in enumerate(fh, start=1):
            text = line.strip()
            if not text:
                continue
            # told by the first column: a comma in the file name (the last) is part of the name
            delim = "," if "," in text.split(None, 1)[0] else None
            parts = [p.strip() for p in text.split(delim, 4)] if delim else text.split(None, 4)
            if parts[0] == SEPARATOR and len(parts) == 1:
                close()
                rows, key = [], None
                continue
            if len(parts) < 5:
                raise InputFormatError(f"expected 5 columns (x y z strip_index file_name), found {len(parts)}",
                                       path=path, line=number)
            try:
                x, y, z = float(parts[0]), float(parts[1]), float(parts[2])
                value = float(parts[3])
            except ValueError:
                raise InputFormatError("x, y, z and strip_index must be numbers", path=path, line=number) from None
            # said here, as the point reader says it: a NaN or 1e300 corner went into the
            # shapefile as it was, an infinite index was an internal error, and an index of 1e20
            # was cut to the ten digits of the shapefile's field
            for name, token, v in zip("xyz", parts, (x, y, z), strict=False):
                if not abs(v) <= MAX_COORDINATE:
                    raise InputFormatError(f"{name} = {shown(token, quoted=False)} is not a plausible coordinate "
                                           f"(larger than {MAX_COORDINATE:g} in magnitude, or not finite)",
                                           path=path, line=number)
            if not (value.is_integer() and abs(value) <= MOST_INDEX):
                raise InputFormatError(f"strip_index {shown(parts[3], quoted=False)} is not a whole number of at "
                                       f"most {len(str(MOST_INDEX))} digits", path=path, line=number)
            index = int(value)
            this = (index, parts[4])
            if key is not None and this != key:  # a new strip without a separator line
                close()
                rows = []
            key = this
            rows.append((x, y, z))
    close()
    if not strips:
        raise InputFormatError("no boundary points in file", path=path)
    return strips
