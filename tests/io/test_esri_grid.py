"""ArcGIS grids: GDAL's EHdr and AAIGrid drivers read what we write with the right values,
nodata, size, cell-centre georeferencing and CRS; our readers read them back."""

from __future__ import annotations

import numpy as np
import pytest
import rasterio

from aldpat.core.grid_extent import GridSpec
from aldpat.errors import DataError
from aldpat.io.esri_grid import (
    read_ascii_grid,
    read_float_grid,
    write_ascii_grid,
    write_float_grid,
)

SPEC = GridSpec(300000.0, 4100000.0, 0.5, 0.5, 6, 4)


def values() -> np.ndarray:
    rows, cols = np.mgrid[0:SPEC.ny, 0:SPEC.nx]
    vals = 10.0 * rows + cols + 0.125
    vals[1, 4] = np.nan
    return vals


def check_gdal(path, driver: str, vals: np.ndarray, nodata: float, epsg: int | None) -> None:
    with rasterio.open(path) as ds:
        assert ds.driver == driver
        assert (ds.width, ds.height) == (SPEC.nx, SPEC.ny)
        assert ds.nodata == nodata
        band = ds.read(1, masked=True)
        np.testing.assert_array_equal(band.mask[::-1], np.isnan(vals))
        np.testing.assert_allclose(band.filled(np.nan)[::-1], vals, equal_nan=True)
        assert ds.xy(SPEC.ny - 1, 0) == pytest.approx((SPEC.xmin, SPEC.ymin))
        assert ds.xy(0, SPEC.nx - 1) == pytest.approx((SPEC.xmax, SPEC.ymax))
        if epsg is None:
            assert ds.crs is None
        else:
            assert ds.crs.to_epsg() == epsg


def test_float_grid_opens_in_gdal_with_crs(tmp_path):
    vals = values()
    paths = write_float_grid(tmp_path / "t.flt", vals, SPEC, crs="EPSG:26917")
    assert [p.suffix for p in paths] == [".flt", ".hdr", ".prj"]
    hdr = (tmp_path / "t.hdr").read_text()
    for key in ("NCOLS", "NROWS", "XLLCORNER", "YLLCORNER", "CELLSIZE", "NODATA_VALUE"):
        assert key in hdr
    assert "BYTEORDER     LSBFIRST" in hdr
    assert "XLLCORNER     299999.75" in hdr  # half a cell west of the first node
    assert (tmp_path / "t.flt").stat().st_size == SPEC.nx * SPEC.ny * 4
    check_gdal(tmp_path / "t.flt", "EHdr", vals, -9999.0, 26917)
    back, spec = read_float_grid(tmp_path / "t.flt")
    assert spec == SPEC
    np.testing.assert_allclose(back, vals, equal_nan=True)


def test_ascii_grid_opens_in_gdal(tmp_path):
    vals = values()
    write_ascii_grid(tmp_path / "t.asc", vals, SPEC, nodata=-32768.0)
    assert not (tmp_path / "t.prj").exists()
    check_gdal(tmp_path / "t.asc", "AAIGrid", vals, -32768.0, None)
    back, spec = read_ascii_grid(tmp_path / "t.asc")
    assert spec == SPEC
    np.testing.assert_allclose(back, vals, equal_nan=True)


def test_non_square_cells_and_nodata_clash_are_refused(tmp_path):
    with pytest.raises(DataError, match="square"):
        write_float_grid(tmp_path / "a.flt", np.zeros((3, 3)), GridSpec(0, 0, 1, 2, 3, 3))
    vals = values()
    vals[0, 0] = -9999.0
    with pytest.raises(DataError, match="nodata"):
        write_float_grid(tmp_path / "b.flt", vals, SPEC)
    assert not list(tmp_path.iterdir())


def test_bad_headers_and_sizes_name_the_file(tmp_path):
    from aldpat.errors import InputFormatError

    (tmp_path / "a.asc").write_text("ncols 0\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n")
    with pytest.raises(InputFormatError, match="a.asc"):
        read_ascii_grid(tmp_path / "a.asc")
    write_float_grid(tmp_path / "b.flt", values(), SPEC)
    with open(tmp_path / "b.flt", "ab") as fh:
        fh.write(b"\0\0\0\0")
    with pytest.raises(InputFormatError, match="expected 24 cells, found 25"):
        read_float_grid(tmp_path / "b.flt")
