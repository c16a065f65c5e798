"""A GDAL virtual raster (VRT) over tile grids, so a whole project opens as one raster.

Tile grids made with ``--tile-params`` share their edge rows and columns (ALDPAT 1.0 user
manual (2007), task 9, Fig. 7), all on nodes at whole multiples of the cell size, so each tile
is a window of one grid of nodes. The VRT places every tile at its window (``DstRect``); where
two tiles share a node they hold the same value, and a blank node of one tile never covers a
value of its neighbour (each source declares its own blank value). The file is plain XML, written
without GDAL; GDAL, QGIS and ArcGIS read it.

Reading one (``aldpat preview mosaic.vrt``) goes through GDAL, which does what a VRT says: a
raw band reads any file's bytes as pixels, a source may be a URL, an archive member or another
VRT, a derived band may run code. A VRT is data that someone may have mailed, so before GDAL
opens it :func:`check_mosaic` parses it (bounded size, no entities) and allows only what
:func:`write_mosaic` writes: sourced bands over local grid files of the formats aldpat writes,
each recognised by its first bytes.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from xml.etree import ElementTree
from xml.sax.saxutils import escape

from aldpat.core.grid_extent import GridSpec
from aldpat.core.paths import not_local
from aldpat.errors import DataError, InputFormatError
from aldpat.io.atomic import atomic_output


@dataclass(frozen=True)
class TileGrid:
    """One grid file of the mosaic: where its nodes lie and its blank value."""

    path: Path
    spec: GridSpec
    nodata: float


def write_mosaic(path: str | Path, tiles: list[TileGrid], *, nodata: float, crs: Any = None,
                 overwrite: bool = False) -> Path:
    """Write the VRT ``path`` over ``tiles`` (paths stored relative to it)."""
    path = Path(path)
    if not tiles:
        raise DataError("no grid to put in the mosaic", path=path)
    dx, dy = tiles[0].spec.dx, tiles[0].spec.dy
    for t in tiles:
        if abs(t.spec.dx - dx) > 1e-9 * dx or abs(t.spec.dy - dy) > 1e-9 * dy:
            raise DataError(f"grids of {t.spec.dx:g} x {t.spec.dy:g} and {dx:g} x {dy:g} cells cannot share a "
                            "mosaic", path=t.path)
    xmin = min(t.spec.xmin for t in tiles)
    ymax = max(t.spec.ymax for t in tiles)
    xmax = max(t.spec.xmax for t in tiles)
    ymin = min(t.spec.ymin for t in tiles)
    width = round((xmax - xmin) / dx) + 1
    height = round((ymax - ymin) / dy) + 1
    lines = [f'<VRTDataset rasterXSize="{width}" rasterYSize="{height}">']
    if crs is not None:
        from aldpat.core.crs import parse_crs

        lines.append(f"  <SRS>{escape(parse_crs(crs).to_wkt())}</SRS>")
    lines.append(f"  <GeoTransform>{xmin - dx / 2!r}, {dx!r}, 0.0, {ymax + dy / 2!r}, 0.0, {-dy!r}</GeoTransform>")
    lines.append('  <VRTRasterBand dataType="Float32" band="1">')
    lines.append(f"    <NoDataValue>{nodata!r}</NoDataValue>")
    for t in tiles:
        col = (t.spec.xmin - xmin) / dx
        row = (ymax - t.spec.ymax) / dy
        if abs(col - round(col)) > 1e-6 or abs(row - round(row)) > 1e-6:
            raise DataError("grid nodes are not on the mosaic's nodes (grids of other tiles or cell sizes?)",
                            path=t.path)
        source = os.path.relpath(t.path.resolve(), path.resolve().parent)
        lines += [
            "    <ComplexSource>",
            f'      <SourceFilename relativeToVRT="1">{escape(source)}</SourceFilename>',
            "      <SourceBand>1</SourceBand>",
            f'      <SrcRect xOff="0" yOff="0" xSize="{t.spec.nx}" ySize="{t.spec.ny}"/>',
            f'      <DstRect xOff="{round(col)}" yOff="{round(row)}" xSize="{t.spec.nx}" ySize="{t.spec.ny}"/>',
            f"      <NODATA>{t.nodata!r}</NODATA>",
            "    </ComplexSource>",
        ]
    lines += ["  </VRTRasterBand>", "</VRTDataset>", ""]
    with atomic_output(path, overwrite=overwrite) as tmp:
        tmp.write_text("\n".join(lines), encoding="utf-8")
    return path


# ------------------------------------------------------------------------------ reading

#: the largest VRT read: a mosaic of 100,000 tiles is about 40 MB of XML
MAX_VRT_BYTES = 64 << 20
#: the elements a VRT written by :func:`write_mosaic` (or GDAL's gdalbuildvrt over such grids)
#: holds; anything else -- raw bands, derived bands and their pixel functions, warped or
#: processed datasets, open options, overviews, masks -- is refused
VRT_ELEMENTS = frozenset({
    "VRTDataset", "SRS", "GeoTransform", "Metadata", "MDI", "VRTRasterBand", "NoDataValue", "ColorInterp",
    "Description", "UnitType", "Offset", "Scale", "SimpleSource", "ComplexSource", "AveragedSource",
    "SourceFilename", "SourceBand", "SourceProperties", "SrcRect", "DstRect", "NODATA", "ScaleOffset",
    "ScaleRatio", "UseMaskBand", "BlockXSize", "BlockYSize",
})
#: a GDAL connection string (``HDF5:file:...``, ``GTIFF_DIR:1:file``): a driver prefix before a
#: colon (a Windows drive letter is one letter, not this)
_DRIVER_PREFIX = re.compile(r"^[A-Za-z][A-Za-z0-9_]+:")
#: extension -> what such a grid begins with (GeoTIFF: classic or BigTIFF, either byte order;
#: Surfer 7 binary, 6 binary, 6 ASCII; ESRI ASCII grid; a .flt is raw floats described by its .hdr)
GRID_MAGIC: dict[str, tuple[bytes, ...]] = {
    ".tif": (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+"),
    ".tiff": (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+"),
    ".grd": (b"DSRB", b"DSBB", b"DSAA"),
    ".asc": (b"ncols", b"NCOLS", b"nrows", b"NROWS"),
}


def check_grid_file(path: Path, *, named_by: Path | None = None) -> None:
    """Refuse ``path`` unless it is a local grid file of a format aldpat writes, recognised by its
    first bytes (GDAL picks a driver by content, so a ``.tif`` holding VRT XML would be read as a
    VRT)."""
    where = named_by or path
    what = f"source {path.name!r} " if named_by is not None else ""
    why = not_local(str(path))
    if why is not None:
        raise InputFormatError(f"{what or 'it '}is {why}", path=where)
    ext = path.suffix.lower()
    if ext == ".flt":
        if not (path.is_file() and path.with_suffix(".hdr").is_file()):
            raise InputFormatError(f"{what}no such .flt grid with its .hdr", path=where)
        return
    magic = GRID_MAGIC.get(ext)
    if magic is None:
        raise InputFormatError(f"{what}is not a grid aldpat reads (.tif, .grd, .asc, .flt)", path=where)
    try:
        with open(path, "rb") as fh:
            head = fh.read(16).lstrip()
    except OSError as exc:
        raise InputFormatError(f"{what}{(exc.strerror or str(exc)).lower()}", path=where) from None
    if not path.is_file() or not head.startswith(magic):
        raise InputFormatError(f"{what}is not a {ext} grid (its first bytes say otherwise)", path=where)


def check_mosaic(path: str | Path) -> None:
    """Refuse a VRT that asks GDAL for more than grids of local files: anything but
    :data:`VRT_ELEMENTS`, a band of another kind than sourced, a source that is not a local grid
    file (:func:`check_grid_file`), entities, or more than :data:`MAX_VRT_BYTES`."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_VRT_BYTES + 1)
    except OSError as exc:
        raise InputFormatError(f"cannot read: {(exc.strerror or str(exc)).lower()}", path=path) from None
    if len(data) > MAX_VRT_BYTES:
        raise InputFormatError(f"a VRT of more than {MAX_VRT_BYTES >> 20} MB is not a mosaic aldpat reads", path=path)
    if re.search(rb"<!(DOCTYPE|ENTITY)", data, re.IGNORECASE):
        raise InputFormatError("VRT declares a DOCTYPE or entities; a mosaic has none", path=path)
    try:
        root = ElementTree.fromstring(data)
    except ElementTree.ParseError as exc:
        raise InputFormatError(f"not a VRT: {exc}", path=path) from None
    if root.tag != "VRTDataset":
        raise InputFormatError(f"not a VRT (root element {root.tag!r})", path=path)
    for element in root.iter():
        attributes = {k.lower(): v for k, v in element.attrib.items()}
        if element.tag not in VRT_ELEMENTS:
            raise InputFormatError(f"VRT element <{element.tag}> is not allowed (aldpat reads mosaics of grid "
                                   "files only)", path=path)
        if attributes.get("subclass", "VRTSourcedRasterBand") != "VRTSourcedRasterBand":
            raise InputFormatError(f"VRT {element.tag} of subClass {attributes['subclass']!r} is not allowed "
                                   "(aldpat reads mosaics of grid files only)", path=path)
        if element.tag == "SourceFilename":
            name = (element.text or "").strip()
            if _DRIVER_PREFIX.match(name) or not_local(name):
                raise InputFormatError(f"VRT source {name!r} is not a local file", path=path)
            relative = attributes.get("relativetovrt", "0").strip() == "1"
            source = path.parent / name if relative else Path(name)
            check_grid_file(source, named_by=path)
