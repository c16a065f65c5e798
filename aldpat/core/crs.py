"""Coordinate reference systems: the one parser of what users type, and the ``.prj`` text.

Every ``--crs`` / ``--to-crs`` of every task goes through :func:`parse_crs`, so one spelling works
everywhere: an EPSG code (``EPSG:26917`` or ``26917``), a WGS 84 UTM zone (``17N``, ``utm17s``,
``UTM zone 17``; north when no hemisphere is given) or anything PROJ accepts (PROJ string,
WKT, authority code). :func:`prj_wkt` is the text of every ``.prj`` aldpat writes (shapefiles
and ArcGIS grids): ESRI WKT1, what ArcGIS and GDAL expect, or OGC WKT1 for a CRS ESRI WKT1
cannot express. :func:`horizontal_part`, :func:`vertical_part` and :func:`compound` take a
compound CRS (horizontal + vertical, ISO 19111 / OGC WKT ``COMPD_CS``, EPSG codes such as
``EPSG:32632+5773``) apart and put one together.
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


def horizontal_part(crs: Any) -> Any:
    """The 2D horizontal CRS of ``crs``: itself when horizontal, the horizontal component of a
    compound CRS, the 2D form of a 3D one (EPSG:4979 -> EPSG:4326); None for a vertical CRS."""
    crs = parse_crs(crs)
    if crs.is_compound:
        parts = [c for c in crs.sub_crs_list if not c.is_vertical]
        if not parts:
            return None
        crs = parts[0]
    if crs.is_vertical:
        return None
    return crs.to_2d() if len(crs.axis_info) > 2 else crs


def vertical_part(crs: Any) -> Any:
    """The vertical CRS of ``crs`` (itself, or a compound CRS's vertical component); None when
    it names no height (a horizontal or 3D ellipsoidal CRS)."""
    crs = parse_crs(crs)
    if crs.is_compound:  # before is_vertical: pyproj calls a compound with a height vertical too
        return next((c for c in crs.sub_crs_list if c.is_vertical), None)
    return crs if crs.is_vertical else None


def compound(horizontal: Any, vertical: Any) -> Any:
    """The compound CRS ``horizontal + vertical``, named as EPSG names its compounds
    ("WGS 84 / UTM zone 32N + EGM96 height")."""
    horizontal, vertical = parse_crs(horizontal), parse_crs(vertical)
    return pyproj.crs.CompoundCRS(name=f"{horizontal.name} + {vertical.name}", components=[horizontal, vertical])
