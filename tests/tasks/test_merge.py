"""``aldpat merge``: tiles back into one file, every point once (buffer copies left out)."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import laspy
import numpy as np
import pytest

from aldpat.errors import UsageError
from aldpat.tasks import get_task

STRIP = Path(__file__).resolve().parents[1] / "data" / "fsite5_strip.laz"  # EPSG:32632


def points_of(las) -> np.ndarray:
    """Every point as one sortable record of its stored values."""
    return np.sort(np.rec.fromarrays([las.X, las.Y, las.Z, las.intensity, las.return_number, las.gps_time]
                                     if "gps_time" in las.point_format.dimension_names else
                                     [las.X, las.Y, las.Z, las.intensity, las.return_number]))


@pytest.fixture(scope="module")
def las_tiles(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("merge")
    assert get_task("tile")([STRIP], width=150.0, height=150.0, buffer=20.0, odir=str(root / "tiles")).exit_code == 0
    return root


def test_classified_las_tiles_merge_to_every_point_once(las_tiles, tmp_path):
    tiles = las_tiles / "tiles"
    assert get_task("filter pm")([tiles], result="classified", odir=str(tmp_path / "ground")).exit_code == 0
    report = get_task("merge")([tmp_path / "ground"], output=str(tmp_path / "site.laz"))
    assert report.exit_code == 0, report.results[0].error
    original, merged = laspy.read(STRIP), laspy.read(tmp_path / "site.laz")
    held = sum(laspy.open(p).header.point_count for p in tiles.glob("tile_*.laz"))
    assert held > len(original.points)  # the tiles hold buffer copies ...
    assert np.array_equal(points_of(original), points_of(merged))  # ... the merged file each point once
    assert {1, 2} <= set(np.unique(merged.classification)) <= {1, 2, 7}  # the class its own tile gave it
    assert "tile_buffer" not in list(merged.point_format.extra_dimension_names)
    assert merged.header.parse_crs().to_epsg() == 32632 and merged.header.point_count == len(original.points)
    assert "buffer points of tiles left out" in (tmp_path / "site.log").read_text()


def test_text_tiles_merge_by_their_cores(tmp_path, samp24):
    tiles = tmp_path / "tiles"
    assert get_task("tile")([samp24], width=50.0, height=50.0, buffer=8.0, odir=str(tiles)).exit_code == 0
    # beside tile_parameter.txt: the cores say which points are buffer copies
    assert get_task("merge")([tiles], output=str(tmp_path / "site.txt")).exit_code == 0
    original, merged = np.loadtxt(samp24), np.loadtxt(tmp_path / "site.txt")
    assert np.array_equal(np.sort(original.view("f8,f8,f8,f8"), axis=0), np.sort(merged.view("f8,f8,f8,f8"), axis=0))
    # files made from the tiles elsewhere: --tile-params
    assert get_task("filter pm")([tiles], odir=str(tmp_path / "ground")).exit_code == 0
    assert get_task("merge")([tmp_path / "ground"], output=str(tmp_path / "ground.txt"),
                             tile_params=str(tiles / "tile_parameter.txt")).exit_code == 0
    ground = np.loadtxt(tmp_path / "ground.txt")
    held, got = (Counter(map(tuple, rows[:, :3].round(2))) for rows in (original, ground))
    assert len(ground) > 0.5 * len(original) and not got - held  # no point twice (genuine duplicates kept)


def test_plain_files_merge_whole_at_the_finest_scales_that_keep_every_input_exact(tmp_path):
    original = laspy.read(STRIP)
    half = len(original.points) // 2
    first = laspy.LasData(original.header)
    first.points = original.points[:half]
    first.write(tmp_path / "a.laz")
    header = laspy.LasHeader(point_format=original.header.point_format.id, version="1.2")
    header.scales, header.offsets = np.array([0.001, 0.001, 0.001]), np.array([494000.0, 5420000.0, 0.0])
    second = laspy.LasData(header)
    second.points = laspy.ScaleAwarePointRecord.zeros(len(original.points) - half, header=header)
    for dim in ("intensity", "return_number", "number_of_returns", "gps_time"):
        if dim in header.point_format.dimension_names:
            second[dim] = original[dim][half:]
    second.x, second.y, second.z = original.x[half:], original.y[half:], original.z[half:]
    second.write(tmp_path / "b.laz")
    report = get_task("merge")([tmp_path / "a.laz", tmp_path / "b.laz"], output=str(tmp_path / "ab.laz"))
    assert report.exit_code == 0
    assert not any("rounded" in w for w in report.results[0].warnings)
    merged = laspy.read(tmp_path / "ab.laz")
    assert list(merged.header.scales) == pytest.approx([0.001] * 3)  # the finer: b's millimetres kept
    assert list(merged.header.offsets) == list(original.header.offsets)

    def coordinates(las) -> np.ndarray:  # every point: coordinates in millimetres and attributes, sorted
        return np.sort(np.rec.fromarrays([np.rint(np.asarray(las[a]) * 1000).astype(np.int64) for a in "xyz"]
                                         + [las.intensity, las.return_number]))

    assert np.array_equal(coordinates(original), coordinates(merged))
    # a tile's millimetres after one at centimetres: kept, not rounded to the first's scale
    header.offsets = np.array([494000.0005, 5420000.0, 0.0])  # half a step off: no one scale holds both
    shifted = laspy.LasData(header)
    shifted.points = laspy.ScaleAwarePointRecord.zeros(3, header=header)
    shifted.x, shifted.y, shifted.z = original.x[:3] + 0.0005, original.y[:3], original.z[:3]
    shifted.write(tmp_path / "c.laz")
    report = get_task("merge")([tmp_path / "a.laz", tmp_path / "c.laz"], output=str(tmp_path / "ac.laz"))
    assert report.exit_code == 0
    assert any("c.laz: stored at scales or offsets" in w and "rounded" in w for w in report.results[0].warnings)
    with pytest.raises(UsageError, match="would replace the input"):  # before anything runs
        get_task("merge")([tmp_path / "a.laz"], output=str(tmp_path / "a.laz"), overwrite=True)


def test_a_text_file_merged_after_a_las_tile_keeps_its_decimals(tmp_path):
    """A text input's points took the first LAS input's centimetres: 500030.125 became 500030.12,
    silently. The LAS output's scales now become as fine as the text's decimals ask."""
    header = laspy.LasHeader(point_format=1, version="1.2")
    header.scales, header.offsets = np.array([0.01, 0.01, 0.01]), np.array([500000.0, 4000000.0, 0.0])
    tile = laspy.LasData(header)
    tile.x, tile.y, tile.z = np.array([500010.0, 500011.0]), np.array([4000001.0, 4000002.0]), np.array([10.0, 11.0])
    tile.write(tmp_path / "a.las")
    (tmp_path / "c.txt").write_text("500030.125 4000001.000 10.125\n500031.250 4000002.000 11.500\n")
    report = get_task("merge")([tmp_path / "a.las", tmp_path / "c.txt"], output=str(tmp_path / "ac.las"),
                               fields="xyz")
    assert report.exit_code == 0, report.results[0].error
    merged = laspy.read(tmp_path / "ac.las")
    assert list(merged.header.scales) == pytest.approx([0.001] * 3)
    assert np.asarray(merged.x).tolist() == pytest.approx([500010.0, 500011.0, 500030.125, 500031.25], abs=1e-9)
    assert np.asarray(merged.z).tolist() == pytest.approx([10.0, 11.0, 10.125, 11.5], abs=1e-9)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.las", "ac.las", "ac.log", "c.txt"]


def test_inputs_of_other_columns_are_refused_in_either_order_and_nothing_is_dropped_silently(tmp_path):
    """The first input's columns once decided the merged file's: x y z first, then a file with
    intensity, merged to x y z (its intensity gone without a word); the other order was refused.
    Now both orders are refused, naming the two files; ``--fields xyz`` merges x, y and z of both.
    A LAS input's points keep their whole record in a LAS output that a text input joins, and
    nothing says otherwise (a warning said its classes, returns and times were not written).
    The merges run one after another in one fresh process."""
    from tests.cli.fresh import aldpat_batch, leftovers

    (tmp_path / "xyz.txt").write_text("500000.5 4000000.5 10.25\n500001.5 4000001.5 11.25\n")
    (tmp_path / "xyzi.txt").write_text("500002.5 4000002.5 12.25 40\n500003.5 4000003.5 13.25 50\n")
    tile = laspy.read(STRIP)
    tile.write(tmp_path / "strip.las")
    extra = laspy.read(STRIP)
    extra.add_extra_dim(laspy.ExtraBytesParams(name="height_above_ground", type=np.float32))
    extra.height_above_ground = np.ones(len(extra.points), np.float32)
    extra.write(tmp_path / "extra.las")
    other = laspy.read(STRIP)
    other.add_extra_dim(laspy.ExtraBytesParams(name="height_above_ground", type=np.int16))
    other.height_above_ground = np.full(len(other.points), 3, np.int16)
    other.write(tmp_path / "other.las")

    checks = []  # (arguments, what to check of the run)

    def merge(*args, then):
        checks.append((["merge", *args], then))

    def refused_columns(done):
        assert done["status"] == 1, done["stderr"]
        assert "xyz.txt: has no intensity column and xyzi.txt has one; use --fields xyz" in done["stderr"]
        # one job of both, failed whole
        assert done["stderr"].splitlines()[-1] == "aldpat: merge of 2 inputs failed"
        assert not (tmp_path / done["args"][-1]).exists()

    def merged_xyz(done):
        assert done["status"] == 0, done["stderr"]
        assert np.loadtxt(tmp_path / "m.txt").shape == (4, 3)

    def kept_whole_records(done):
        assert done["status"] == 0 and "not written" not in done["stderr"], done["stderr"]
        merged = laspy.read(tmp_path / done["args"][done["args"].index("-o") + 1])
        assert len(merged.points) == 2 + len(tile.points)
        own = merged.points[merged.z != 10.25]
        own = own[own.z != 11.25]
        for name in ("intensity", "classification", "return_number", "number_of_returns"):
            assert np.array_equal(np.sort(np.asarray(own[name])), np.sort(np.asarray(tile[name]))), name

    def refused_saying(text):
        def check(done):
            assert done["status"] == 1 and text in done["stderr"], done["stderr"]
            output = done["args"][done["args"].index("-o") + 1]
            assert not (tmp_path / output).exists(), output
        return check

    # each refused merge names an output of its own: none may exist after the batch
    for n, order in enumerate((["xyz.txt", "xyzi.txt"], ["xyzi.txt", "xyz.txt"])):
        merge(*order, "-o", f"refused{n}.txt", then=refused_columns)
    merge("xyzi.txt", "xyz.txt", "-o", "m.txt", "--fields", "xyz", then=merged_xyz)
    for n, order in enumerate((["xyz.txt", "strip.las"], ["strip.las", "xyz.txt"])):
        merge(*order, "-o", f"m{n}.las", "--fields", "xyz", then=kept_whole_records)
    # LAS inputs into LAS: their extra dimensions agree, or the merge says which differ; a text
    # input beside them changes nothing (strip.las's points were given 0 for it silently)
    for n, order in enumerate((["strip.las", "extra.las"], ["extra.las", "strip.las"])):
        merge(*order, "-o", f"e{n}.las", then=refused_saying("height_above_ground (extra bytes), unlike"))
        merge(*order, "xyz.txt", "-o", f"e{n}t.las", "--fields", "xyz",
              then=refused_saying("height_above_ground (extra bytes), unlike"))
    # and of one kind: the first input's kind decided, and 0.75 in float32 was written as 0 in int16
    for n, (order, kinds) in enumerate(((["other.las", "extra.las"], "is float32, int16 in other.las"),
                                        (["extra.las", "other.las"], "is int16, float32 in extra.las"))):
        merge(*order, "-o", f"k{n}.las", then=refused_saying(f"its extra dimension height_above_ground {kinds}"))
    runs = aldpat_batch([{"args": args, "cwd": tmp_path} for args, _ in checks])
    assert len(runs) == len(checks)
    for (args, then), done in zip(checks, runs, strict=True):
        assert "Traceback" not in done["stderr"], (args, done["stderr"])
        then(done)
    assert leftovers(tmp_path) == []


def _extra_bytes_described(path: Path) -> int:
    """How many dimensions the file's Extra Bytes record (LASF_Spec 4) describes, read from its bytes:
    laspy rebuilds it from the point format, and a stale one is what PDAL refuses."""
    import struct

    with laspy.open(path) as f:
        stored = f.header.point_format.num_extra_bytes  # what each point record holds past its format
    data = path.read_bytes()
    header_size, _, vlrs = struct.unpack_from("<HII", data, 94)
    at, described = header_size, 0
    for _ in range(vlrs):
        user, record, length = struct.unpack_from("<16sHH", data, at + 2)
        if user.rstrip(b"\0") == b"LASF_Spec" and record == 4:
            described = length // 192
            sizes = [struct.unpack_from("<2xB", data, at + 54 + 192 * k)[0] for k in range(described)]
            assert sum({9: 4, 10: 8, 3: 2, 4: 2, 1: 1, 2: 1, 5: 4, 6: 4, 7: 8, 8: 8}[t] for t in sizes) == stored
        at += 54 + length
    return described


@pytest.mark.parametrize("vendor_extra", [False, True])
def test_merged_tiles_describe_only_the_extra_bytes_their_points_hold(tmp_path, vendor_extra):
    """The merged file dropped the tiles' buffer mark from its points but kept it in its Extra Bytes
    record: PDAL refused the file ("extra byte specification exceeds point length"), and with a
    vendor's own extra bytes laspy did too ("incoherent point size")."""
    source = laspy.read(STRIP)
    if vendor_extra:
        source.add_extra_dim(laspy.ExtraBytesParams(name="amplitude", type=np.float32))
        source.amplitude = np.linspace(0, 1, len(source.points), dtype=np.float32)
    source.write(tmp_path / "site.laz")
    assert get_task("tile")([tmp_path / "site.laz"], width=150.0, height=150.0, buffer=20.0,
                            odir=str(tmp_path / "tiles")).exit_code == 0
    report = get_task("merge")(sorted((tmp_path / "tiles").glob("*.laz")), output=str(tmp_path / "site_back.laz"))
    assert report.exit_code == 0, report.results[0].error
    back = laspy.read(tmp_path / "site_back.laz")
    assert list(back.point_format.extra_dimension_names) == (["amplitude"] if vendor_extra else [])
    assert _extra_bytes_described(tmp_path / "site_back.laz") == (1 if vendor_extra else 0)
    assert np.array_equal(points_of(back), points_of(source))
    if vendor_extra:
        order_a, order_b = np.lexsort((source.Z, source.Y, source.X)), np.lexsort((back.Z, back.Y, back.X))
        assert np.array_equal(np.asarray(source.amplitude)[order_a], np.asarray(back.amplitude)[order_b])


@pytest.mark.parametrize("task, args, product", [
    ("merge", ["-o", "site.laz"], "site.laz"),
    ("tile", ["--width", "300", "--height", "300", "--odir", "tiles"], "tiles"),
])
@pytest.mark.parametrize("missing", ["nosuch.laz", "@list.txt"])
def test_one_product_of_every_input_is_not_made_without_one_of_them(tmp_path, task, args, product, missing):
    """``merge a.laz nosuch.laz -o site.laz`` wrote site.laz of a.laz's points alone under its
    final name, and said "merge of 2 inputs failed": a merged site without a tile, which the next
    run would not replace without --overwrite. As lasmerge stops at a file it cannot open (and as
    merge already stopped at an input it cannot read), nothing is made when a file named (on the
    command line or in an @list) does not exist. A pattern matching nothing names no file: the
    others are made, with its line (tests/cli/test_bad_inputs.py)."""
    from tests.cli.fresh import aldpat

    (tmp_path / "a.laz").write_bytes(STRIP.read_bytes())
    (tmp_path / "list.txt").write_text("nosuch.laz\n")
    done = aldpat(task, "a.laz", missing, *args, cwd=tmp_path)
    assert done.returncode == 1 and f"{task} of 2 inputs failed" in done.stderr, done.stderr
    assert "nosuch.laz: no such file" in done.stderr and not (tmp_path / product).exists()
    aldpat(task, "a.laz", *args, cwd=tmp_path).ok()  # once every input is there, as before
    assert (tmp_path / product).exists()


def _vendor_tile(path: Path, point_format: int, keep: np.ndarray, classes: int, seed: int) -> laspy.LasData:
    """STRIP's points ``keep`` as a vendor's file of ``point_format`` (LAS 1.2 for 0-5, 1.4 for
    6-10): a noise class, withheld points, scan angles, times, and colour where the format has it."""
    rng = np.random.default_rng(seed)
    source = laspy.read(STRIP)
    las = laspy.convert(source, point_format_id=point_format, file_version="1.4" if point_format >= 6 else "1.2")
    las.points = las.points[keep]
    n = len(las.points)
    las.classification = np.where(rng.random(n) < 0.1, classes, las.classification)
    las.withheld = rng.random(n) < 0.05
    angles = rng.integers(-20, 21, n)
    if point_format >= 6:
        las.scan_angle = np.round(angles / 0.006).astype(np.int16)
        las.header.global_encoding.gps_time_type = laspy.header.GpsTimeType.STANDARD  # LAS 1.4 R15, table 5
    else:
        las.scan_angle_rank = angles.astype(np.int8)
    las.gps_time = rng.uniform(1e5, 2e5, n)
    if "red" in las.point_format.dimension_names:
        las.red, las.green, las.blue = (rng.integers(0, 65536, n, dtype=np.uint16) for _ in range(3))
    las.header.add_crs(source.header.parse_crs())
    las.write(path)
    return laspy.read(path)


def test_las_12_and_14_tiles_merge_into_the_format_holding_both(tmp_path):
    """A vendor's LAS 1.2 point format 3 tile and a LAS 1.4 point format 6 tile (a class above
    31) were refused ("a LAS file holds one"). They merge into LAS 1.4 format 7 -- 3's colour in
    6's record --, every point with its class, flags, scan angle, time and colour, the CRS as the
    WKT a format 6-10 file records; in either order. Waveform packets cannot be merged across
    formats: they point into their own file's waveform data."""
    from tests.cli.fresh import aldpat, leftovers

    n = laspy.open(STRIP).header.point_count
    old = _vendor_tile(tmp_path / "old.las", 3, np.arange(0, n // 2), 7, 1)
    new = _vendor_tile(tmp_path / "new.laz", 6, np.arange(n // 2, n), 40, 2)
    for order in (["old.las", "new.laz"], ["new.laz", "old.las"]):
        done = aldpat("merge", *order, "-o", "m.laz", "--overwrite", "-v", cwd=tmp_path).ok()
        assert f"{order[1]}: its GPS times are of another kind" in done.stderr  # week seconds and standard time
        merged = laspy.read(tmp_path / "m.laz")
        assert (merged.header.version.major, merged.header.version.minor, merged.point_format.id) == (1, 4, 7)
        assert merged.header.global_encoding.wkt and merged.header.parse_crs().to_epsg() == 32632
        assert merged.header.vlrs.get("GeoKeyDirectoryVlr") == []  # no GeoTIFF keys beside the WKT
        assert merged.header.point_count == n
        log = (tmp_path / "m.log").read_text()
        assert "point formats [3, 6] written as point format 7 (LAS 1.4)" in log

        def rows(las, colour: bool):
            names = ["X", "Y", "Z", "intensity", "return_number", "number_of_returns", "classification",
                     "withheld", "gps_time"]
            columns = [np.asarray(las[name]) for name in names]
            degrees = las.scan_angle_rank if "scan_angle_rank" in las.point_format.dimension_names \
                else np.round(las.scan_angle * 0.006)
            columns.append(np.asarray(degrees, np.int64))
            columns += [np.asarray(las[c]) if colour else np.zeros(len(las.points), np.uint16)
                        for c in ("red", "green", "blue")]
            return np.sort(np.rec.fromarrays(columns))

        assert np.array_equal(rows(merged, True), np.sort(np.concatenate([rows(old, True), rows(new, False)])))
        assert {7, 40} <= set(np.unique(merged.classification).tolist())

    one = laspy.convert(laspy.read(STRIP), point_format_id=1)
    one.write(tmp_path / "one.las")
    wave = laspy.convert(laspy.read(STRIP), point_format_id=4)
    wave.write(tmp_path / "wave.las")
    done = aldpat("merge", "one.las", "wave.las", "-o", "w.las", cwd=tmp_path)
    assert done.returncode == 1, done.stderr
    assert "wave.las: LAS inputs of point formats [1, 4]: its point format 4's waveform packets" in done.stderr
    assert not (tmp_path / "w.las").exists()
    assert leftovers(tmp_path) == []


def test_a_project_of_las_12_and_14_strips_tiles_filters_and_merges_back(tmp_path):
    """Tiling refused strips of two point formats ("LAS/LAZ tiles need inputs of one point
    format"), the first step of the tile -> filter -> merge workflow on a project flown twice.
    The tiles take the format holding both (3 and 6: 7), the filter keeps it, and the merge
    gives every point of both strips once, its time and colour kept; a text strip among LAS
    ones is refused, naming it."""
    from tests.cli.fresh import aldpat

    n = laspy.open(STRIP).header.point_count
    old = _vendor_tile(tmp_path / "old.las", 3, np.arange(0, n, 2), 7, 3)
    new = _vendor_tile(tmp_path / "new.laz", 6, np.arange(1, n, 2), 18, 4)
    done = aldpat("tile", "old.las", "new.laz", "--width", "150", "--height", "150", "--buffer", "20",
                  "--odir", "tiles", "-v", cwd=tmp_path).ok()
    assert "point formats [3, 6] tiled as point format 7 (LAS 1.4)" in done.stderr
    # week seconds (format 3's LAS 1.2) beside adjusted standard time: copied, and said, as merge says it
    assert "new.laz: its GPS times are of another kind" in done.stderr
    assert "than the first input's, which the tiled header records" in done.stderr
    tiles = sorted((tmp_path / "tiles").glob("tile_*.las"))
    assert len(tiles) > 1 and {laspy.open(t).header.point_format.id for t in tiles} == {7}
    aldpat("filter", "pm", "tiles", "--result", "classified", "--odir", "ground", cwd=tmp_path).ok()
    aldpat("merge", "ground", "-o", "site.laz", cwd=tmp_path).ok()
    site = laspy.read(tmp_path / "site.laz")
    assert site.point_format.id == 7 and site.header.point_count == n
    key = np.sort(np.rec.fromarrays([site.X, site.Y, site.Z, site.gps_time, site.red]))
    held = np.sort(np.concatenate([np.rec.fromarrays([old.X, old.Y, old.Z, old.gps_time, old.red]),
                                   np.rec.fromarrays([new.X, new.Y, new.Z, new.gps_time,
                                                      np.zeros(len(new.points), np.uint16)])]))
    assert np.array_equal(key, held)  # every point once, its time and colour (none in format 6) kept
    assert {7, 18} <= set(np.unique(site.classification).tolist())  # the vendor's noise kept as noise

    (tmp_path / "strip.txt").write_text("513000.5 5402000.5 10.25\n")
    done = aldpat("tile", "old.las", "strip.txt", "--odir", "mixed", cwd=tmp_path)
    assert done.returncode == 1 and "strip.txt: is text, beside the LAS input old.las: LAS/LAZ tiles of LAS inputs take" in done.stderr
