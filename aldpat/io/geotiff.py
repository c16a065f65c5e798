"""GeoTIFF and Cloud Optimized GeoTIFF grids, written through GDAL (rasterio).

What LiDAR users open today (QGIS, GDAL, ArcGIS Pro, web maps): float32, the nodata value set,
the CRS embedded, deflate compression with the floating-point predictor, internal 256 x 256
tiles, and for a COG the overviews and the layout GDAL's COG driver gives (IFDs first, so a
reader fetches only the bytes it shows). Georeferencing is node-centred as in the Surfer grids
aldpat writes: the pixel of node (row, col) is centred on that node's coordinates
(:meth:`aldpat.core.grid_extent.GridSpec.corner_transform`), so the same node has the same
coordinates in every format.

The library: rasterio, an optional extra (``pip install 'aldpat[geotiff]'``), because GDAL is
the reference implementation of GeoTIFF keys and of the COG layout, and because it is what the
tests already use to check every grid aldpat writes; writing the GeoTIFF keys by hand would be a
second implementation to keep right.
"""

from __future__ import annotations

import contextlib
import importlib
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aldpat.core.grid_extent import GridSpec, refuse_held_nodata
from aldpat.core.paths import not_local
from aldpat.core.threads import thread_budget
from aldpat.errors import InputFormatError, ParamError, UsageError, one_line, shown
from aldpat.io.atomic import atomic_output

#: ``--grid-format`` / ``--to`` name -> file extension
FORMATS = {"geotiff": ".tif", "cog": ".tif"}
#: nodata of GeoTIFF grids unless the user gives one
DEFAULT_NODATA = -9999.0
#: deflate's level for every GeoTIFF and COG written (GDAL's default is 6): on a DTM of 33 M
#: float32 nodes with the floating-point predictor, 4 compresses in about three quarters of the
#: CPU time of 6 (the COG's overviews included), into a file 1.3 % larger
DEFLATE_LEVEL = 4
#: the largest float32 (a band's values and its nodata value)
FLOAT32_MAX = float(np.finfo(np.float32).max)


def _rasterio() -> Any:
    """rasterio with the submodules used here, or a usage error saying how to install it."""
    try:
        rasterio = importlib.import_module("rasterio")
        for sub in ("rasterio.shutil", "rasterio.transform", "rasterio.errors"):
            importlib.import_module(sub)
        return rasterio
    except ImportError:
        raise UsageError("GeoTIFF and COG grids need the optional GDAL binding rasterio: "
                         "pip install 'aldpat[geotiff]'") from None


@dataclass(frozen=True, eq=False)
class Raster:
    """A grid of heights placed on the ground: what :func:`aldpat.dtm` returns and what a
    GeoTIFF aldpat writes holds.

    ``array`` is float32 with the first row north, ``nodata`` at blank nodes; ``transform`` the
    affine of its pixels in rasterio's order ``(a, b, c, d, e, f)`` (``x = a * col + b * row +
    c``, ``y = d * col + e * row + f``, at a pixel's corner; ``rasterio.Affine(*transform)``);
    ``crs`` a ``pyproj.CRS`` or None. Pixels are centred on the nodes, as in every grid aldpat
    writes (:meth:`aldpat.core.grid_extent.GridSpec.corner_transform`).
    """

    array: np.ndarray
    transform: tuple[float, float, float, float, float, float]
    crs: Any = None
    nodata: float = DEFAULT_NODATA

    def __post_init__(self) -> None:
        """A raster made by hand (the class is the API's) is checked as a call's parameters are:
        each bad field named, at once -- not numpy's, Affine's or GDAL's error when it is written.
        A list of rows becomes an array, a CRS given as text (``"EPSG:32632"``) a ``pyproj.CRS``."""
        from aldpat.core.crs import parse_crs

        array = self.array if isinstance(self.array, np.ndarray) else np.asarray(self.array)
        if array.ndim != 2 or 0 in array.shape or array.dtype.kind not in "fiu":
            raise ParamError(f"Raster: array: expected a 2-D array of heights with a row and a column at least, "
                             f"got {array.dtype} of shape {array.shape}")
        transform = tuple(self.transform) if isinstance(self.transform, (tuple, list)) else ()
        if len(transform) != 6 or not all(isinstance(v, (int, float, np.number)) and np.isfinite(v)
                                          for v in transform):
            raise ParamError(f"Raster: transform: expected 6 finite numbers (a, b, c, d, e, f), got {self.transform!r}")
        try:
            nodata = float(self.nodata)
        except (TypeError, ValueError):
            nodata = float("nan")
        if not np.isfinite(nodata) or abs(nodata) > float(np.finfo(np.float32).max):
            raise ParamError(f"Raster: nodata: expected a finite float32 value, got {self.nodata!r}")
        object.__setattr__(self, "array", array)
        object.__setattr__(self, "transform", tuple(float(v) for v in transform))
        object.__setattr__(self, "nodata", nodata)
        if self.crs is not None and not hasattr(self.crs, "to_wkt"):
            object.__setattr__(self, "crs", parse_crs(self.crs, key="Raster: crs"))

    @classmethod
    def from_nodes(cls, values: np.ndarray, spec: GridSpec, *, crs: Any = None, nodata: float | None = None,
                   path: str | Path | None = None) -> Raster:
        """The raster of node ``values`` (rows from the south, NaN blank) on ``spec``; ``crs`` is
        anything :func:`aldpat.core.crs.parse_crs` accepts. A node holding ``nodata`` itself is an
        error naming ``path`` (it would read back as blank)."""
        from aldpat.core.crs import parse_crs

        nodata = DEFAULT_NODATA if nodata is None else float(nodata)
        values = np.asarray(values)
        if values.shape != spec.shape:
            raise ValueError(f"values have shape {values.shape}, grid is {spec.shape}")
        # one float32 copy, north row first; a value equal to nodata once stored as float32
        # would read back as blank (NaN equals nothing, so blank nodes never match)
        band = np.ascontiguousarray(values[::-1], dtype=np.float32)
        refuse_held_nodata(band, nodata, path or "grid", np.float32)
        np.copyto(band, np.float32(nodata), where=np.isnan(band))
        gt = spec.corner_transform()
        return cls(band, (gt[1], gt[2], gt[0], gt[4], gt[5], gt[3]),
                   parse_crs(crs) if crs is not None else None, nodata)

    @property
    def geotransform(self) -> tuple[float, float, float, float, float, float]:
        """The transform in GDAL's order ``(c, a, b, f, d, e)``."""
        a, b, c, d, e, f = self.transform
        return (c, a, b, f, d, e)

    def write(self, path: str | Path, *, format: str | None = None, overwrite: bool = False) -> Path:
        """Write the raster as a GeoTIFF (``.tif``, ``.tiff``) or a Cloud Optimized GeoTIFF
        (``.cog.tif``), as ``format`` (``geotiff`` or ``cog``) says or else by the extension:
        float32, deflate with the floating-point predictor, 256 x 256 tiles (a COG with its
        overviews), the CRS and nodata set; atomically, an existing file replaced only with
        ``overwrite``. ``path`` is a local file: a URL or a GDAL virtual file system (``s3://``,
        ``/vsicurl/``) is refused before GDAL is asked, which would reach the network for it (and
        ``Path`` would make ``s3:`` a local folder)."""
        why = not_local(os.fspath(path))
        if why is not None:
            raise UsageError(f"raster not written: {shown(os.fspath(path))} is {why}")
        path = Path(path)
        name = path.name.lower()
        if format is None:
            if not name.endswith((".tif", ".tiff")):
                raise UsageError(f"a raster is written as .tif (GeoTIFF) or .cog.tif (COG), not {path.suffix!r}",
                                 path=path)
            format = "cog" if name.endswith((".cog.tif", ".cog.tiff")) else "geotiff"
        if format not in FORMATS:
            raise UsageError(f"format: expected one of {', '.join(FORMATS)}, got {format!r}")
        _write_band(path, self, cog=format == "cog", overwrite=overwrite)
        return path


def write_geotiff(path: str | Path, values: np.ndarray, spec: GridSpec, *, cog: bool = False,
                  nodata: float | None = None, crs: Any = None, overwrite: bool = False) -> Path:
    """Write ``values`` (rows from the south, NaN for blank nodes) as a GeoTIFF, or a COG,
    atomically; ``crs`` is anything :func:`aldpat.core.crs.parse_crs` accepts, or None."""
    raster = Raster.from_nodes(values, spec, crs=crs, nodata=nodata, path=path)
    _write_band(Path(path), raster, cog=cog, overwrite=overwrite)
    return Path(path)


def _write_band(path: Path, raster: Raster, *, cog: bool, overwrite: bool) -> None:
    rasterio = _rasterio()
    height, width = raster.array.shape
    profile = {
        "width": width, "height": height, "count": 1, "dtype": "float32", "nodata": raster.nodata,
        "transform": rasterio.transform.Affine(*raster.transform),
        "crs": raster.crs.to_wkt() if raster.crs is not None else None,
        "compress": "deflate", "predictor": 3,
        # tiles compressed on the process's threads (the same bytes as on one)
        "num_threads": thread_budget(),
    }
    band = raster.array.astype(np.float32, copy=False)
    if cog:  # the COG driver names deflate's level LEVEL, the GTiff driver ZLEVEL
        profile.update(driver="COG", blocksize=256, overview_resampling="average", level=DEFLATE_LEVEL)
    else:
        profile.update(driver="GTiff", tiled=True, blockxsize=256, blockysize=256, zlevel=DEFLATE_LEVEL)
    with atomic_output(path, overwrite=overwrite) as tmp:
        if cog:
            # the COG driver writes by copying a finished dataset: build it in memory first
            mem_profile = {k: profile[k] for k in ("width", "height", "count", "dtype", "nodata", "transform", "crs")}
            with rasterio.MemoryFile() as mem:
                with mem.open(driver="GTiff", **mem_profile) as ds:
                    ds.write(band, 1)
                with mem.open() as src:
                    rasterio.shutil.copy(src, str(tmp), **{k: v for k, v in profile.items()
                                                             if k not in mem_profile})
        else:
            with rasterio.open(str(tmp), "w", **profile) as ds:
                ds.write(band, 1)


#: GDAL's settings while aldpat reads a raster, behind :func:`open_raster`'s own checks: no
#: side-car files (.aux.xml) read or written beside a user's grid, no directory listing, no file
#: found by /vsicurl/, and -- for the GDAL versions that know these settings -- no raw bands and
#: no Python pixel functions in a VRT
READ_SETTINGS = {
    "GDAL_PAM_ENABLED": "NO",
    "GDAL_DISABLE_READDIR_ON_OPEN": "EMPTY_DIR",
    "CPL_VSIL_CURL_ALLOWED_EXTENSIONS": ".aldpat-none",
    "GDAL_VRT_ENABLE_RAWRASTERBAND": "NO",
    "GDAL_VRT_RAWRASTERBAND_ALLOWED_SOURCE": "SIBLING_OR_CHILD_OF_VRT_PATH",
    "GDAL_VRT_ENABLE_PYTHON": "NO",
}


@contextlib.contextmanager
def open_raster(path: str | Path) -> Iterator[Any]:
    """Open a GeoTIFF or a VRT mosaic for reading through GDAL, and nothing else: the path a local
    file, a VRT's content checked first (:func:`aldpat.io.vrt.check_mosaic`), a GeoTIFF
    recognised by its first bytes, and GDAL held to that one driver (it would otherwise pick a
    driver by content) under :data:`READ_SETTINGS`."""
    from aldpat.io.vrt import check_grid_file, check_mosaic

    rasterio = _rasterio()
    path = Path(path)
    if path.suffix.lower() == ".vrt":
        why = not_local(str(path))
        if why is not None:
            raise InputFormatError(f"is {why}", path=path)
        check_mosaic(path)
        driver = "VRT"
    else:
        check_grid_file(path)
        driver = "GTiff"
    with rasterio.Env(**READ_SETTINGS):
        try:
            ds = rasterio.open(str(path), driver=driver)
        except rasterio.errors.RasterioIOError as exc:
            raise InputFormatError(f"cannot read as a grid: {one_line(exc)[:200]}", path=path) from None
        with ds:
            yield ds


def geotiff_header(path: str | Path) -> tuple[GridSpec, float | None, str | None]:
    """The nodes, the nodata value and the CRS (WKT) of a GeoTIFF, without reading its values."""
    with open_raster(path) as ds:
        return _placement(ds, path)[0], ds.nodata, (ds.crs.to_wkt() if ds.crs else None)


def read_geotiff(path: str | Path, longest: int | None = None) -> tuple[np.ndarray, GridSpec]:
    """A GeoTIFF grid (or a VRT mosaic of grids) as written here: values with rows from the south,
    NaN for blank nodes. Blank nodes are those holding the nodata value (not a mask GDAL would
    look for in side-car files). With ``longest``, a grid longer than that on a side is read at
    every k-th node (k odd), the fewest that keep it within ``longest`` (GDAL's nearest-node reading,
    from the file's overviews when it has them): a county's mosaic, not its 12 bytes a node."""
    with open_raster(path) as ds:
        step = -(-max(ds.width, ds.height) // longest) if longest else 1
        step += 1 - step % 2 if step > 1 else 0  # odd: the node GDAL picks is the pixel's centre
        if step > 1:  # whole steps from the north-west corner: the last few nodes east and south left out
            from rasterio.windows import Window

            shape = (max(1, ds.height // step), max(1, ds.width // step))
            window = Window(0, 0, min(shape[1] * step, ds.width), min(shape[0] * step, ds.height))
            band = ds.read(1, window=window, out_shape=shape)
            spec, north_first = _placement(_Decimated(ds.transform @ ds.transform.scale(step, step), shape[1],
                                                      shape[0]), path)
        else:
            spec, north_first = _placement(ds, path)
            band = ds.read(1)
        values = band.astype(np.float64)
        if ds.nodata is not None:  # compared as the band stores it (a float32 band's 1.70141e38)
            values[(band == np.asarray(ds.nodata, dtype=band.dtype)) | np.isnan(values)] = np.nan
        return (values[::-1] if north_first else values), spec


@dataclass(frozen=True)
class _Decimated:
    """The placement of a raster read at a coarser size (what :func:`_placement` reads of one)."""

    transform: Any
    width: int
    height: int


def _placement(ds: Any, path: str | Path) -> tuple[GridSpec, bool]:
    """The nodes of a raster whose pixels are centred on them (the inverse of
    :meth:`GridSpec.corner_transform`), and whether its first row is the northern one.

    aldpat writes north-up rasters (first row north, a negative y pixel size); GDAL also writes and
    reads south-up ones (first row south, a positive y pixel size), which hold the same grid with
    their rows the other way round. A rotated or sheared raster, or one whose columns run west, is
    refused: its nodes do not lie on a lattice of x and y."""
    t = ds.transform
    if t.b != 0 or t.d != 0 or not t.a > 0 or t.e == 0:
        raise InputFormatError(f"not a grid of x and y: the raster's pixels are rotated, sheared or run west "
                               f"(geotransform {t.c:g}, {t.a:g}, {t.b:g}, {t.f:g}, {t.d:g}, {t.e:g})", path=path)
    if t.e < 0:
        return GridSpec(t.c + t.a / 2, t.f + t.e * (ds.height - 0.5), t.a, -t.e, ds.width, ds.height), True
    return GridSpec(t.c + t.a / 2, t.f + t.e / 2, t.a, t.e, ds.width, ds.height), False
