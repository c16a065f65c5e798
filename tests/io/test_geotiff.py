"""GeoTIFF and COG grids: read back by GDAL (rasterio) with the values, nodata, CRS and node
coordinates of the Surfer grid of the same nodes; a COG has GDAL's COG layout and overviews."""

from __future__ import annotations

import builtins

import numpy as np
import pytest
import rasterio

from aldpat.core.grid_extent import GridSpec
from aldpat.errors import DataError, UsageError
from aldpat.io.geotiff import write_geotiff
from aldpat.io.surfer import write_surfer

SPEC = GridSpec(640000.0, 4300000.0, 2.0, 2.0, 600, 300)  # 600 x 300 nodes of 2 m


def values() -> np.ndarray:
    rows, cols = np.mgrid[0:SPEC.ny, 0:SPEC.nx]
    v = 100.0 + 0.01 * cols + 0.5 * rows  # rises to the north: row order shows
    v[10:20, 30:40] = np.nan
    return v


@pytest.mark.parametrize("cog", [False, True])
def test_values_nodata_crs_and_node_centres(tmp_path, cog):
    path = write_geotiff(tmp_path / "g.tif", values(), SPEC, cog=cog, crs="17N")
    with rasterio.open(path) as ds:
        assert (ds.width, ds.height, ds.count, ds.dtypes[0]) == (SPEC.nx, SPEC.ny, 1, "float32")
        assert ds.nodata == -9999.0 and ds.crs.to_epsg() == 32617
        band = ds.read(1, masked=True)[::-1]  # back to rows from the south
        assert band.mask[10:20, 30:40].all() and band.mask.sum() == 100
        np.testing.assert_allclose(band.filled(np.nan), values(), rtol=0, atol=1e-4, equal_nan=True)
        # the pixel of node (row, col) is centred on that node
        assert ds.xy(SPEC.ny - 1, 0) == pytest.approx((SPEC.xmin, SPEC.ymin))
        assert ds.xy(0, SPEC.nx - 1) == pytest.approx((SPEC.xmax, SPEC.ymax))
        assert ds.compression.name == "deflate" and ds.tags(ns="IMAGE_STRUCTURE")["PREDICTOR"] == "3"
        assert ds.block_shapes == [(256, 256)]
        layout = ds.tags(ns="IMAGE_STRUCTURE").get("LAYOUT")
        if cog:
            assert layout == "COG" and ds.overviews(1) == [2, 4]  # halved until under a 256-pixel block
        else:
            assert layout is None and ds.overviews(1) == []


def test_same_nodes_same_coordinates_as_the_surfer_grid(tmp_path):
    write_surfer(tmp_path / "g.grd", values(), SPEC)
    write_geotiff(tmp_path / "g.tif", values(), SPEC)
    with rasterio.open(tmp_path / "g.grd") as surfer, rasterio.open(tmp_path / "g.tif") as tif:
        assert tif.transform.almost_equals(surfer.transform)
        np.testing.assert_allclose(tif.read(1, masked=True).filled(np.nan), surfer.read(1, masked=True).filled(np.nan),
                                   atol=1e-4, equal_nan=True)


def test_a_node_holding_the_nodata_value_is_refused(tmp_path):
    v = values()
    v[0, 0] = -9999.0
    with pytest.raises(DataError, match="nodata value"):
        write_geotiff(tmp_path / "g.tif", v, SPEC)
    assert not (tmp_path / "g.tif").exists()


def test_without_rasterio_the_message_says_how_to_install_it(tmp_path, monkeypatch):
    real_import = builtins.__import__

    def no_rasterio(name, *args, **kwargs):
        if name == "rasterio" or name.startswith("rasterio."):
            raise ImportError(name)
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_rasterio)
    for mod in [m for m in __import__("sys").modules if m == "rasterio" or m.startswith("rasterio.")]:
        monkeypatch.delitem(__import__("sys").modules, mod)
    with pytest.raises(UsageError, match=r"pip install 'aldpat\[geotiff\]'"):
        write_geotiff(tmp_path / "g.tif", values(), SPEC)
