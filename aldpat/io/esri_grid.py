"""ArcGIS grids: binary float grid (``.flt`` + ``.hdr`` [+ ``.prj``]) and ESRI ASCII (``.asc``).

ALDPAT 1.0 user manual (2007), task 10 "Convert Surfer Grids to ArcGIS Grids" (Grd2Bin): ALDPAT wrote
binary float grids that were "not georeferenced"; these carry their lower-left corner and cell
size in the header and, when a CRS is known, a ``.prj`` in ESRI WKT, so ArcGIS and GDAL (EHdr,
AAIGrid drivers) place them without an import step.

* ``.flt``: float32, little-endian, the *top* (northern) row first;
* ``.hdr``: NCOLS NROWS XLLCORNER YLLCORNER CELLSIZE NODATA_VALUE and ``BYTEORDER LSBFIRST``
  (without BYTEORDER GDAL assumes the machine's order of the file's origin and may read garbage);
* corners are cell corners: a node centre at x lies half a cell east of XLLCORNER.

Values travel as in :mod:`aldpat.io.surfer`: ``(values, spec)``, row 0 southern, NaN blank.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np

from aldpat.core.crs import prj_wkt
from aldpat.core.grid_extent import GridSpec, refuse_held_nodata
from aldpat.errors import DataError, InputFormatError, InputMissingError
from aldpat.io.atomic import atomic_outputs

log = logging.getLogger(__name__)

DEFAULT_NODATA = -9999.0


def _square_cell(spec: GridSpec, path: Path) -> float:
    if abs(spec.dx - spec.dy) > 1e-9 * max(spec.dx, spec.dy):
        raise DataError(f"ArcGIS grids need square cells; this grid's are {spec.dx:g} x {spec.dy:g}", path=path)
    return spec.dx


def filled_with_nodata(values: np.ndarray, spec: GridSpec, nodata: float, path: Path) -> np.ndarray:
    """``values`` with blank (NaN) nodes set to ``nodata``; a node already holding ``nodata`` is an error
    (it would read back as blank)."""
    values = np.asarray(values, dtype=np.float64)
    if values.shape != spec.shape:
        raise ValueError(f"values have shape {values.shape}, grid is {spec.shape}")
    refuse_held_nodata(values, nodata, path)
    return np.where(np.isnan(values), nodata, values)


def header_lines(spec: GridSpec, nodata: float, *, ascii: bool = False) -> list[str]:
    """The georeferencing header: corners are the outer cell edges around the nodes."""
    cell = spec.dx
    rows = [("NCOLS", spec.nx), ("NROWS", spec.ny), ("XLLCORNER", repr(spec.xmin - cell / 2)),
            ("YLLCORNER", repr(spec.ymin - cell / 2)), ("CELLSIZE", repr(cell)),
            ("NODATA_VALUE", f"{nodata:.10g}")]
    if ascii:
        return [f"{k.lower() if k != 'NODATA_VALUE' else 'NODATA_value'} {v}" for k, v in rows]
    return [f"{k:<14s}{v}" for k, v in rows] + [f"{'BYTEORDER':<14s}LSBFIRST"]


def write_float_grid(path: str | Path, values: np.ndarray, spec: GridSpec, *, nodata: float = DEFAULT_NODATA,
                     crs: Any = None, overwrite: bool = False) -> list[Path]:
    """Write ``path`` (.flt), its ``.hdr`` and, when ``crs`` is given, its ``.prj``; all or none."""
    path = Path(path)
    _square_cell(spec, path)
    filled = filled_with_nodata(values, spec, nodata, path)
    targets = [path, path.with_suffix(".hdr")]
    if crs is not None:
        targets.append(path.with_suffix(".prj"))
        wkt = prj_wkt(crs)
    with atomic_outputs(targets, overwrite=overwrite) as tmps:
        with open(tmps[0], "wb") as fh:
            # northern rows first, 512 rows at a time
            fh.writelines(filled[max(0, start - 512):start][::-1].astype("<f4").tobytes()
                          for start in range(spec.ny, 0, -512))
        tmps[1].write_text("\n".join(header_lines(spec, nodata)) + "\n", encoding="ascii")
        if crs is not None:
            tmps[2].write_text(wkt, encoding="ascii")
    stale = path.with_suffix(".prj")
    if crs is None and stale.exists():
        log.warning("%s is left from an earlier run and may not describe this grid", stale)
    return targets


def write_ascii_grid(path: str | Path, values: np.ndarray, spec: GridSpec, *, nodata: float = DEFAULT_NODATA,
                     crs: Any = None, overwrite: bool = False) -> list[Path]:
    """Write an ESRI ASCII grid (northern row first) and, when ``crs`` is given, its ``.prj``."""
    path = Path(path)
    _square_cell(spec, path)
    filled = filled_with_nodata(values, spec, nodata, path)
    targets = [path] + ([path.with_suffix(".prj")] if crs is not None else [])
    fmt = "{:.10g}".format
    with atomic_outputs(targets, overwrite=overwrite) as tmps:
        with open(tmps[0], "w", encoding="ascii", newline="\n") as fh:
            fh.write("\n".join(header_lines(spec, nodata, ascii=True)) + "\n")
            fh.writelines(" ".join([fmt(v) for v in row.tolist()]) + "\n" for row in filled[::-1])
        if crs is not None:
            tmps[1].write_text(prj_wkt(crs), encoding="ascii")
    return targets


# ---------------------------------------------------------------------------- reading


def _header(lines: list[str], path: Path) -> dict[str, str]:
    out = {}
    for line in lines:
        parts = line.split()
        if len(parts) < 2:
            continue
        out[parts[0].upper()] = parts[1]
    for key in ("NCOLS", "NROWS", "CELLSIZE"):
        if key not in out:
            raise InputFormatError(f"header has no {key}", path=path)
    return out


def _spec(head: dict[str, str], path: Path) -> tuple[GridSpec, float | None]:
    try:
        nx, ny, cell = int(head["NCOLS"]), int(head["NROWS"]), float(head["CELLSIZE"])
        if "XLLCENTER" in head:
            x0, y0 = float(head["XLLCENTER"]), float(head["YLLCENTER"])
        else:
            x0, y0 = float(head["XLLCORNER"]) + cell / 2, float(head["YLLCORNER"]) + cell / 2
        nodata = float(head["NODATA_VALUE"]) if "NODATA_VALUE" in head else None
        return GridSpec(x0, y0, cell, cell, nx, ny), nodata
    except (KeyError, ValueError) as exc:  # UsageError from GridSpec is a ValueError too
        raise InputFormatError(f"bad grid header ({exc})", path=path) from None


def read_float_grid(path: str | Path) -> tuple[np.ndarray, GridSpec]:
    """Read a ``.flt`` beside its ``.hdr``; nodata nodes come back as NaN, row 0 southern."""
    path = Path(path)
    hdr = path.with_suffix(".hdr")
    if not path.is_file() or not hdr.is_file():
        raise InputMissingError("no such float grid (.flt and .hdr)", path=path if not path.is_file() else hdr)
    head = _header(hdr.read_text(encoding="ascii", errors="replace").splitlines(), hdr)
    spec, nodata = _spec(head, hdr)
    order = "<" if head.get("BYTEORDER", "LSBFIRST").upper() in ("LSBFIRST", "I") else ">"
    values = np.fromfile(path, dtype=order + "f4").astype(np.float64)
    if values.size != spec.nx * spec.ny:
        raise InputFormatError(f"expected {spec.nx * spec.ny} cells, found {values.size}", path=path)
    values = values.reshape(spec.ny, spec.nx)[::-1].copy()
    if nodata is not None:
        values[values == np.float32(nodata)] = np.nan
    return values, spec


def read_ascii_grid(path: str | Path) -> tuple[np.ndarray, GridSpec]:
    """Read an ESRI ASCII grid; nodata nodes come back as NaN, row 0 southern."""
    path = Path(path)
    if not path.is_file():
        raise InputMissingError("no such file", path=path)
    lines = path.read_text(encoding="ascii", errors="replace").splitlines()
    nhead = 0
    while nhead < len(lines) and lines[nhead].strip()[:1].isalpha():
        nhead += 1
    spec, nodata = _spec(_header(lines[:nhead], path), path)
    try:
        values = np.array(" ".join(lines[nhead:]).split(), dtype=np.float64)
    except ValueError:
        raise InputFormatError("a cell value is not a number", path=path) from None
    if values.size != spec.nx * spec.ny:
        raise InputFormatError(f"expected {spec.nx * spec.ny} cells, found {values.size}", path=path)
    values = values.reshape(spec.ny, spec.nx)[::-1].copy()
    if nodata is not None:
        values[values == nodata] = np.nan
    return values, spec

