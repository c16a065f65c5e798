"""Surfer grids: round trips, GDAL (GSAG, GSBG, GS7BG) reading what we write, and us reading
what GDAL writes; node-centre georeferencing, blanks, the Surfer 6 binary size limit."""

from __future__ import annotations

import struct

import numpy as np
import pytest
import rasterio

from aldpat.core.grid_extent import GridSpec
from aldpat.errors import DataError, InputFormatError, OutputExistsError, UsageError
from aldpat.io.surfer import BLANK, FORMATS, read_surfer, surfer_format, write_surfer

DRIVERS = {"surfer7": "GS7BG", "surfer6": "GSBG", "surfer6-ascii": "GSAG"}
SPEC = GridSpec(500000.0, 4200000.0, 2.0, 2.0, 7, 5)


def sample_values() -> np.ndarray:
    """Distinct value per node (row from the south * 100 + column), two blanks."""
    rows, cols = np.mgrid[0:SPEC.ny, 0:SPEC.nx]
    vals = 100.0 * rows + cols + 0.25
    vals[0, 0] = np.nan  # south-west corner
    vals[3, 5] = np.nan
    return vals


@pytest.mark.parametrize("fmt", FORMATS)
def test_round_trip(tmp_path, fmt):
    vals = sample_values()
    path = write_surfer(tmp_path / "g.grd", vals, SPEC, fmt=fmt)
    assert surfer_format(path) == fmt
    back, spec = read_surfer(path)
    assert (spec.nx, spec.ny) == (SPEC.nx, SPEC.ny)
    assert spec.xmin == SPEC.xmin and spec.ymin == SPEC.ymin
    assert spec.dx == pytest.approx(2.0, abs=1e-12) and spec.dy == pytest.approx(2.0, abs=1e-12)
    np.testing.assert_array_equal(np.isnan(back), np.isnan(vals))
    np.testing.assert_allclose(back, vals, rtol=1e-7, equal_nan=True)


@pytest.mark.parametrize("fmt", FORMATS)
def test_gdal_reads_values_nodata_size_and_node_centres(tmp_path, fmt):
    vals = sample_values()
    path = write_surfer(tmp_path / "g.grd", vals, SPEC, fmt=fmt)
    with rasterio.open(path) as ds:
        assert ds.driver == DRIVERS[fmt]
        assert (ds.width, ds.height) == (SPEC.nx, SPEC.ny)
        assert ds.nodata == pytest.approx(BLANK, rel=1e-6)
        band = ds.read(1, masked=True)
        # GDAL rows run from the north: our row r is GDAL row ny-1-r.
        np.testing.assert_array_equal(band.mask[::-1], np.isnan(vals))
        np.testing.assert_allclose(band.filled(np.nan)[::-1], vals, rtol=1e-7, equal_nan=True)
        # centre of GDAL pixel (col, row) is the node: south-west node = (xmin, ymin)
        x, y = ds.xy(SPEC.ny - 1, 0)
        assert (x, y) == pytest.approx((SPEC.xmin, SPEC.ymin), abs=1e-6)
        x, y = ds.xy(0, SPEC.nx - 1)
        assert (x, y) == pytest.approx((SPEC.xmax, SPEC.ymax), abs=1e-6)


@pytest.mark.parametrize("fmt", FORMATS)
def test_reads_grids_gdal_writes(tmp_path, fmt):
    from rasterio.shutil import copy
    from rasterio.transform import Affine

    data = (np.arange(20, dtype=np.float32).reshape(4, 5) * 1.5 + 10)  # north row first
    data[1, 2] = BLANK
    src = tmp_path / "src.tif"
    with rasterio.open(src, "w", driver="GTiff", width=5, height=4, count=1, dtype="float32", nodata=BLANK,
                       transform=Affine(10.0, 0.0, 1000.0, 0.0, -10.0, 2000.0)) as ds:
        ds.write(data, 1)
    out = tmp_path / "gdal.grd"
    copy(src, out, driver=DRIVERS[fmt])
    vals, spec = read_surfer(out)
    assert surfer_format(out) == fmt
    assert (spec.nx, spec.ny) == (5, 4)
    # pixel corners 1000..1050 x 1960..2000 -> node centres 1005..1045, 1965..1995
    assert (spec.xmin, spec.ymin, spec.xmax, spec.ymax) == pytest.approx((1005, 1965, 1045, 1995))
    expect = data[::-1].astype(float)
    expect[expect >= 1.7e38] = np.nan
    assert np.isnan(vals[2, 2])
    np.testing.assert_allclose(vals, expect, rtol=1e-6, equal_nan=True)


def test_anything_from_1_7e38_is_blank(tmp_path):
    path = tmp_path / "a.grd"
    path.write_text("DSAA\n2 2\n0 1\n0 1\n1 2\n1 1.71e38\n2 1.70141e+38\n")
    vals, _ = read_surfer(path)
    assert np.isnan(vals[0, 1]) and np.isnan(vals[1, 1])
    assert vals[0, 0] == 1 and vals[1, 0] == 2


def test_surfer6_binary_limit_is_a_clear_error(tmp_path):
    spec = GridSpec(0.0, 0.0, 1.0, 1.0, 32768, 2)
    with pytest.raises(DataError, match="32767"):
        write_surfer(tmp_path / "big.grd", np.zeros(spec.shape), spec, fmt="surfer6")
    assert not list(tmp_path.iterdir())  # nothing half written


def test_surfer7_custom_blank_is_honoured_by_gdal(tmp_path):
    vals = sample_values()
    path = write_surfer(tmp_path / "c.grd", vals, SPEC, fmt="surfer7", blank=-9999.0)
    back, _ = read_surfer(path)
    np.testing.assert_array_equal(np.isnan(back), np.isnan(vals))
    with rasterio.open(path) as ds:
        assert ds.nodata == -9999.0
    with pytest.raises(UsageError):
        write_surfer(tmp_path / "d.grd", vals, SPEC, fmt="surfer6", blank=-9999.0)


def test_existing_output_needs_overwrite(tmp_path):
    path = write_surfer(tmp_path / "g.grd", sample_values(), SPEC)
    with pytest.raises(OutputExistsError):
        write_surfer(path, sample_values(), SPEC)
    write_surfer(path, sample_values(), SPEC, fmt="surfer6", overwrite=True)
    assert surfer_format(path) == "surfer6"


@pytest.mark.parametrize("content", [b"XXXX1234", b"DSBB\x02\x00", b"DSAA\n3 3\n0 1\n0 1\n0 1\n1 2 3\n",
                                     struct.pack("<iii", 0x42525344, 4, 1)])
def test_bad_files_are_format_errors(tmp_path, content):
    path = tmp_path / "bad.grd"
    path.write_bytes(content)
    with pytest.raises(InputFormatError) as err:
        read_surfer(path)
    assert "bad.grd" in str(err.value)


def test_ascii_header_is_plain_numbers_whatever_built_the_spec(tmp_path):
    spec = GridSpec(np.float64(500000.0), np.float32(4200000.0), np.float64(2.0), 2.0, np.int64(7), 5)
    write_surfer(tmp_path / "a.grd", sample_values(), spec, fmt="surfer6-ascii")
    head = (tmp_path / "a.grd").read_text().splitlines()[:5]
    assert head[:4] == ["DSAA", "7 5", "500000.0 500012.0", "4200000.0 4200008.0"]
    assert head[4] == "1.25 406.25"  # z range of the non-blank nodes
