"""Fixed-decimal text output without a Python object per value.

The plain formatter (``aldpat.io.text.format_rows``) turns every value into a Python
float and formats it with ``%``: simple and exact, but several times slower than parsing, so a
task writing millions of rows is bound by it. Here each column becomes digits by integer
arithmetic on whole arrays: the value is scaled by 10^decimals and rounded (``np.rint``; integer
columns truncate like ``%d``), its digits are peeled off right to left into a byte matrix, and
the matrix is compacted into lines. For values read from text with that many decimals (what these
tasks write) the digits are exactly those ``%.Nf`` gives.

:class:`aldpat.io.text.TextWriter` formats every chunk through :func:`format_block`;
:func:`aldpat.io.text.format_rows` stays as the plain reference the tests compare against.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

import numpy as np

from aldpat.io.table import PointTable

_FMT = re.compile(r"^%(?:\.(\d+))?([df])$")
#: rows formatted at a time (the byte matrix is about 40 bytes a row)
BLOCK_ROWS = 500_000
#: columns always written as whole numbers
INTEGER_COLUMNS = {"intensity", "i1", "i2", "class", "mark", "label", "strip_index", "classification"}


def _column_bytes(values: np.ndarray, decimals: int, integer: bool) -> np.ndarray:
    """(width, n) uint8 matrix of one column's text, right-aligned, 0 where there is no character
    (built column-major: each digit position is one contiguous row)."""
    v = np.asarray(values, dtype=np.float64)
    scaled = np.trunc(v) if integer else np.rint(v * (10.0 ** decimals))
    # %.Nf keeps the sign of a negative zero (-0.00); %d does not
    negative = (scaled < 0) if integer else np.signbit(scaled)
    a = np.abs(scaled).astype(np.int64)
    d = 0 if integer else decimals
    # digits needed: at least d + 1 (a leading 0 before the point)
    top = int(a.max()) if len(a) else 0
    ndig_max = max(len(str(top)), d + 1)
    width = ndig_max + (1 if d else 0) + 1  # digits, point, sign
    out = np.zeros((width, len(a)), dtype=np.uint8)
    ndig = np.maximum(np.floor(np.log10(np.maximum(a, 1))).astype(np.int64) + 1, d + 1)
    # log10 can be off by one just below a power of ten: correct it exactly
    ten = np.power(10, np.minimum(ndig, 18)).astype(np.int64)
    ndig = np.where((a >= ten) & (ndig < 19), ndig + 1, ndig)
    rest = a
    col = width - 1
    for k in range(ndig_max):
        if d and k == d:
            out[col] = ord(".")
            col -= 1
        rest, digit = np.divmod(rest, 10)
        np.add(digit, 48, out=out[col], casting="unsafe")
        col -= 1
    # blank out the leading zeros; the sign goes just left of the leading digit
    used = ndig + (1 if d else 0)
    out[np.arange(width)[:, None] < (width - used)[None, :]] = 0
    rows = np.flatnonzero(negative)
    out[width - 1 - used[rows], rows] = ord("-")
    return out


#: the most decimals a number is written with: 1e-10, far below any coordinate's precision
MOST_DECIMALS = 10
#: the most decimals a coordinate keeps where its own text does not bound them (exponent form,
#: more decimals further down a file than in its first lines) and the finest LAS scale made for
#: text points: 1e-8 of a degree, about a millimetre of latitude
COORDINATE_DECIMALS = 8


def decimal_places(value: float, most: int = MOST_DECIMALS) -> int:
    """The fewest decimals that write ``value`` exactly, at most ``most``: 3 for a LAS scale of
    0.025 (its points' 0.075 was written 0.08 when the decimals came from the scale's power of
    ten alone), 3 for 5.120001230000000214e+05 (numpy's savetxt), whose decimals as written say
    nothing of the number's."""
    if value == 0 or not np.isfinite(value):
        return 0
    for places in range(most):
        if whole_at(np.array([value]), places):
            return places
    return most


def whole_at(values: np.ndarray, places: int) -> bool:
    """Whether every one of ``values`` (finite) is written exactly with ``places`` decimals: times
    ``10 ** places`` it is whole but for the binary fraction's error, a few units in the last place
    of the largest product (0.1 * 10 is 1 to the bit, 0.3 * 10 is 3.0000000000000004)."""
    shifted = np.abs(values) * 10.0 ** places
    error = np.rint(shifted)
    np.subtract(shifted, error, out=error)
    return float(np.max(np.abs(error, out=error))) <= 16 * float(np.spacing(np.max(shifted)))


def column_formats(table: PointTable, names: tuple[str, ...], decimals: Mapping[str, int] | None = None) -> list[str]:
    """printf formats per column: integers for integer columns, the input's decimals otherwise."""
    decimals = decimals if decimals is not None else table.meta.get("decimals", {})
    fmts = []
    for n in names:
        col = table.columns[n]
        # whole numbers as such; but an intensity of 0.35 (a reflectance) keeps its decimals: as "%d" it was 0
        if np.issubdtype(col.dtype, np.integer) or col.dtype == bool or (
                n in INTEGER_COLUMNS and (not decimals.get(n) or bool(np.all(col == np.round(col))))):
            fmts.append("%d")
        else:
            d = decimals.get(n)
            if d is None:
                d = 3 if n in ("x", "y", "z") or n[:1] in "xyz" else 6
            fmts.append(f"%.{d}f")
    return fmts


def format_block(table: PointTable, names: tuple[str, ...], delimiter: str = " ", decimals: Mapping[str, int] | None = None) -> np.ndarray:
    """The rows of ``table`` as text lines (a uint8 array), with the columns and decimals of
    :func:`column_formats` (those :func:`aldpat.io.text.format_rows` uses too)."""
    n = len(table)
    if n == 0:
        return np.zeros(0, dtype=np.uint8)

    parts = []
    sep = np.frombuffer(delimiter.encode("ascii"), dtype=np.uint8)
    for k, (name, fmt) in enumerate(zip(names, column_formats(table, names, decimals), strict=False)):
        m = _FMT.match(fmt)
        assert m is not None, fmt  # column_formats writes only these
        places = int(m.group(1) or 0)
        parts.append(_column_bytes(table.columns[name], places, m.group(2) == "d"))
        end = sep if k < len(names) - 1 else np.array([10], np.uint8)
        parts.append(np.broadcast_to(end[:, None], (len(end), n)))
    matrix = np.ascontiguousarray(np.concatenate(parts, axis=0).T)
    return matrix[matrix != 0]
