"""A GDAL virtual raster (VRT) over tile grids, so a whole project opens as one raster.

Tile grids made with ``--tile-params`` share their edge rows and columns (ALDPAT 1.0 user
manual (2007), task 9, Fig. 7), all on nodes at whole multiples of the cell size, so each tile
is a window of one grid of nodes. The VRT places every tile at its window (``DstRect``); where
two tiles share a node they hold the same value, and a blank node of one tile never covers a
value of its neighbour (each source declares its own blank value). The file is plain XML, written
without GDAL; GDAL, QGIS and ArcGIS read it.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from xml.sax.saxutils import escape

from aldpat.core.grid_extent import GridSpec
from aldpat.errors import DataError
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
