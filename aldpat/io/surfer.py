"""Surfer grids: Surfer 6 ASCII (DSAA), Surfer 6 binary (DSBB) and Surfer 7 binary (DSRB).

ALDPAT 1.0 user manual (2007), tasks 9 and 10: ALDPAT gridded tiles with Golden Software Surfer and
converted its ``.grd`` files for ArcGIS; these are the three grid files Surfer reads and writes,
following Golden Software's published layouts (the same ones GDAL's GSAG, GSBG and GS7BG
drivers implement):

* extents are the centres of the outer nodes; the first row stored is the southern one;
* a blank node holds 1.70141e38; anything >= 1.7e38 is read as blank;
* DSBB stores the node counts as 16-bit integers, so it cannot exceed 32767 nodes a side.

Grids are handed around as ``(values, spec)``: a float64 array of shape ``(ny, nx)``, row 0 the
southern row, NaN for blank nodes, and the :class:`~aldpat.core.grid_extent.GridSpec` of the
nodes.
"""

from __future__ import annotations

import logging
import os
import struct
from pathlib import Path
from typing import BinaryIO

import numpy as np

from aldpat.core.grid_extent import GridSpec, refuse_held_nodata
from aldpat.errors import DataError, InputFormatError, InputMissingError, UsageError
from aldpat.io.atomic import atomic_output

log = logging.getLogger(__name__)

#: Surfer's blank value and the threshold from which a value reads as blank.
BLANK = 1.70141e38
BLANK_FROM = 1.7e38
#: the largest node count a side that Surfer 6 binary's 16-bit header can hold
DSBB_MAX = 32767

#: ``--grid-format`` name -> writer; the names ``aldpat grid --grid-format`` accepts.
FORMATS = ("surfer7", "surfer6", "surfer6-ascii")

_TAG_HEADER = 0x42525344  # "DSRB"
_TAG_GRID = 0x44495247  # "GRID"
_TAG_DATA = 0x41544144  # "DATA"
_DSBB_HEAD = struct.Struct("<4shh6d")
_DSRB_GRID = struct.Struct("<ii8d")


def _checked(values: np.ndarray, spec: GridSpec) -> np.ndarray:
    values = np.asarray(values, dtype=np.float64)
    if values.shape != spec.shape:
        raise ValueError(f"values have shape {values.shape}, grid is {spec.shape}")
    if spec.nx < 2 or spec.ny < 2:
        raise DataError(f"a Surfer grid needs at least 2 nodes a side, this one is {spec.nx} x {spec.ny}")
    return values


def _zrange(values: np.ndarray) -> tuple[float, float]:
    """Minimum and maximum of the non-blank nodes (0, 0 when all are blank)."""
    finite = np.isfinite(values)
    if not finite.any():
        return 0.0, 0.0
    return float(np.min(values, where=finite, initial=np.inf)), float(np.max(values, where=finite, initial=-np.inf))


def check_holds(spec: GridSpec, fmt: str, path: str | Path | None = None) -> None:
    """Refuse a grid the format ``fmt`` cannot hold (checked before a grid is made, and by the
    writer): a Surfer 6 binary grid at most :data:`DSBB_MAX` nodes a side, a Surfer 7 grid's
    data section less than 2 GiB of doubles."""
    if fmt == "surfer6" and max(spec.nx, spec.ny) > DSBB_MAX:
        raise DataError(
            f"Surfer 6 binary grids hold at most {DSBB_MAX} nodes a side; this grid is "
            f"{spec.nx} x {spec.ny} (use surfer7)", path=path)
    if fmt == "surfer7" and spec.nx * spec.ny * 8 >= 2**31:
        raise DataError(f"a grid of {spec.nx} x {spec.ny} nodes is too large for one Surfer 7 data section "
                        "(2 GiB); use a larger --cell, --grid-format geotiff, or tile the data", path=path)


def write_surfer(path: str | Path, values: np.ndarray, spec: GridSpec, *, fmt: str = "surfer7",
                 blank: float | None = None, overwrite: bool = False) -> Path:
    """Write a grid atomically in one of :data:`FORMATS`; NaN nodes are written blank.

    ``blank`` replaces 1.70141e38 in a Surfer 7 grid (its header carries the value); Surfer 6
    grids only know 1.70141e38.
    """
    path = Path(path)
    values = _checked(values, spec)
    if fmt not in FORMATS:
        raise UsageError(f"unknown grid format {fmt!r} (use {', '.join(FORMATS)})")
    if blank is not None and fmt != "surfer7" and blank != BLANK:
        raise UsageError(f"Surfer 6 grids only know the blank value {BLANK:g}; use surfer7 for {blank:g}")
    check_holds(spec, fmt, path)
    refuse_held_nodata(values, BLANK if blank is None or fmt != "surfer7" else blank, path)
    with atomic_output(path, overwrite=overwrite) as tmp, open(tmp, "wb") as fh:
        if fmt == "surfer7":
            _write_dsrb(fh, values, spec, BLANK if blank is None else blank)
        elif fmt == "surfer6":
            _write_dsbb(fh, values, spec)
        else:
            _write_dsaa(fh, values, spec)
    log.debug("wrote %s grid %s (%d x %d nodes)", fmt, path, spec.nx, spec.ny)
    return path


def _write_dsaa(fh: BinaryIO, values: np.ndarray, spec: GridSpec) -> None:
    zlo, zhi = _zrange(values)
    head = (f"DSAA\n{spec.nx} {spec.ny}\n{spec.xmin!r} {spec.xmax!r}\n{spec.ymin!r} {spec.ymax!r}\n"
            f"{zlo!r} {zhi!r}\n")
    fh.write(head.encode("ascii"))
    fmt = "{:.10g}".format
    for row in values:  # a loop over rows; each row is formatted in one go
        items = [fmt(v) for v in np.where(np.isnan(row), BLANK, row).tolist()]
        lines = [" ".join(items[i:i + 10]) for i in range(0, len(items), 10)]
        fh.write(("\n".join(lines) + "\n\n").encode("ascii"))


def _write_dsbb(fh: BinaryIO, values: np.ndarray, spec: GridSpec) -> None:
    zlo, zhi = _zrange(values)
    fh.write(_DSBB_HEAD.pack(b"DSBB", spec.nx, spec.ny, spec.xmin, spec.xmax, spec.ymin, spec.ymax, zlo, zhi))
    for start in range(0, spec.ny, 512):
        block = values[start:start + 512]
        fh.write(np.where(np.isnan(block), BLANK, block).astype("<f4").tobytes())


def _write_dsrb(fh: BinaryIO, values: np.ndarray, spec: GridSpec, blank: float) -> None:
    zlo, zhi = _zrange(values)
    # Version 1 blanks every value >= BlankValue (Surfer's own), version 2 only == BlankValue.
    version = 1 if blank == BLANK else 2
    fh.write(struct.pack("<iii", _TAG_HEADER, 4, version))
    fh.write(struct.pack("<ii", _TAG_GRID, _DSRB_GRID.size))
    fh.write(_DSRB_GRID.pack(spec.ny, spec.nx, spec.xmin, spec.ymin, spec.dx, spec.dy, zlo, zhi, 0.0, blank))
    fh.write(struct.pack("<ii", _TAG_DATA, values.size * 8))
    for start in range(0, spec.ny, 512):
        block = values[start:start + 512]
        fh.write(np.where(np.isnan(block), blank, block).astype("<f8").tobytes())


# ---------------------------------------------------------------------------- reading


def surfer_format(path: str | Path) -> str:
    """Which of :data:`FORMATS` a file is, from its first four bytes."""
    path = Path(path)
    if not path.is_file():
        raise InputMissingError("no such file", path=path)
    with open(path, "rb") as fh:
        magic = fh.read(4)
    kinds = {b"DSRB": "surfer7", b"DSBB": "surfer6", b"DSAA": "surfer6-ascii"}
    if magic not in kinds:
        raise InputFormatError("not a Surfer grid (expected DSAA, DSBB or DSRB at the start)", path=path, line=1)
    return kinds[magic]


def _spec_from_range(path: Path, nx: int, ny: int, xlo: float, xhi: float, ylo: float, yhi: float) -> GridSpec:
    if nx < 2 or ny < 2:
        raise InputFormatError(f"grid of {nx} x {ny} nodes has no spacing", path=path)
    if not (xhi > xlo and yhi > ylo):
        raise InputFormatError(f"empty grid range x {xlo:g}..{xhi:g}, y {ylo:g}..{yhi:g}", path=path)
    return GridSpec(xlo, ylo, (xhi - xlo) / (nx - 1), (yhi - ylo) / (ny - 1), nx, ny)


def read_surfer(path: str | Path) -> tuple[np.ndarray, GridSpec]:
    """Read any Surfer grid; blank nodes come back as NaN, row 0 the southern row."""
    path = Path(path)
    kind = surfer_format(path)
    try:
        if kind == "surfer7":
            return _read_dsrb(path)
        if kind == "surfer6":
            return _read_dsbb(path)
        return _read_dsaa(path)
    except struct.error:
        raise InputFormatError("truncated Surfer grid header", path=path) from None


def _blanked(values: np.ndarray, blank: float | None = None, exact: bool = False) -> np.ndarray:
    values = values.astype(np.float64)
    mask = values >= BLANK_FROM
    if blank is not None:
        mask |= (values == blank) if exact else (values >= blank)
    values[mask] = np.nan
    return values


def _read_dsaa(path: Path) -> tuple[np.ndarray, GridSpec]:
    text = path.read_text(encoding="ascii", errors="replace")
    tokens = text.split()
    if len(tokens) < 9:
        raise InputFormatError("truncated Surfer ASCII grid header", path=path)
    try:
        nx, ny = int(tokens[1]), int(tokens[2])
        xlo, xhi, ylo, yhi = (float(t) for t in tokens[3:7])
    except ValueError:
        raise InputFormatError("bad Surfer ASCII grid header (lines 2-4)", path=path, line=2) from None
    spec = _spec_from_range(path, nx, ny, xlo, xhi, ylo, yhi)
    body = tokens[9:]
    if len(body) != nx * ny:
        raise InputFormatError(f"expected {nx * ny} node values, found {len(body)}", path=path)
    try:
        values = np.array(body, dtype=np.float64)
    except ValueError:
        raise InputFormatError("a node value is not a number", path=path) from None
    return _blanked(values).reshape(ny, nx), spec


def _node_values(fh: BinaryIO, dtype: str, count: int, path: Path) -> np.ndarray:
    """``count`` node values from ``fh``: a header counting more nodes than the file's bytes
    hold is refused before anything is allocated for them (numpy would allocate them all)."""
    size = np.dtype(dtype).itemsize
    left = os.fstat(fh.fileno()).st_size - fh.tell()
    if count * size > left:
        raise InputFormatError(f"expected {count:,} node values, the file holds {max(left, 0) // size:,}", path=path)
    return np.fromfile(fh, dtype=dtype, count=count)


def _read_dsbb(path: Path) -> tuple[np.ndarray, GridSpec]:
    with open(path, "rb") as fh:
        _magic, nx, ny, xlo, xhi, ylo, yhi, _, _ = _DSBB_HEAD.unpack(fh.read(_DSBB_HEAD.size))
        spec = _spec_from_range(path, nx, ny, xlo, xhi, ylo, yhi)
        values = _node_values(fh, "<f4", nx * ny, path)
    if values.size != nx * ny:
        raise InputFormatError(f"expected {nx * ny} node values, found {values.size}", path=path)
    return _blanked(values).reshape(ny, nx), spec


def _read_dsrb(path: Path) -> tuple[np.ndarray, GridSpec]:
    spec = None
    blank, version = BLANK, 1
    with open(path, "rb") as fh:
        while True:
            head = fh.read(8)
            if len(head) < 8:
                break
            tag, size = struct.unpack("<ii", head)
            if tag == _TAG_HEADER:
                (version,) = struct.unpack("<i", fh.read(4))
                fh.seek(size - 4, 1)
            elif tag == _TAG_GRID:
                ny, nx, xll, yll, dx, dy, _, _, rotation, blank = _DSRB_GRID.unpack(fh.read(_DSRB_GRID.size))
                fh.seek(size - _DSRB_GRID.size, 1)
                if rotation != 0:
                    raise InputFormatError(f"rotated grids are not supported (rotation {rotation:g})", path=path)
                if nx < 1 or ny < 1 or not (dx > 0 and dy > 0):
                    raise InputFormatError(f"bad grid section ({nx} x {ny} nodes, spacing {dx:g} x {dy:g})",
                                           path=path)
                spec = GridSpec(xll, yll, dx, dy, nx, ny)
            elif tag == _TAG_DATA:
                if spec is None:
                    raise InputFormatError("data section before the grid section", path=path)
                values = _node_values(fh, "<f8", spec.nx * spec.ny, path)
                if values.size != spec.nx * spec.ny:
                    raise InputFormatError(f"expected {spec.nx * spec.ny} node values, found {values.size}",
                                           path=path)
                return _blanked(values, blank, exact=version == 2).reshape(spec.ny, spec.nx), spec
            else:
                if size < 0:
                    raise InputFormatError("corrupt section size", path=path)
                fh.seek(size, 1)  # fault lines and future sections are not needed
    raise InputFormatError("no grid data section", path=path)
