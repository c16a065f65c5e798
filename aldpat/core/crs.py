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
from collections.abc import Callable
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
        if value.isascii() and value.isdigit() and len(value) > 2:
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


#: Output suffixes that can carry a CRS: LAS/LAZ headers, GeoTIFF keys, a VRT's SRS, and the
#: ``.prj`` beside a shapefile or an ArcGIS grid. Text points and Surfer grids cannot.
CRS_CARRIERS = (".las", ".laz", ".tif", ".tiff", ".vrt", ".shp", ".flt", ".asc")


def carries_crs(out: Any) -> bool:
    """Whether an output of this name can carry a CRS (:data:`CRS_CARRIERS`)."""
    return str(out).lower().endswith(CRS_CARRIERS)


#: the end of :func:`without_crs`'s line
WITHOUT_CRS = ": written without a CRS (none given with --crs, none in the input)"


def without_crs(out: Any) -> str:
    """The one warning line of an output that can carry a CRS (LAS/LAZ, GeoTIFF, a shapefile's or
    ArcGIS grid's ``.prj``) and will not: none was given and the input names none. A job that
    fails does not say it (:func:`aldpat.jobs.execute.execute`): its outputs were not written."""
    name = getattr(out, "name", str(out))
    return f"{name}{WITHOUT_CRS}"


def say_cell_in_degrees(given: Any, source: Any, cell: float, name: str, warn: Callable[[str], None],
                        option: str = "--cell") -> None:
    """Say (through ``warn``, a job's ``ctx.warn``) that a cell given in metres (``--cell``, as
    every command documents it) lies over coordinates in degrees: the output's CRS (``given``,
    else the input's ``source``) is geographic, so a cell of 1 is a degree, about 111 km -- a grid
    of 2 x 2 nodes over points 0.02 degrees apart, without a word (``option``: the size's own
    option, ``--width`` of a tile). Nothing for a projected CRS, or none known."""
    try:
        crs = parse_crs(given if given is not None else source) if (given or source) is not None else None
    except Exception:  # noqa: BLE001  (a CRS that does not parse is said where it is used)
        return
    if crs is None or not crs.is_geographic:
        return
    warn(f"{name}: the coordinates are in degrees ({crs_label(crs)}): {option} {cell:g} is {cell:g} degrees "
         f"(about {cell * 111.32:.3g} km), not metres; re-project first (ortho-height --to-crs) for cells in metres")


#: how a message names the units of a projected CRS's first axis (pyproj's ``unit_name``)
_UNIT_WORDS = {"metre": "m", "foot": "ft", "US survey foot": "US ft"}


def coordinate_unit(given: Any, source: Any) -> str:
    """The units the coordinates are in, as a message names them: "degrees" where the CRS
    (``given``, else the input's ``source``) is geographic, its axis unit where projected ("m",
    "ft", "US ft"), and "m" where none is known, as every size option documents its values."""
    try:
        crs = parse_crs(given if given is not None else source) if (given or source) is not None else None
    except Exception:  # noqa: BLE001  (a CRS that does not parse is said where it is used)
        return "m"
    if crs is None:
        return "m"
    if crs.is_geographic:
        return "degrees"
    axes = horizontal_part(crs)
    unit = axes.axis_info[0].unit_name if axes is not None and axes.axis_info else "metre"
    return _UNIT_WORDS.get(unit, unit)


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


def crs_label(crs: Any) -> str:
    """A CRS in a few words: ``EPSG:32632``, else its name."""
    crs = parse_crs(crs)
    code = crs.to_authority()
    return ":".join(code) if code else crs.name


def output_crs(given: Any, source: Any, out: Any, warn: Callable[[str], None]) -> Any:
    """The CRS an output carries, for every task that writes one: ``given`` (``--crs``), else the
    input's own (``source``, a LAS header's), else none.

    ``--crs`` overrides an input's different CRS, with a warning line, as PDAL's LAS reader does
    with ``override_srs``: a header naming the wrong CRS is a common vendor slip, and the
    coordinates are kept as they are (``ortho-height --to-crs`` re-projects). An output of a
    format that can carry a CRS (:func:`carries_crs`) and gets none says so in one line
    (:func:`without_crs`).
    """
    crs = parse_crs(given) if given is not None else None
    known = parse_crs(source) if source is not None else None
    if crs is not None and known is not None and not crs.equals(known, ignore_axis_order=True):
        warn(f"{getattr(out, 'name', out)}: --crs {crs_label(crs)} replaces the input's CRS "
             f"{crs_label(known)} (x, y are kept as they are, not re-projected)")
    crs = crs if crs is not None else known
    if crs is None and carries_crs(out):
        warn(without_crs(out))
    return crs
