"""Geoid heights: the NGA's EGM96 test values within 0.1 m (windows of the real grid in
tests/data), reverse direction, GeoTIFF grids, re-projection to State Plane feet, and points
outside the grid reported by number instead of a silent zero or NaN."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pyproj
import pytest

from aldpat.core.heights import HeightConverter, parse_crs
from aldpat.errors import DataError, InputMissingError, UsageError

DATA = Path(__file__).resolve().parents[1] / "data"
#: (latitude, longitude 0..360, N) published by the NGA for EGM96
NGA = [tuple(row) for row in np.loadtxt(DATA / "egm96_nga_values.txt")]


def window(k: int) -> Path:
    return DATA / f"egm96_15_nga{k}.gtx"


def lon180(lon: float) -> float:
    return (lon + 180.0) % 360.0 - 180.0


@pytest.mark.parametrize("k", range(1, 7))
def test_nga_egm96_values(k):
    lat, lon, n = NGA[k - 1]
    conv = HeightConverter("EPSG:4326", window(k))
    assert conv.undulation([lon180(lon)], [lat])[0] == pytest.approx(n, abs=0.1)
    x, y, h = conv(np.array([lon180(lon)]), np.array([lat]), np.array([100.0]))
    assert h[0] == pytest.approx(100.0 - n, abs=0.1)  # H = h - N
    assert (x[0], y[0]) == (lon180(lon), lat)


def test_utm_input_and_reverse_round_trip():
    lat, lon, n = NGA[0]
    utm = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32616", always_xy=True)
    ex, ny = utm.transform(lon180(lon), lat)
    x = np.array([ex, ex + 100.0])
    y = np.array([ny, ny - 50.0])
    h = np.array([200.0, 150.0])
    forward = HeightConverter("16N", window(1))
    _, _, big_h = forward(x, y, h)
    assert big_h[0] == pytest.approx(200.0 - n, abs=0.1)
    _, _, back = HeightConverter("utm zone 16", window(1), reverse=True)(x, y, big_h)
    np.testing.assert_allclose(back, h, atol=1e-9)


def test_geotiff_grid_gives_the_same_undulations(tmp_path):
    import rasterio  # test-only dependency
    from rasterio.transform import Affine

    raw = window(3).read_bytes()
    lat0, lon0, dlat, dlon, rows, cols = struct.unpack(">4d2i", raw[:40])
    vals = np.frombuffer(raw, ">f4", rows * cols, 40).reshape(rows, cols)
    tif = tmp_path / "geoid.tif"
    # GTX values are at nodes; a GeoTIFF pixel is centred on them (north row first)
    transform = Affine(dlon, 0, lon0 - dlon / 2, 0, -dlat, lat0 + (rows - 0.5) * dlat)
    with rasterio.open(tif, "w", driver="GTiff", width=cols, height=rows, count=1, dtype="float32",
                       crs="EPSG:4326", transform=transform) as ds:
        ds.write(vals[::-1].astype("float32"), 1)
    lat, lon, _n = NGA[2]
    gtx = HeightConverter("EPSG:4326", window(3)).undulation([lon], [lat])[0]
    assert HeightConverter("EPSG:4326", tif).undulation([lon], [lat])[0] == pytest.approx(gtx, abs=1e-4)


def test_outside_the_grid_names_the_point():
    conv = HeightConverter("EPSG:4326", window(1))
    lat, lon, _ = NGA[0]
    x = np.array([lon180(lon), lon180(lon) + 5.0, lon180(lon) + 6.0])
    y = np.array([lat, lat, lat])
    with pytest.raises(DataError) as err:
        conv(x, y, np.zeros(3), first=1000, path="strip.txt")
    text = str(err.value)
    assert text.startswith("strip.txt: point 1002 ") and "outside the geoid grid" in text and "1 more" in text


def test_state_plane_feet_and_z_units(tmp_path):
    # Florida East (NAD83, US survey feet): its origin (81W, 24 20'N) maps to the false
    # easting 656166.667 ftUS, northing 0.
    lat, lon = 24.0 + 20.0 / 60.0, -81.0
    # a 4 x 4 window of constant N = 10 m centred on the origin
    conv = HeightConverter("EPSG:4326", _constant_gtx(tmp_path / "const.gtx", lat, lon, 10.0), to_crs="EPSG:2236", z_unit="us-ft")
    x, y, z = conv(np.array([lon]), np.array([lat]), np.array([100.0]))
    assert x[0] == pytest.approx(656166.667, abs=0.01)
    assert y[0] == pytest.approx(0.0, abs=0.01)
    assert z[0] == pytest.approx(100.0 - 10.0 / 0.3048006096, abs=1e-6)


def _constant_gtx(path: Path, lat: float, lon: float, value: float) -> Path:
    path.write_bytes(struct.pack(">4d2i", lat - 1, lon - 1, 0.5, 0.5, 5, 5) + np.full(25, value, ">f4").tobytes())
    return path


@pytest.mark.parametrize("text, epsg", [("EPSG:26917", 26917), ("26917", 26917), ("17N", 32617), ("17", 32617),
                                        ("utm17s", 32717), ("UTM zone 17 south", 32717)])
def test_parse_crs(text, epsg):
    assert parse_crs(text).to_epsg() == epsg


def test_bad_parameters_are_reported_before_work(tmp_path):
    with pytest.raises(UsageError, match="unknown CRS"):
        HeightConverter("EPSG:999999", window(1))
    with pytest.raises(UsageError, match="UTM zone"):
        parse_crs("61N")
    with pytest.raises(InputMissingError):
        HeightConverter("EPSG:4326", tmp_path / "nope" / "geoid.gtx")
    with pytest.raises(UsageError, match="cannot open geoid grid"):
        HeightConverter("EPSG:4326", "no_such_grid_name.tif")
    junk = tmp_path / "junk.gtx"
    junk.write_text("not a grid")
    with pytest.raises(UsageError, match="cannot open geoid grid"):
        HeightConverter("EPSG:4326", junk)


@pytest.mark.parametrize("header, message", [
    ((-90.0, 0.0, 0.25, 0.25, 2**30, 2**30), "its header says 1,073,741,824 x 1,073,741,824 values, the file holds 25"),
    ((-90.0, 0.0, -0.25, 0.25, 10, 10), "its GTX header is not a grid"),
    ((float("nan"), 0.0, 0.25, 0.25, 10, 10), "its GTX header is not a grid"),
    ((-90.0, 0.0, 0.25, 0.25, 0, 10), "its GTX header is not a grid"),
])
def test_a_gtx_header_not_describing_its_file_is_refused_before_proj_reads_it(tmp_path, header, message):
    grid = tmp_path / "hostile.gtx"
    grid.write_bytes(struct.pack(">4d2i", *header) + bytes(100))
    with pytest.raises(UsageError, match=message):
        HeightConverter("EPSG:4326", grid)


def test_grid_found_by_name_in_proj_data_folders(tmp_path):
    import shutil

    folder = tmp_path / "proj"
    folder.mkdir()
    shutil.copy(window(2), folder / "egm96_window_for_test.gtx")
    pyproj.datadir.append_data_dir(str(folder))
    lat, lon, n = NGA[1]
    for name in ("egm96_window_for_test.gtx", str(tmp_path / "worksheet" / "egm96_window_for_test.gtx")):
        conv = HeightConverter("EPSG:4326", name)  # a worksheet hands names over as rebased paths
        assert conv.geoid_name == "egm96_window_for_test.gtx"
        assert conv.undulation([lon180(lon)], [lat])[0] == pytest.approx(n, abs=0.1)
