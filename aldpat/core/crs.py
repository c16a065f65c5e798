"""Coordinate reference systems: the one parser of what users type, and the ``.prj`` text.

Every ``--crs`` / ``--to-crs`` of every task goes through :func:`parse_crs`, so one spelling works
everywhere: an EPSG code (``EPSG:26917`` or ``26917``), a WGS 84 UTM zone (``17N``, ``utm17s``,
``UTM zone 17``; north when no hemisphere is given) or anything PROJ accepts (PROJ string,
WKT, authority code). :func:`prj_wkt` is the text of every ``.prj`` aldpat writes (shapefiles
and ArcGIS grids): ESRI WKT1, what ArcGIS and GDAL expect, or OGC WKT1 for a CRS ESRI WKT1
cannot express.
"""

from __future__ import annotations

import re
from typing import Any

from aldpat._lazy import lazy_import
from aldpat.errors import ParamError

pyproj = lazy_import("pyproj")

_UTM = re.compile(r"^\s*(?:utm)?\s*(?:zone)?\s*(\d{1,2})\s*(n|s|north|south)?\s*$", re.IGNORECASE)


def parse_crs(text: Any, key: str = "crs") -> Any:
    """A ``pyproj.CRS`` from user input (see the module docstring); a CRS is returned as is.

    Raises :class:`ParamError` naming ``key`` when PROJ knows no such CRS.
    """
    if isinstance(text, pyproj.CRS):
        return text
    value = str(text).strip()
    match = _UTM.match(value)
    try:
        if value.isdigit() and len(value) > 2:
            return pyproj.CRS.from_epsg(int(value))
        if match:
            zone = int(match.group(1))
            if not 1 <= zone <= 60:
                raise ParamError(f"{key}: UTM zone must be 1..60, got {zone}")
            south = (match.group(2) or "n").lower().startswith("s")
            return pyproj.CRS.from_epsg((32700 if south else 32600) + zone)
        return pyproj.CRS.from_user_input(value)
    except pyproj.exceptions.CRSError:
        raise ParamError(f"{key}: unknown CRS {value!r} (give an EPSG code such as EPSG:26917, a UTM zone "
                         "such as 17N, or WKT)") from None


def prj_wkt(crs: Any) -> str:
    """The ``.prj`` text of a CRS (or of anything :func:`parse_crs` accepts)."""
    crs = parse_crs(crs)
    try:
        wkt = crs.to_wkt(pyproj.enums.WktVersion.WKT1_ESRI)
    except pyproj.exceptions.CRSError:
        wkt = None
    return wkt or crs.to_wkt(pyproj.enums.WktVersion.WKT1_GDAL)  # a CRS ESRI WKT1 cannot express


def without_crs(out: Any) -> str:
    """The one warning line of an output that can carry a CRS (LAS/LAZ, GeoTIFF) and will not:
    none was given and the input names none."""
    name = getattr(out, "name", str(out))
    return f"{name}: written without a CRS (none given with --crs, none in the input)"
