"""A LAS/LAZ file filtered in two streaming passes gets exactly the classes of the whole file held
in memory (``aldpat.filters.streamed``), for every grid filter that can stream."""

from __future__ import annotations

from pathlib import Path

import laspy
import numpy as np
import pytest

from aldpat.filters import FILTERS, ground_filter
from aldpat.filters.streamed import Unstreamable, lowest_codes, streamable
from aldpat.io.las import LasReader, z_codes
from aldpat.params import resolve
from tests.cli.fresh import aldpat, aldpat_batch

DATA = Path(__file__).resolve().parents[1] / "data"
STRIP = DATA / "fsite5_strip.laz"  # a strip of the ISPRS site FSite5: real points, data gaps
PARAMS = Path(__file__).resolve().parents[2] / "jobs" / "params"

STREAMABLE = sorted(name for name, spec in FILTERS.items() if streamable(name, spec.params()))


def _param_file(name: str) -> Path:
    return PARAMS / ("gapm-isprs-set01.toml" if name == "gapm" else f"{name}.toml")


def _params(name: str, **values):
    import tomllib

    layers = [("file", tomllib.loads(_param_file(name).read_text())), ("test", values)]
    return resolve(FILTERS[name].params, layers).values


def test_the_grid_filters_that_can_stream():
    assert set(STREAMABLE) == {n for n, s in FILTERS.items() if not s.on_points}
    assert streamable("gapm", _params("gapm", low_outliers=2.0))  # the test decides on the grid
    assert not streamable("gapm", _params("gapm", auto=True))
    # the final surface test can give a cell's lowest point another mark than its cell's, which
    # the noise test reads
    assert not streamable("outlier", _params("outlier", surface_threshold=0.5))


@pytest.mark.parametrize("source", ["fsite5_strip.laz", "fsite5_pit.laz", "csite1_slice.laz"])
def test_streamed_outlier_writes_the_noise_classes_of_the_whole_file(source, tmp_path, monkeypatch, runner, cli):
    """``outlier`` finds noise (classes 7 and 18): in a fresh ``aldpat`` process its two-pass run
    writes every point's class and mark as the whole file held in memory gives them, on LAS 1.4
    output (point format 6, which holds class 18) -- and the file is never read whole."""
    from aldpat.tasks.filter import point_classes

    las = laspy.read(DATA / source)
    x, y, z = (np.asarray(v, dtype=np.float64) for v in (las.x, las.y, las.z))
    params = FILTERS["outlier"].params(cell=1.0)
    expected = ground_filter(x, y, z, "outlier", params)
    want = point_classes(expected, z, params, "outlier")
    assert {7, 18} <= set(np.unique(want).tolist())  # both kinds of noise occur
    six = tmp_path / f"{Path(source).stem}_14.las"
    laspy.convert(las, point_format_id=6, file_version="1.4").write(six)
    aldpat("filter", "outlier", six, "--odir", tmp_path / "out", "--result", "classified", "--marks", "--cell", "1").ok()
    got = laspy.read(tmp_path / "out" / f"{six.stem}_outlier.las")
    assert np.array_equal(np.asarray(got["mark"]), expected.point_marks)
    noise = np.isin(want, (7, 18))
    assert np.array_equal(np.asarray(got.classification)[noise], want[noise])
    assert not np.isin(np.asarray(got.classification)[~noise], (7, 18)).any()

    def whole(_self):
        raise AssertionError("the file was read whole")

    monkeypatch.setattr(LasReader, "read", whole)
    out = runner.invoke(cli, ["filter", "outlier", str(six), "--odir", str(tmp_path / "again"), "--result",
                              "classified", "--cell", "1"])
    assert out.exit_code == 0, out.output
    assert np.array_equal(np.asarray(laspy.read(tmp_path / "again" / f"{six.stem}_outlier.las").classification),
                          np.asarray(got.classification))


def test_height_codes_read_back_as_laspys_heights():
    reader = LasReader(STRIP)
    heights = reader.height_codes()
    for table in reader.chunks(50_000):
        assert np.array_equal(heights.decode(z_codes(table)), table.z)  # bit for bit


@pytest.mark.parametrize("name", [n for n in STREAMABLE if FILTERS[n].noise is None])  # outlier: below
@pytest.mark.parametrize("defaults", [False, True])
def test_streamed_classes_equal_the_whole_file(name, defaults, tmp_path):
    """In a fresh ``aldpat`` process: classes and marks written by the two-pass run equal
    ``ground_filter`` on the points held in memory; with ``defaults`` the filter's built-in
    parameters (for gapm the segment and surface tests), else its shipped file; 1 m cells."""
    las = laspy.read(STRIP)
    x, y, z = (np.asarray(v, dtype=np.float64) for v in (las.x, las.y, las.z))
    params = FILTERS[name].params(cell=1.0) if defaults else _params(name, cell=1.0)
    expected = ground_filter(x, y, z, name, params)
    args = ["filter", name, STRIP, "--odir", tmp_path, "--result", "classified", "--marks", "--cell", "1"]
    if not defaults:
        args += ["--params", _param_file(name)]
    aldpat(*args).ok()
    got = laspy.read(tmp_path / f"{STRIP.stem}_{name}.laz")
    assert np.array_equal(np.asarray(got.classification) == 2, expected.is_ground)
    assert np.array_equal(np.asarray(got["mark"]), expected.point_marks)
    assert 0.05 < expected.is_ground.mean() < 0.95  # both classes occur


def test_classes_alone_need_not_compare_the_points_above_their_cell():
    """With the final surface test, a run without ``--marks`` skips the comparison that only the
    marks use: the classes are the same."""
    from aldpat.filters.grid_stage import cell_classes
    from aldpat.filters.registry import get_filter

    reader = LasReader(STRIP)
    params = FILTERS["gapm"].params(cell=1.0)
    chunks = [(t.x, t.y, z_codes(t)) for t in reader.chunks(40_000)]
    classes = cell_classes(get_filter("gapm"), lowest_codes(chunks, reader.bounds, reader.height_codes(), 1.0,
                                                            None), params)
    for table in reader.chunks(40_000):
        with_marks = classes.classify(table.x, table.y, table.z)[1]
        assert np.array_equal(classes.classify(table.x, table.y, table.z, marks=False)[1], with_marks)


def test_a_header_wider_than_the_points_gives_the_points_own_grid():
    reader = LasReader(STRIP)
    chunks = [(t.x, t.y, z_codes(t)) for t in reader.chunks(100_000)]
    xmin, ymin, xmax, ymax = reader.bounds
    tight = lowest_codes(chunks, reader.bounds, reader.height_codes(), 1.0, None)
    wide = lowest_codes(chunks, (xmin - 37.2, ymin - 5.0, xmax + 12.9, ymax + 101.0), reader.height_codes(), 1.0,
                        None)
    assert wide.spec == tight.spec
    assert np.array_equal(wide.codes, tight.codes)
    with pytest.raises(Unstreamable):
        lowest_codes(chunks, (xmin + 10.0, ymin, xmax, ymax), reader.height_codes(), 1.0, None)


def test_a_stale_header_far_wider_than_the_points_grids_the_points_own_extent(tmp_path):
    """A tile carrying its project's header (bounds 20 km across, points a few hundred metres):
    every grid filter refused it ("a 26668 x 26668 grid of 0.75 m cells is too large"), and with
    14 km bounds held 1.5 GB for a strip of 20,000 points. The first pass now reads the points'
    own extent first; in one fresh process, filter and dtm give the classes and the DTM of the same
    file with a true header."""
    import struct

    las = laspy.read(STRIP)
    las.write(tmp_path / "true.las", do_compress=False)
    stale = tmp_path / "stale.las"
    stale.write_bytes((tmp_path / "true.las").read_bytes())
    x0, y0 = float(np.asarray(las.x).min()), float(np.asarray(las.y).min())
    with open(stale, "r+b") as fh:  # Max X, Min X, Max Y, Min Y: doubles from byte 179
        fh.seek(179)
        fh.write(struct.pack("<dddd", x0 + 20_000.0, x0 - 500.0, y0 + 20_000.0, y0 - 500.0))
    runs = aldpat_batch([{"args": [*command, f"{name}.las", *extra, "--odir", "out"], "cwd": tmp_path}
                         for name in ("true", "stale")
                         for command, extra in ((["filter", "gapm"], []), (["filter", "pm"], []), (["dtm"], ["--cell", "2"]))])
    assert [run["status"] for run in runs] == [0] * 6, [run["stderr"] for run in runs]
    for suffix in ("_gapm.las", "_pm.las"):
        classes = [np.asarray(laspy.read(tmp_path / "out" / f"{n}{suffix}").classification) for n in ("true", "stale")]
        assert np.array_equal(*classes) and (classes[0] == 2).mean() > 0.5
    import rasterio

    rasters = []
    for name in ("true", "stale"):
        with rasterio.open(tmp_path / "out" / f"{name}_dtm.tif") as ds:
            rasters.append((ds.transform, ds.read(1)))
    assert rasters[0][0] == rasters[1][0] and np.array_equal(rasters[0][1], rasters[1][1])


def test_a_header_narrower_than_the_points_is_refused(tmp_path, runner, cli):
    """Bounds in the header that leave points out contradict the data (a damaged file, or a tool
    that did not update them): the file is refused in one line naming the first such point,
    nothing is written."""
    import struct

    las = laspy.read(STRIP)
    bad = tmp_path / "bad.las"
    las.write(bad, do_compress=False)
    with open(bad, "r+b") as fh:  # Max X, a double at byte 179 of every LAS header
        fh.seek(179)
        fh.write(struct.pack("<d", float(np.asarray(las.x).max()) - 50.0))
    assert laspy.open(bad).header.maxs[0] < np.asarray(las.x).max()
    out = runner.invoke(cli, ["filter", "pm", str(bad), "--result", "classified", "--cell", "1"])
    assert out.exit_code == 1
    assert "outside the header's bounds" in out.output
    assert not (tmp_path / "bad_pm.las").exists()


def test_pass_one_keeps_each_cells_lowest_code_as_numpy_finds_it():
    """The compiled pass over a chunk gives numpy's running minimum (``np.minimum.at`` over
    ``floor((v - origin) / cell)``), extent and spacing, whatever the origin and however the
    points are cut into chunks; a point off the grid is named before a height coded as empty."""
    from aldpat.core.height_codes import EMPTY_CODE, ScaledHeights

    rng = np.random.default_rng(5)
    n = 20_000
    x = rng.uniform(1000.0, 1093.7, n)
    y = rng.uniform(-40.0, 21.3, n)
    x[:50] = np.round(x[:50])  # on cell edges
    y[50:100] = np.round(y[50:100] * 2) / 2
    z = rng.integers(-30_000, 90_000, n).astype(np.int32)
    heights = ScaledHeights(0.01, 100.0)
    bounds = (float(x.min()), float(y.min()), float(x.max()), float(y.max()))
    for cell, origin in ((1.0, None), (0.75, (0.3, -0.2)), (2.5, (1000.0, 0.0))):
        ox, oy = origin or (0.0, 0.0)
        spec = lowest_codes([], bounds, heights, cell, origin).spec  # the grid over the bounds
        col = np.floor((x - ox) / cell).astype(np.int64) - round((spec.x0 - ox) / cell)
        row = np.floor((y - oy) / cell).astype(np.int64) - round((spec.y0 - oy) / cell)
        expected = np.full(spec.size, EMPTY_CODE, np.int32)
        np.minimum.at(expected, row * spec.cols + col, z)
        pieces = [(x[a:a + 3001], y[a:a + 3001], z[a:a + 3001]) for a in range(0, n, 3001)]
        got = lowest_codes(pieces, bounds, heights, cell, origin)
        assert got.spec == spec
        assert np.array_equal(got.codes.ravel(), expected)
        assert got.spacing == lowest_codes([(x, y, z)], bounds, heights, cell, origin).spacing
    coded = z.copy()
    coded[7] = EMPTY_CODE
    off = x.copy()
    off[9000] = bounds[2] + 10.0
    with pytest.raises(Unstreamable, match="outside"):
        lowest_codes([(off, y, coded)], bounds, heights, 1.0, None)
    with pytest.raises(Unstreamable, match="empty cell"):
        lowest_codes([(x, y, coded)], bounds, heights, 1.0, None)


def test_a_height_stored_as_the_empty_cells_code_is_not_streamed():
    """The largest integer marks an empty cell: a point stored with it (a height 21,474 km up at
    1 cm) must not vanish from the grid, so the file is read whole instead."""
    from aldpat.core.height_codes import EMPTY_CODE

    reader = LasReader(STRIP)
    x, y = np.array([10.2, 11.7]), np.array([5.1, 5.3])
    codes = np.array([1200, EMPTY_CODE], np.int32)
    with pytest.raises(Unstreamable, match="empty cell"):
        lowest_codes([(x, y, codes)], (10.0, 5.0, 12.0, 6.0), reader.height_codes(), 1.0, None)


def test_low_outliers_are_found_in_the_two_passes(tmp_path, monkeypatch, runner, cli):
    """The low-outlier test decides on the grid, so a file holding a point 106 m under the ground
    is still filtered in two passes (never read whole), with the classes of the points held in
    memory: that point is class 7, low noise."""
    pit = DATA / "fsite5_pit.laz"
    las = laspy.read(pit)
    x, y, z = (np.asarray(v, dtype=np.float64) for v in (las.x, las.y, las.z))
    params = FILTERS["gapm"].params(cell=1.0)
    assert streamable("gapm", params)
    expected = ground_filter(x, y, z, "gapm", params)
    aldpat("filter", "gapm", pit, "--odir", tmp_path, "--result", "classified", "--marks", "--cell", "1").ok()
    got = laspy.read(tmp_path / "fsite5_pit_gapm.laz")
    assert np.array_equal(np.asarray(got["mark"]), expected.point_marks)
    cls = np.asarray(got.classification)
    assert np.array_equal(cls == 2, expected.is_ground)
    assert cls[np.argmin(z)] == 7 and z.min() < np.median(z) - 100

    def whole(_self):
        raise AssertionError("the file was read whole")

    monkeypatch.setattr(LasReader, "read", whole)
    out = runner.invoke(cli, ["filter", "gapm", str(pit), "--odir", str(tmp_path / "again"), "--result", "classified",
                              "--cell", "1"])
    assert out.exit_code == 0, out.output
    assert np.array_equal(np.asarray(laspy.read(tmp_path / "again" / "fsite5_pit_gapm.laz").classification), cls)


def _las14(path: Path, seed: int = 3) -> laspy.LasData:
    """STRIP as a LAS 1.4 file of point format 7 (layered LAZ), with a GPS time, colours, withheld
    points and a vendor's noise class to decode or not."""
    las = laspy.convert(laspy.read(STRIP), point_format_id=7, file_version="1.4")
    rng = np.random.default_rng(seed)
    n = len(las.points)
    las.gps_time = np.sort(rng.uniform(3e8, 3e8 + 600, n))
    las.red, las.green, las.blue = (rng.integers(0, 65535, n).astype(np.uint16) for _ in range(3))
    las.intensity = rng.integers(0, 4000, n).astype(np.uint16)
    las.classification = np.where(rng.random(n) < 0.01, 7, 0).astype(np.uint8)
    las.withheld = rng.random(n) < 0.01
    las.write(path)
    return las


def test_a_chunk_read_with_only_holds_what_a_full_read_holds_and_is_never_written(tmp_path):
    """``chunks(only=...)`` of a LAS 1.4 LAZ: x, y, z and the dimensions named equal a full
    read's, no other column is made, the layers not named are not decoded (their fields do not
    hold the points' values), and a LAS writer refuses such a table."""
    from aldpat.filters.survey import TAKING_PART_FIELDS
    from aldpat.io.las import LasWriter

    path = tmp_path / "strip14.laz"
    _las14(path)
    reader = LasReader(path)
    full = list(reader.chunks(4_000))
    part = list(reader.chunks(4_000, only=TAKING_PART_FIELDS))
    assert len(full) == len(part) > 1
    for a, b in zip(full, part, strict=True):
        assert set(b.columns) == {"x", "y", "z", "classification", "return_number", "number_of_returns"}
        for name in b.columns:
            assert np.array_equal(a.columns[name], b.columns[name])
        assert np.array_equal(a.record["withheld"], b.record["withheld"]) and np.asarray(a.record["withheld"]).any()
        for skipped in ("gps_time", "red", "intensity"):
            assert not np.array_equal(a.record[skipped], b.record[skipped])
    with pytest.raises(AssertionError, match="for reading"):
        LasWriter(tmp_path / "out.laz", tuple(part[0].columns), template=reader.header).write(part[0])


def test_streamed_gapm_on_a_las14_laz_equals_the_whole_file(tmp_path):
    """In a fresh ``aldpat`` process, gapm's defaults on a LAS 1.4 LAZ whose grid pass decodes
    only coordinates, classes, flags and returns: the classes of ``ground_filter`` on the points
    held in memory (withheld and noise points set aside as there), every other field written as
    read."""
    from aldpat.filters.survey import taking_part
    from aldpat.io.las import las_table

    path = tmp_path / "strip14.laz"
    las = _las14(path)
    x, y, z = (np.asarray(v, dtype=np.float64) for v in (las.x, las.y, las.z))
    params = FILTERS["gapm"].params(cell=1.0)
    part = taking_part(las_table(las), params)
    assert part is not None and not part.all()
    expected = ground_filter(x[part], y[part], z[part], "gapm", params).is_ground
    aldpat("filter", "gapm", path, "--odir", tmp_path / "out", "--cell", "1").ok()
    got = laspy.read(tmp_path / "out" / "strip14_gapm.laz")
    assert np.array_equal(np.asarray(got.classification)[part] == 2, expected)
    for name in ("gps_time", "red", "intensity", "withheld", "X"):
        assert np.array_equal(np.asarray(got[name]), np.asarray(las[name]))


def test_dtm_of_a_las14_laz_equals_the_dtm_of_the_same_points_as_las(tmp_path):
    """``aldpat dtm`` decodes only coordinates, classes, flags and returns of a LAS 1.4 LAZ, in a
    fresh process: its DTM is, node for node, that of the same points in an uncompressed LAS
    (every field read), with the withheld and noise points set aside in both."""
    import rasterio

    las = _las14(tmp_path / "strip14.laz")
    las.write(tmp_path / "plain14.las")
    for name in ("strip14.laz", "plain14.las"):
        aldpat("dtm", tmp_path / name, "--cell", "2", "--odir", tmp_path / "out").ok()
    with rasterio.open(tmp_path / "out" / "strip14_dtm.tif") as a, rasterio.open(tmp_path / "out" / "plain14_dtm.tif") as b:
        first, second = a.read(1, masked=True), b.read(1, masked=True)
        assert a.transform == b.transform and first.count() > 1000
        assert np.array_equal(first.mask, second.mask) and np.array_equal(first.filled(0), second.filled(0))
