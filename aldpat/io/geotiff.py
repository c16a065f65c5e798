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

import importlib
from pathlib import Path
from typing import Any

import numpy as np

from aldpat.core.grid_extent import GridSpec
from aldpat.errors import UsageError
from aldpat.io.atomic import atomic_output
from aldpat.io.esri_grid import filled_with_nodata

#: ``--grid-format`` / ``--to`` name -> file extension
FORMATS = {"geotiff": ".tif", "cog": ".tif"}
#: nodata of GeoTIFF grids unless the user gives one
DEFAULT_NODATA = -9999.0


def _rasterio() -> Any:
    """rasterio with the submodules used here, or a usage error saying how to install it."""
    try:
        rasterio = importlib.import_module("rasterio")
        for sub in ("rasterio.shutil", "rasterio.transform"):
            importlib.import_module(sub)
        return rasterio
    except ImportError:
        raise UsageError("GeoTIFF and COG grids need the optional GDAL binding rasterio: "
                         "pip install 'aldpat[geotiff]'") from None


def write_geotiff(path: str | Path, values: np.ndarray, spec: GridSpec, *, cog: bool = False,
                  nodata: float | None = None, crs: Any = None, overwrite: bool = False) -> Path:
    """Write ``values`` (rows from the south, NaN for blank nodes) as a GeoTIFF, or a COG,
    atomically; ``crs`` is anything :func:`aldpat.core.crs.parse_crs` accepts, or None."""
    rasterio = _rasterio()
    from aldpat.core.crs import parse_crs

    path = Path(path)
    nodata = DEFAULT_NODATA if nodata is None else float(nodata)
    # GeoTIFF rows run from the north
    band = filled_with_nodata(values, spec, nodata, path).astype(np.float32)[::-1]
    gt = spec.corner_transform()
    profile = {
        "width": spec.nx, "height": spec.ny, "count": 1, "dtype": "float32", "nodata": nodata,
        "transform": rasterio.transform.Affine(gt[1], gt[2], gt[0], gt[4], gt[5], gt[3]),
        "crs": parse_crs(crs).to_wkt() if crs is not None else None,
        "compress": "deflate", "predictor": 3,
    }
    if cog:
        profile.update(driver="COG", blocksize=256, overview_resampling="average")
    else:
        profile.update(driver="GTiff", tiled=True, blockxsize=256, blockysize=256)
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
    return path


def geotiff_header(path: str | Path) -> tuple[GridSpec, float | None, str | None]:
    """The nodes, the nodata value and the CRS (WKT) of a GeoTIFF, without reading its values."""
    rasterio = _rasterio()
    with rasterio.open(str(path)) as ds:
        return _spec_of(ds), ds.nodata, (ds.crs.to_wkt() if ds.crs else None)


def read_geotiff(path: str | Path) -> tuple[np.ndarray, GridSpec]:
    """A GeoTIFF grid as written here: values with rows from the south, NaN for blank nodes."""
    rasterio = _rasterio()
    with rasterio.open(str(path)) as ds:
        return ds.read(1, masked=True).astype(np.float64).filled(np.nan)[::-1], _spec_of(ds)


def _spec_of(ds: Any) -> GridSpec:
    """The nodes of a north-up raster whose pixels are centred on them (the inverse of
    :meth:`GridSpec.corner_transform`)."""
    t = ds.transform
    return GridSpec(t.c + t.a / 2, t.f + t.e * (ds.height - 0.5), t.a, -t.e, ds.width, ds.height)
