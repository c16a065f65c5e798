"""``import aldpat`` as a notebook uses it: ``aldpat.ground`` and ``aldpat.dtm`` on the repository's
real sample files, equal to what the commands write for the same points and parameters, bad
parameters refused at the call, and ``docs/api.md``'s examples run as written."""

from __future__ import annotations

import doctest
import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import laspy
import numpy as np
import pytest

import aldpat
from tests.cli.fresh import aldpat as run_aldpat

REPO = Path(__file__).resolve().parents[1]
STRIP = REPO / "tests" / "data" / "fsite5_strip.laz"  # real points of an ISPRS site, LAS 1.2 with a CRS
SAMPLE = REPO / "jobs" / "data" / "samp24.txt"  # an ISPRS reference sample as ASCII


def test_the_package_shows_its_api():
    names = dir(aldpat)
    for name in ("ground", "dtm", "Raster", "ParamError", "AldpatError", "__version__"):
        assert name in names
    assert issubclass(aldpat.ParamError, ValueError) and issubclass(aldpat.ParamError, aldpat.AldpatError)
    # the API is loaded when first used: importing the package (as every command does) stays light
    probe = "import sys, aldpat; print('aldpat.api' in sys.modules, 'aldpat.tasks' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert done.stdout.split() == ["False", "False"]


def _classes(path: Path) -> np.ndarray:
    if path.suffix == ".laz":
        return np.asarray(laspy.read(path).classification)
    return np.loadtxt(path)[:, -1].astype(int)


@pytest.mark.parametrize("source, algorithm, options", [
    (STRIP, "gapm", {"cell": 1.5}),
    (SAMPLE, "gapm", {}),
    (STRIP, "slope", {"max_slope": 0.5}),
], ids=["laz-gapm", "text-gapm", "laz-slope"])
def test_ground_is_the_commands_class_2(source, algorithm, options, tmp_path):
    args = [a for k, v in options.items() for a in (f"--{k.replace('_', '-')}", str(v))]
    run_aldpat("filter", algorithm, source, "--result", "classified", "--odir", tmp_path, *args).ok()
    written = _classes(tmp_path / f"{source.stem}_{algorithm}{source.suffix}")
    flags = aldpat.ground(source, algorithm, **options)
    assert flags.dtype == bool and flags.shape == written.shape
    assert 0 < flags.sum() < len(flags)
    np.testing.assert_array_equal(flags, written == 2)


def test_every_form_of_points_gives_the_same_flags():
    las = laspy.read(STRIP)
    flags = aldpat.ground(str(STRIP))
    x, y, z = np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)
    for points in (las, STRIP, np.column_stack([x, y, z]), (x, y, z), (list(x), list(y), list(z)), las.points):
        np.testing.assert_array_equal(aldpat.ground(points), flags)


def test_a_selection_of_a_las_files_points_is_points():
    """``aldpat.ground(las.points[keep])`` -- a notebook's selection of a file's points -- was refused
    with "argument of type 'NoneType' is not iterable": a point record carries the point format,
    scales and offsets a header would give, and is taken as the LasData holding just those points."""
    las = laspy.read(STRIP)
    keep = np.asarray(las.z) < np.median(las.z) + 5
    selected = laspy.LasData(las.header)
    selected.points = las.points[keep]
    np.testing.assert_array_equal(aldpat.ground(las.points[keep]), aldpat.ground(selected))
    assert aldpat.dtm(las.points[keep], cell=5.0).array.shape == aldpat.dtm(selected, cell=5.0).array.shape


def test_dtm_is_the_commands_dtm(tmp_path):
    import rasterio

    run_aldpat("dtm", STRIP, "--cell", "2", "--odir", tmp_path).ok()
    dem = aldpat.dtm(STRIP, cell=2.0)
    with rasterio.open(tmp_path / "fsite5_strip_dtm.tif") as ds:
        band, transform, crs, nodata = ds.read(1), ds.transform, ds.crs, ds.nodata
    assert dem.array.dtype == np.float32 and dem.array.shape == band.shape
    np.testing.assert_array_equal(dem.array, band)
    assert rasterio.Affine(*dem.transform) == transform and dem.nodata == nodata
    assert dem.crs is not None and dem.crs.to_epsg() == crs.to_epsg()
    assert dem.geotransform == transform.to_gdal()
    # first row north: the transform's y step is negative, and the top row lies at the north edge
    assert dem.transform[4] < 0 and dem.transform[5] > float(laspy.read(STRIP).header.maxs[1])

    for name, layout in (("api.tif", None), ("api.cog.tif", "COG")):
        assert dem.write(tmp_path / name) == tmp_path / name
        with rasterio.open(tmp_path / name) as ds:
            np.testing.assert_array_equal(ds.read(1), band)
            assert ds.transform == transform and ds.crs == crs and ds.nodata == nodata
            assert ds.tags(ns="IMAGE_STRUCTURE").get("LAYOUT") == layout
    with pytest.raises(FileExistsError):
        dem.write(tmp_path / "api.tif")
    dem.write(tmp_path / "api.tif", overwrite=True)
    with pytest.raises(ValueError, match="tif"):
        dem.write(tmp_path / "api.png")


def test_dtm_takes_the_filters_parameters_and_its_own(tmp_path):
    params = tmp_path / "gapm.toml"
    params.write_text("cell = 0.8\n")
    run_aldpat("dtm", STRIP, "--cell", "2", "--filter-params", params, "--nodata", "-1", "--odir", tmp_path).ok()
    import rasterio

    with rasterio.open(tmp_path / "fsite5_strip_dtm.tif") as ds:
        band = ds.read(1)
    for given in ({"filter_params": params}, {"filter_params": {"cell": 0.8}}):
        dem = aldpat.dtm(STRIP, cell=2.0, nodata=-1, **given)
        assert dem.nodata == -1
        np.testing.assert_array_equal(dem.array, band)


@pytest.mark.parametrize("call, words", [
    (lambda: aldpat.ground(STRIP, cell=-1), "ground: cell: -1 is out of range (must be > 0)"),
    (lambda: aldpat.ground("no/such/file.laz", cell=0), "ground: cell: 0 is out of range"),  # before reading
    (lambda: aldpat.ground(STRIP, cel=2), "did you mean 'cell'"),
    (lambda: aldpat.ground(STRIP, result="classified"), "result: an option of the command"),
    (lambda: aldpat.ground(STRIP, chunk=100), "chunk: an option of the command"),
    (lambda: aldpat.ground(STRIP, "gapx"), "algorithm: no filter 'gapx'"),
    (lambda: aldpat.ground(STRIP, window_series=[4, 2]), "window_series"),
    (lambda: aldpat.ground(np.zeros((5, 2))), "points: expected"),
    (lambda: aldpat.ground([["a", "b", "c"]]), "points: expected"),  # not numpy's bare ValueError
    (lambda: aldpat.ground({"x": 1}), "points: expected"),  # nor its TypeError
    (lambda: aldpat.ground((["a"], [1.0], [2.0])), "points: expected"),
    (lambda: aldpat.ground(STRIP, cell=np.float32("nan")), "ground: cell: expected a finite number"),
    (lambda: aldpat.ground(STRIP, cell=True), "ground: cell: expected a number, got True"),
    (lambda: aldpat.ground(STRIP, low_outlier_window=np.float32(2.5)), "expected a whole number, got 2.5"),
    (lambda: aldpat.ground(STRIP, cell=np.array([1.5])), "got [1.5] (numpy.ndarray)"),  # its type named
    (lambda: aldpat.dtm(STRIP, cell=0), "dtm: cell: 0 is out of range"),
    (lambda: aldpat.dtm(STRIP, crs="EPSG:0"), "dtm: crs:"),
    (lambda: aldpat.dtm(STRIP, mosaic="x.vrt"), "mosaic: an option of the command 'aldpat dtm'"),
    (lambda: aldpat.dtm(STRIP, filter_params={"cell": -2}), "dtm: cell: -2 is out of range"),
    (lambda: aldpat.dtm(STRIP, algorithm="outlier"), "dtm: algorithm"),
    (lambda: aldpat.ground("http://example.com/a.laz"), "points: 'http://example.com/a.laz' is a URL"),
    (lambda: aldpat.ground("/vsicurl/https://example.com/a.laz"), "is a GDAL virtual file system path"),
    (lambda: aldpat.ground(np.zeros((5, 3), complex)), "points: expected real coordinates, got an array of complex128"),
    (lambda: aldpat.dtm(STRIP, filter_params=["cell", 2]), "dtm: filter_params: expected a mapping"),
    (lambda: aldpat.dtm(STRIP, filter_params="s3://bucket/gapm.toml"), "dtm: filter_params: 's3://bucket/gapm.toml' is a URL"),
], ids=lambda v: v if isinstance(v, str) else "")
def test_a_bad_parameter_is_refused_at_the_call_by_name(call, words):
    with pytest.raises(aldpat.ParamError) as caught:
        call()
    assert isinstance(caught.value, ValueError)
    assert words in str(caught.value)


def test_numpy_arrays_for_list_parameters_are_their_values():
    """A notebook holds its windows and thresholds as numpy arrays: a 1-D array is the list of its
    values (each checked as a list's would be), a 2-D one is refused by name."""
    as_lists = {"window_series": [1, 2, 4, 8], "cluster_thresholds": [0.3, 0.5, 1.0, 1.0],
                "row_windows": [1, 2, 4, 8], "column_windows": [1, 2, 4]}
    as_arrays = {k: np.asarray(v) for k, v in as_lists.items()}
    np.testing.assert_array_equal(aldpat.ground(STRIP, cell=1.5, **as_arrays), aldpat.ground(STRIP, cell=1.5, **as_lists))
    with pytest.raises(aldpat.ParamError, match=r"row_windows: \[16\] not in window_series"):
        aldpat.ground(STRIP, **{**as_arrays, "row_windows": np.array([4, 16], np.int64)})
    with pytest.raises(aldpat.ParamError, match="window_series: expected a whole number"):
        aldpat.ground(STRIP, window_series=np.array([[1, 2], [4, 8]]))


def test_float32_coordinates_of_a_survey_are_filtered_with_a_warning_of_their_steps():
    """At UTM northings float32 keeps steps of 0.5 m: the points arrive rounded, and the warning
    says so where the call is made; the same points moved near the origin keep millimetres and
    pass without one."""
    las = laspy.read(STRIP)
    xyz = np.c_[las.x, las.y, las.z]
    with pytest.warns(UserWarning, match=r"float32 coordinates as large as 5\.42\d*e\+06 hold steps of 0\.5 m") as got:
        aldpat.ground(xyz.astype(np.float32), cell=1.5)
    assert got[0].filename == __file__
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        local = (xyz - xyz.min(axis=0)).astype(np.float32)
        assert aldpat.ground(local, cell=1.5).shape == (len(xyz),)


def test_a_missing_file_is_an_aldpat_error_naming_it():
    with pytest.raises(FileNotFoundError) as caught:
        aldpat.ground("no/such/file.laz")
    assert isinstance(caught.value, aldpat.AldpatError) and "no/such/file.laz" in str(caught.value)


def test_the_documented_examples_run(tmp_path, monkeypatch):
    """docs/api.md's examples and the README's, run from a folder holding the repository's sample files as the
    documentation names them (tests/data, jobs/data), writing its outputs there."""
    for folder in ("tests/data", "jobs/data"):
        (tmp_path / folder).parent.mkdir(parents=True, exist_ok=True)
        os.symlink(REPO / folder, tmp_path / folder)
    monkeypatch.chdir(tmp_path)
    flags = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
    result = doctest.testfile(str(REPO / "docs" / "api.md"), module_relative=False, optionflags=flags)
    assert result.attempted >= 20
    assert result.failed == 0
    assert (tmp_path / "strip_dtm.tif").is_file() and (tmp_path / "strip_dtm.cog.tif").is_file()
    (tmp_path / "strip_dtm.tif").unlink()
    readme = doctest.testfile(str(REPO / "README.md"), module_relative=False, optionflags=flags)  # "From Python"
    assert readme.attempted >= 5 and readme.failed == 0


def test_dtm_takes_the_low_outlier_options_as_the_command_does():
    """``aldpat dtm --low-outliers``, ``--low-outlier-window``...: keywords of :func:`aldpat.dtm`
    too. Off, the DTM of a file holding one point 106 m under the ground has the pit."""
    pit = "tests/data/fsite5_pit.laz"
    default = aldpat.dtm(pit, cell=1.0)
    same = aldpat.dtm(pit, cell=1.0, low_outlier_window=3)  # gapm's own window
    off = aldpat.dtm(pit, cell=1.0, low_outliers=None)
    assert np.array_equal(default.array, same.array)
    lowest = {name: r.array[r.array != r.nodata].min() for name, r in (("default", default), ("off", off))}
    assert lowest["off"] < lowest["default"] - 100.0, lowest


def test_numpy_numbers_are_numbers():
    """A value computed with numpy (``np.float32``, ``np.int64``) is taken as the Python number it
    equals: refusing it as "expected a number, got 1.5" contradicted itself."""
    las = laspy.read(STRIP)
    xyz = np.column_stack([las.x, las.y, las.z])[:5000]
    for numpy_value, value in ((np.float32(1.5), 1.5), (np.int64(2), 2), (np.float64(2.0), 2)):
        np.testing.assert_array_equal(aldpat.ground(xyz, cell=numpy_value), aldpat.ground(xyz, cell=value))
    for window in (np.int64(3), np.int32(5), np.float32(5.0)):
        np.testing.assert_array_equal(aldpat.ground(xyz, low_outlier_window=window),
                                      aldpat.ground(xyz, low_outlier_window=int(window)))


def _noisy_strip(path: Path, returns: str) -> np.ndarray:
    """The strip written to ``path`` with points a survey sets aside lowered 40 m: 300 of class 7,
    50 of class 18, 100 withheld and, for ``returns`` "last", 150 first returns of two (the
    others last ones). Returns which points take part; none of the changed ones is at the edge
    of the extent, so the DTM of the others alone has the same nodes."""
    las = laspy.read(STRIP)
    x, y = np.asarray(las.x), np.asarray(las.y)
    rng = np.random.default_rng(7)
    inner = np.flatnonzero((x > x.min()) & (x < x.max()) & (y > y.min()) & (y < y.max()))
    picked = rng.choice(inner, 600, replace=False)
    noise, high, held, first = picked[:300], picked[300:350], picked[350:450], picked[450:]
    classes = np.zeros(len(x), np.uint8)
    classes[noise], classes[high] = 7, 18
    las.classification = classes
    las.withheld = np.isin(np.arange(len(x)), held)
    lowered = picked[:450]
    number = np.ones(len(x), np.uint8)
    if returns == "last":
        las.number_of_returns = np.full(len(x), 2, np.uint8)
        number[:] = 2
        number[first] = 1
        lowered = picked
    las.return_number = number
    z = np.asarray(las.z).copy()
    z[lowered] -= 40.0
    las.z = z
    las.write(path)
    return ~np.isin(np.arange(len(x)), lowered)


@pytest.mark.parametrize("returns", ["all", "last"])
def test_dtm_leaves_out_the_points_the_command_leaves_out(returns, tmp_path):
    """Noise classes (``ignore_classes``: 7, 18), withheld points and, with ``returns``, the other
    returns take no part in the DTM of a call, as in ``aldpat dtm``'s: a file's and a laspy
    ``LasData``'s DTM is the command's, node for node, and none is pulled down by the noise."""
    import rasterio

    source = tmp_path / "noisy.laz"
    taking_part = _noisy_strip(source, returns)
    run_aldpat("dtm", source, "--cell", "2", "--returns", returns, "--odir", tmp_path / "cli").ok()
    with rasterio.open(tmp_path / "cli" / "noisy_dtm.tif") as ds:
        band, transform = ds.read(1), ds.transform
    las = laspy.read(source)
    x, y, z = (np.asarray(v)[taking_part] for v in (las.x, las.y, las.z))
    # only the points taking part, given as x, y, z: the terrain the noise must not change
    clean = aldpat.dtm((x, y, z), cell=2.0, returns=returns).array
    for points in (source, las):
        dem = aldpat.dtm(points, cell=2.0, returns=returns)
        assert dem.array.shape == band.shape and rasterio.Affine(*dem.transform) == transform
        np.testing.assert_array_equal(dem.array == dem.nodata, band == dem.nodata)
        valued = band != dem.nodata
        np.testing.assert_allclose(dem.array[valued], band[valued], rtol=0, atol=1e-6)
        both = valued & (clean != dem.nodata)  # blank nodes differ: every point read counts for data gaps
        assert both.sum() > 0.9 * valued.sum()
        assert (dem.array[both] - clean[both]).min() > -1e-6
        assert dem.array[valued].min() >= z.min() - 1e-3  # no node within 40 m of the noise's depth


def test_a_dtm_too_large_for_memory_is_refused_before_it_is_allocated():
    """``aldpat.dtm(points, cell=0.001)`` over 100 m asked numpy for 37 GiB and raised its bare
    MemoryError (or swapped); the command refuses such a grid before making it, and so does the
    call now, with aldpat's error saying what to change."""
    rng = np.random.default_rng(0)
    xyz = np.c_[rng.uniform(0, 100, 1000), rng.uniform(0, 100, 1000), rng.uniform(0, 1, 1000)]
    with pytest.raises(aldpat.AldpatError, match=r"99933 x 99617 grid .* of 0\.001 m cells needs .*use a larger cell"):
        aldpat.dtm(xyz, cell=0.001)


@pytest.mark.parametrize("target", ["s3://bucket/dtm.tif", "/vsis3/bucket/dtm.tif", "https://example.com/dtm.tif",
                                    "/vsimem/dtm.tif", ""])
def test_a_raster_is_written_to_a_local_file_only(target, tmp_path, monkeypatch):
    """``dem.write("s3://bucket/dtm.tif")`` went to GDAL, which asked for AWS credentials (and with
    them would have written to the bucket), and left a local folder ``s3:/bucket`` behind: nothing
    but a local file is written, and nothing is made for a name that is not one."""
    monkeypatch.chdir(tmp_path)
    rng = np.random.default_rng(0)
    dem = aldpat.dtm(np.c_[rng.uniform(0, 50, 500), rng.uniform(0, 50, 500), rng.uniform(0, 1, 500)], cell=5.0)
    with pytest.raises(aldpat.AldpatError, match="raster not written: .* is (a URL|a GDAL virtual|empty)"):
        dem.write(target)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("fields, words", [
    ({"array": np.zeros((2, 3, 4))}, "Raster: array: expected a 2-D array of heights"),
    ({"array": np.zeros((0, 0))}, "Raster: array: expected a 2-D array"),
    ({"array": [["a", "b"]]}, "Raster: array: expected a 2-D array"),
    ({"transform": (1.0, 0.0)}, "Raster: transform: expected 6 finite numbers"),
    ({"transform": (1.0, 0.0, 0.0, 0.0, -1.0, float("nan"))}, "Raster: transform: expected 6 finite numbers"),
    ({"nodata": 1e300}, "Raster: nodata: expected a finite float32 value"),
    ({"nodata": "blank"}, "Raster: nodata: expected a finite float32 value"),
    ({"crs": "EPSG:0"}, "Raster: crs: unknown CRS 'EPSG:0'"),
], ids=lambda v: v if isinstance(v, str) else "")
def test_a_raster_made_by_hand_is_checked_field_by_field(fields, words):
    """``aldpat.Raster`` is the API's: one made by hand with a 3-D array, a short transform or a CRS
    as text failed when written, with numpy's "too many values to unpack", Affine's missing
    arguments or "'str' object has no attribute 'to_wkt'". Each field is checked when it is made."""
    good = {"array": np.zeros((2, 2), np.float32), "transform": (1.0, 0.0, 500.0, 0.0, -1.0, 100.0)}
    with pytest.raises(aldpat.ParamError, match=re.escape(words)):
        aldpat.Raster(**{**good, **fields})


def test_a_raster_made_by_hand_takes_rows_as_lists_and_a_crs_as_text(tmp_path):
    raster = aldpat.Raster(array=[[1.0, 2.0], [3.0, 4.0]], transform=(1, 0, 500, 0, -1, 100), crs="EPSG:32632")
    assert raster.array.shape == (2, 2) and raster.crs.to_epsg() == 32632
    import rasterio

    with rasterio.open(raster.write(tmp_path / "hand.tif")) as ds:
        assert ds.crs.to_epsg() == 32632 and ds.read(1).tolist() == [[1.0, 2.0], [3.0, 4.0]]


def test_a_search_radius_beyond_the_points_reaches_the_grid_not_further():
    """``aldpat.ground(points, algorithm="slope", search_radius=1e6)`` asked numpy for 29.1 TiB of
    cell offsets (2,000,001 x 2,000,001) and raised its MemoryError; the command said "out of
    memory". A search reaches no farther than the grid's cells: the flags are those of any radius
    spanning the strip (600 x 220 cells). A radius of more than 1,000 cells is refused by name
    before any work: each point would be compared with millions of cells."""
    las = laspy.read(STRIP)
    xyz = np.c_[las.x, las.y, las.z][::4]
    np.testing.assert_array_equal(aldpat.ground(xyz, algorithm="slope", search_radius=999.0),
                                  aldpat.ground(xyz, algorithm="slope", search_radius=650.0))
    with pytest.raises(aldpat.ParamError, match="at most 1,000 cells"):
        aldpat.ground(xyz, algorithm="slope", search_radius=1e6)

def test_points_holding_nan_or_infinity_are_named_by_their_index():
    """A notebook's array has no line to name: the refusal says how many points hold NaN or
    infinity and the first of them, by its index, with its value (it said only that some did)."""
    xyz = np.random.default_rng(0).uniform(0, 100, (1000, 3))
    xyz[500, 2], xyz[700, 0] = np.inf, np.nan
    for call in (aldpat.ground, aldpat.dtm):
        with pytest.raises(aldpat.AldpatError, match=r"non-finite coordinates cannot be filtered: 2 of 1,000, "
                                                      r"the first point 500 \(counting from 0\) with z = inf"):
            call(xyz)
