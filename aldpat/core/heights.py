"""Ellipsoidal <-> orthometric heights with a geoid grid, and horizontal re-projection.

ALDPAT 1.0 user manual (2007), task 3 "Convert ellipsoid to orthometric heights": ALDPAT called the
Corps of Engineers' Corpscon to turn GPS (ellipsoidal) heights h into orthometric heights H with
a geoid model (GeoidXX) and, on the way, to convert x, y between datums, UTM zones and State
Plane. Here PROJ does both through pyproj:

* ``H = h - N`` with N the geoid undulation interpolated (bilinearly, PROJ ``vgridshift``) in
  a GTX or GeoTIFF grid file, or a grid PROJ knows by name; ``reverse`` gives ``h = H + N``;
* x, y are taken in the input's horizontal CRS (an EPSG code, a UTM zone such as ``17N``, or
  anything pyproj accepts), located in geographic coordinates for the geoid, and optionally
  re-projected to ``to_crs`` (x is always easting / longitude: pyproj ``always_xy``).

The heights written say their datum (:func:`recorded_crs`): orthometric heights are recorded as a
compound CRS, the horizontal CRS + EGM96 height (EPSG:5773, the datum of the NGA geoid grid
ALDPAT's users take), or the vertical CRS the user names in a compound ``to_crs`` (a national
geoid's heights: ``EPSG:25832+7837``); ellipsoidal heights (``reverse``) are recorded with the
horizontal CRS alone, whose datum's ellipsoid they refer to. A compound or vertical input CRS
locates points by its horizontal part.

PROJ reads grids from the local disk only (:func:`local_grids_only`), whatever ``PROJ_NETWORK``
says: a CRS string or a LAS header can name a grid by URL (``+nadgrids=https://...``, a WKT
``PARAMETERFILE``), and with PROJ's network on, a worksheet or a vendor's file would make aldpat
fetch it. A grid PROJ knows by name must be installed (``projsync``).

A point the geoid grid does not cover raises :class:`~aldpat.errors.DataError` naming it; PROJ's
``inf`` never reaches an output. Work is per array, so a task converts a file chunk by chunk.
"""

from __future__ import annotations

import logging
import struct
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from aldpat._lazy import lazy_import
from aldpat.core.crs import compound, horizontal_part, parse_crs, vertical_part
from aldpat.core.paths import expand_home
from aldpat.errors import DataError, InputMissingError, UsageError

if TYPE_CHECKING:
    import pyproj
else:
    pyproj = lazy_import("pyproj")

log = logging.getLogger(__name__)

#: metres in one unit of z (``z_unit``); the geoid grid is in metres
Z_UNITS = {"m": 1.0, "ft": 0.3048, "us-ft": 1200.0 / 3937.0}
#: the EPSG vertical CRS of heights above the EGM96 geoid, in metres
EGM96_HEIGHT = 5773
#: z unit -> the unit's name in a vertical CRS (PROJ's unit names)
_UNIT_NAMES = {"m": "metre", "ft": "foot", "us-ft": "US survey foot"}


def egm96_height(z_unit: str = "m") -> pyproj.CRS:
    """EGM96 height (EPSG:5773) in ``z_unit``: the EPSG CRS itself in metres, the same datum
    with a foot axis otherwise."""
    crs = pyproj.CRS.from_epsg(EGM96_HEIGHT)
    if z_unit == "m":
        return crs
    spec = crs.to_json_dict()
    spec.pop("id", None)  # no longer EPSG:5773
    spec["name"] = f"EGM96 height ({z_unit})"
    spec["coordinate_system"]["axis"][0]["unit"] = {"type": "LinearUnit", "name": _UNIT_NAMES[z_unit],
                                                    "conversion_factor": Z_UNITS[z_unit]}
    return pyproj.CRS.from_json_dict(spec)


def check_to_crs(to_crs: Any, *, reverse: bool = False, z_unit: str = "m") -> None:
    """Refuse, naming ``--to-crs``, a target CRS the conversion cannot honour: a height datum
    for ellipsoidal output (``reverse``), or one whose height unit is not ``z_unit``."""
    if to_crs is None:
        return
    _check_not_geocentric(to_crs, "--to-crs")
    vertical = vertical_part(to_crs)
    if vertical is None:
        return
    if reverse:
        raise UsageError(f"--to-crs: {parse_crs(to_crs).name!r} names a height datum ({vertical.name}), but "
                         "--reverse writes ellipsoidal heights: give a horizontal CRS")
    factor = vertical.axis_info[0].unit_conversion_factor if vertical.axis_info else 1.0
    if abs(factor - Z_UNITS[z_unit]) > 1e-9:
        raise UsageError(f"--to-crs: {vertical.name!r} is in {vertical.axis_info[0].unit_name}, the heights "
                         f"in {z_unit} (--z-unit)")


def _check_not_geocentric(crs: Any, option: str) -> None:
    """Geocentric x, y, z (EPSG:4978) have no horizontal part and no height to convert."""
    crs = parse_crs(crs)
    if crs.is_geocentric:
        raise UsageError(f"{option}: {crs.name!r} is geocentric (x, y, z from the Earth's centre): give a "
                         "horizontal or compound CRS")


def recorded_crs(horizontal: Any, to_crs: Any = None, *, reverse: bool = False, z_unit: str = "m") -> pyproj.CRS:
    """The CRS recorded with converted points (see the module docstring): ``to_crs``'s
    horizontal part (else ``horizontal``), + its vertical part or EGM96 height unless ``reverse``."""
    target = horizontal_part(to_crs) if to_crs is not None else None
    target = target if target is not None else horizontal_part(horizontal)
    if reverse:
        return target
    to_crs = parse_crs(to_crs) if to_crs is not None else None
    if to_crs is not None and to_crs.is_compound and len(to_crs.sub_crs_list[0].axis_info) == 2:
        return to_crs  # the user's compound, EPSG code and name kept
    vertical = vertical_part(to_crs) if to_crs is not None else None
    return compound(target, vertical if vertical is not None else egm96_height(z_unit))


def local_grids_only() -> None:
    """Turn PROJ's network access off in this process (and its threads), before any transformer
    is made: see the module docstring."""
    pyproj.network.set_network_enabled(active=False)


def _vgridshift(grids: str) -> pyproj.Transformer:
    """lon, lat in degrees, z = 0 -> z = N (metres) from the grid(s)."""
    return pyproj.Transformer.from_pipeline(
        "+proj=pipeline +step +proj=unitconvert +xy_in=deg +xy_out=rad "
        f"+step +proj=vgridshift +grids={grids} +multiplier=1 "
        "+step +proj=unitconvert +xy_in=rad +xy_out=deg")


#: A GTX file's header: south latitude, west longitude, the latitude and longitude steps
#: (degrees, big-endian float64), the rows and columns (big-endian int32); float32 values follow.
_GTX_HEADER = struct.Struct(">4d2i")


def check_gtx_header(path: Path) -> None:
    """Refuse a GTX grid whose header does not describe the file (:class:`UsageError`) before
    PROJ reads it: a header claiming 2^30 x 2^30 values had PROJ take 4 GB and 13 s on a file of
    100 bytes before saying no point lies in it."""
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(_GTX_HEADER.size)
    if len(head) < _GTX_HEADER.size:
        raise UsageError(f"cannot open geoid grid {str(path)!r}: shorter than a GTX header ({len(head)} bytes)")
    south, west, dlat, dlon, rows, cols = _GTX_HEADER.unpack(head)
    if not all(np.isfinite([south, west, dlat, dlon])) or not (dlat > 0 and dlon > 0) or rows < 1 or cols < 1:
        raise UsageError(f"cannot open geoid grid {str(path)!r}: its GTX header is not a grid (origin {south:g}, "
                         f"{west:g}, steps {dlat:g}, {dlon:g} degrees, {rows} x {cols} values)")
    if _GTX_HEADER.size + 4 * rows * cols > size:
        raise UsageError(f"cannot open geoid grid {str(path)!r}: its header says {rows:,} x {cols:,} values, "
                         f"the file holds {max(0, size - _GTX_HEADER.size) // 4:,}")


def geoid_transformer(geoid: str | Path) -> tuple[pyproj.Transformer, str]:
    """The undulation transformer of a grid file or of a grid PROJ knows by name.

    A path that does not exist is tried by its file name among PROJ's grids, because worksheets
    take file parameters relative to their folder and a grid name such as ``us_nga_egm96_15.tif``
    arrives there as a path.
    """
    local_grids_only()
    text = str(geoid)
    path = Path(expand_home(text))
    if path.is_file():
        if path.suffix.lower() == ".gtx":
            check_gtx_header(path)
        try:
            return _vgridshift('"' + str(path.resolve()) + '"'), str(path)
        except pyproj.exceptions.ProjError:
            raise UsageError(f"cannot open geoid grid {str(path)!r}: not a GTX or GeoTIFF grid") from None
    try:
        return _vgridshift(path.name), path.name
    except pyproj.exceptions.ProjError:
        if path.name != text:
            raise InputMissingError("no such geoid grid file (nor a grid PROJ knows by this name)",
                                    path=path) from None
        raise UsageError(f"cannot open geoid grid {text!r}: no such file, nor a grid PROJ knows") from None


class HeightConverter:
    """Convert chunks of ``x y z`` between ellipsoidal and orthometric heights.

    Parameters are checked (CRS known, grid readable) when the converter is made, before any
    point is read.
    """

    def __init__(self, crs: Any, geoid: str | Path, *, to_crs: Any = None, reverse: bool = False,
                 z_unit: str = "m") -> None:
        if z_unit not in Z_UNITS:
            raise UsageError(f"unknown z unit {z_unit!r} (use {', '.join(Z_UNITS)})")
        check_to_crs(to_crs, reverse=reverse, z_unit=z_unit)
        _check_not_geocentric(crs, "--crs")
        self.crs = horizontal_part(crs)
        if self.crs is None:
            raise UsageError(f"--crs: {parse_crs(crs).name!r} is a height datum alone: give the CRS of x, y")
        self.to_crs = horizontal_part(parse_crs(to_crs, key="to_crs")) if to_crs is not None else None
        self.reverse = reverse
        self.factor = 1.0 / Z_UNITS[z_unit]
        self._geoid, self.geoid_name = geoid_transformer(geoid)
        geographic = self.crs.geodetic_crs
        if geographic is None:
            raise UsageError(f"CRS {self.crs.name!r} has no geographic datum to locate points on the geoid")
        try:
            #: the CRS of the converted points' x, y and z, recorded in their file (:func:`recorded_crs`)
            self.recorded_crs = recorded_crs(self.crs, to_crs, reverse=reverse, z_unit=z_unit)
            self._to_geo = pyproj.Transformer.from_crs(self.crs, geographic, always_xy=True)
            self._xy = (pyproj.Transformer.from_crs(self.crs, self.to_crs, always_xy=True)
                        if self.to_crs is not None and self.to_crs != self.crs else None)
        except (pyproj.exceptions.CRSError, pyproj.exceptions.ProjError) as exc:
            # an engineering CRS, another celestial body...: PROJ knows no way there
            why = str(exc).rsplit("proj_create_operations: ", 1)[-1].rsplit("proj_create: ", 1)[-1].split(". ")[0]
            target = parse_crs(to_crs).name if to_crs is not None else "EGM96 height"
            raise UsageError(f"--to-crs: no transformation from {self.crs.name!r} to {target!r} "
                             f"({why.strip().rstrip(')')[:160]})") from None

    def __repr__(self) -> str:
        return (f"HeightConverter(crs={self.crs.to_string()!r}, geoid={self.geoid_name!r}, "
                f"to_crs={self.to_crs.to_string() if self.to_crs else None!r}, reverse={self.reverse})")

    def _outside(self, bad: np.ndarray, x: np.ndarray, y: np.ndarray, first: int, path: str | Path | None,
                 why: str) -> DataError:
        where = np.flatnonzero(bad)
        i = int(where[0])
        more = f" (and {where.size - 1} more)" if where.size > 1 else ""
        return DataError(f"point {first + i + 1} at x={x[i]:.3f}, y={y[i]:.3f} {why}{more}", path=path)

    def undulation(self, x: ArrayLike, y: ArrayLike, *, first: int = 0, path: str | Path | None = None) -> np.ndarray:
        """Geoid undulation N (metres) under each point; ``first`` is the number of points
        before this chunk in ``path``, so that a message names the point's place in the file."""
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        lon, lat = self._to_geo.transform(x, y, errcheck=False)
        lon, lat = np.asarray(lon), np.asarray(lat)
        bad = ~(np.isfinite(lon) & np.isfinite(lat))
        if bad.any():
            raise self._outside(bad, x, y, first, path, f"cannot be located in {self.crs.name}")
        _, _, n = self._geoid.transform(lon, lat, np.zeros_like(lon), errcheck=False)
        n = np.asarray(n, dtype=np.float64)
        bad = ~np.isfinite(n) | (np.abs(n) > 500.0)  # no geoid departs 500 m from the ellipsoid
        if bad.any():
            raise self._outside(bad, x, y, first, path, f"lies outside the geoid grid {self.geoid_name}")
        return n

    def __call__(self, x: ArrayLike, y: ArrayLike, z: ArrayLike, *, first: int = 0,
                 path: str | Path | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(x', y', z')``: heights converted, x and y re-projected when ``to_crs`` was given."""
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        n = self.undulation(x, y, first=first, path=path) * self.factor
        z = np.asarray(z, dtype=np.float64)
        z_out = z + n if self.reverse else z - n
        x2, y2 = self.horizontal(x, y, first=first, path=path)
        return x2, y2, z_out

    def horizontal(self, x: ArrayLike, y: ArrayLike, *, first: int = 0,
                   path: str | Path | None = None) -> tuple[np.ndarray, np.ndarray]:
        """x, y in ``to_crs`` (unchanged without one)."""
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        if self._xy is None:
            return x, y
        x2, y2 = self._xy.transform(x, y, errcheck=False)
        x2, y2 = np.asarray(x2, dtype=np.float64), np.asarray(y2, dtype=np.float64)
        bad = ~(np.isfinite(x2) & np.isfinite(y2))
        if bad.any():
            raise self._outside(bad, x, y, first, path, f"cannot be projected to {self._xy.target_crs}")
        return x2, y2
