"""``aldpat grd2bin``: Surfer grids become georeferenced ArcGIS grids that GDAL (EHdr,
AAIGrid) reads with the same values, nodata, size, CRS and node-centred cells."""

from __future__ import annotations

import numpy as np
import pytest
import rasterio  # test-only dependency

from aldpat.core.grid_extent import GridSpec
from aldpat.io.surfer import FORMATS, read_surfer, write_surfer
from aldpat.tasks import get_task

SPEC = GridSpec(640000.0, 4300000.0, 1.0, 1.0, 9, 6)


def surfer_grid(path, fmt="surfer7"):
    rows, cols = np.mgrid[0:SPEC.ny, 0:SPEC.nx]
    vals = 50.0 + rows * 0.5 + cols * 0.25
    vals[2, 3] = np.nan
    write_surfer(path, vals, SPEC, fmt=fmt)
    return vals


@pytest.mark.parametrize("fmt", FORMATS)
def test_float_grid_with_prj_in_gdal(tmp_path, fmt):
    vals = surfer_grid(tmp_path / "t.grd", fmt)
    report = get_task("grd2bin")([tmp_path / "t.grd"], crs="17N", odir=str(tmp_path / "arc"))
    assert report.exit_code == 0, report.results[0].error
    assert sorted(p.name for p in (tmp_path / "arc").iterdir()) == ["t.flt", "t.hdr", "t.log", "t.prj"]
    with rasterio.open(tmp_path / "arc" / "t.flt") as ds:
        assert ds.driver == "EHdr" and (ds.width, ds.height) == (SPEC.nx, SPEC.ny)
        assert ds.crs.to_epsg() == 32617 and ds.nodata == -9999.0
        band = ds.read(1, masked=True)
        np.testing.assert_allclose(band.filled(np.nan)[::-1], vals, rtol=1e-6, equal_nan=True)
        assert band.mask[SPEC.ny - 1 - 2, 3]
        assert ds.xy(SPEC.ny - 1, 0) == pytest.approx((SPEC.xmin, SPEC.ymin))


def test_ascii_grid_and_custom_nodata(tmp_path, runner, cli):
    vals = surfer_grid(tmp_path / "t.grd", "surfer6-ascii")
    res = runner.invoke(cli, ["grd2bin", str(tmp_path / "t.grd"), "--to", "asc", "--nodata", "-1",
                              "--odir", str(tmp_path)])
    assert res.exit_code == 0, res.output
    with rasterio.open(tmp_path / "t.asc") as ds:
        assert ds.driver == "AAIGrid" and ds.nodata == -1.0 and ds.crs is None
        np.testing.assert_allclose(ds.read(1, masked=True).filled(np.nan)[::-1], vals, equal_nan=True)
        assert ds.xy(0, SPEC.nx - 1) == pytest.approx((SPEC.xmax, SPEC.ymax))


def test_points_to_arcgis_end_to_end(tmp_path):
    x, y = np.meshgrid(np.arange(0.0, 10.5, 0.5) + 300000, np.arange(0.0, 8.5, 0.5) + 5000000)
    z = 7.0 + 0.1 * (x - 300000) + 0.3 * (y - 5000000)
    np.savetxt(tmp_path / "p.txt", np.column_stack([x.ravel(), y.ravel(), z.ravel()]), fmt="%.4f")
    assert get_task("grid")([tmp_path / "p.txt"], cell=1.0, method="linear", odir=str(tmp_path)).exit_code == 0
    assert get_task("grd2bin")([tmp_path / "p_linear.grd"], crs="EPSG:32633", odir=str(tmp_path)).exit_code == 0
    _grid, _spec = read_surfer(tmp_path / "p_linear.grd")
    with rasterio.open(tmp_path / "p_linear.flt") as ds:
        for px, py in [(300000.0, 5000000.0), (300004.0, 5000003.0), (300010.0, 5000008.0)]:
            row, col = ds.index(px, py)
            assert ds.read(1)[row, col] == pytest.approx(7.0 + 0.1 * (px - 300000) + 0.3 * (py - 5000000), abs=1e-4)


def test_not_a_surfer_grid_is_one_line(tmp_path, runner, cli):
    bad = tmp_path / "bad.grd"
    bad.write_text("hello\n")
    res = runner.invoke(cli, ["grd2bin", str(bad)])
    assert res.exit_code == 1 and "bad.grd" in res.output and "Traceback" not in res.output
    surfer_grid(tmp_path / "t.grd")
    res = runner.invoke(cli, ["grd2bin", str(tmp_path / "t.grd"), "--crs", "EPSG:999999"])
    assert res.exit_code != 0 and "unknown CRS" in res.output
    assert not (tmp_path / "t.flt").exists()
