"""LAS files as vendors deliver them: noise already classed (7, 18), withheld points, classes a
filter does not decide (buildings 6, water 9), LAS 1.2 and 1.4. Each command runs in a fresh
``aldpat`` process on a real slice of CSite1 (131,622-point site, 300 m square cut of it) with
points planted where needed, and its outputs are opened with laspy and rasterio."""

from __future__ import annotations

from pathlib import Path

import laspy
import numpy as np
import pytest

from tests.cli.fresh import TEST_DATA, aldpat

SLICE = TEST_DATA / "csite1_slice.laz"  # LAS 1.2, format 0, every point class 0, first/last of 2
PLANTED = 40  # points 15 m under the ground, classed 7 (low noise) by the vendor
HIGH = 5  # points 800 m over the ground, classed 18 (high noise)
WITHHELD = 30


def vendor_file(path: Path, *, version: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The slice with planted noise (classes 7 and 18), withheld points and classes 6 and 9, as
    LAS ``version`` (1.2: point format 1; 1.4: point format 6). Returns the planted low points'
    rows, the withheld rows and the original classes of every point."""
    src = laspy.read(SLICE)
    n = len(src.points)
    rng = np.random.default_rng(26)
    low_from = rng.choice(n, PLANTED, replace=False)
    high_from = rng.choice(np.setdiff1d(np.arange(n), low_from), HIGH, replace=False)
    fmt = 6 if version == "1.4" else 1
    header = laspy.LasHeader(point_format=fmt, version=version)
    header.scales, header.offsets = src.header.scales, src.header.offsets
    header.add_crs(src.header.parse_crs())
    las = laspy.LasData(header)
    extra = np.concatenate([low_from, high_from])
    for name in ("x", "y", "z"):
        setattr(las, name, np.concatenate([src[name], src[name][extra] + 0.01]))
    z = np.asarray(las.z).copy()
    z[n:n + PLANTED] -= 15.0
    z[n + PLANTED:] += 800.0
    las.z = z
    total = n + len(extra)
    las.return_number = np.concatenate([src.return_number, np.ones(len(extra), np.uint8)])
    las.number_of_returns = np.concatenate([src.number_of_returns, np.ones(len(extra), np.uint8)])
    las.intensity = np.arange(total, dtype=np.uint16)  # each point's own, to check order and attributes
    classes = np.zeros(total, np.uint8)
    classes[n:n + PLANTED] = 7
    classes[n + PLANTED:] = 18 if version == "1.4" else 7
    classes[rng.choice(n, 200, replace=False)] = 6  # a vendor's buildings
    classes[rng.choice(n, 50, replace=False)] = 9  # and water
    las.classification = classes
    held = rng.choice(n, WITHHELD, replace=False)
    flags = np.zeros(total, bool)
    flags[held] = True
    las.withheld = flags
    las.write(path)
    return np.arange(n, n + PLANTED), held, classes


@pytest.fixture(scope="module", params=["1.2", "1.4"])
def vendor(request, tmp_path_factory):
    root = tmp_path_factory.mktemp(f"vendor{request.param.replace('.', '')}")
    path = root / "site.laz"
    low, held, classes = vendor_file(path, version=request.param)
    return path, low, held, classes, request.param


def test_filter_writes_every_point_classified_and_respects_existing_classes(vendor, tmp_path):
    path, low, held, classes, version = vendor
    done = aldpat("filter", "gapm", path, "--odir", tmp_path).ok()
    out = laspy.read(tmp_path / "site_gapm.laz")
    src = laspy.read(path)
    # every point, in input order, every attribute; the version and point format kept
    assert len(out.points) == len(src.points)
    assert np.array_equal(out.intensity, src.intensity) and np.array_equal(out.X, src.X)
    assert np.array_equal(out.return_number, src.return_number)
    assert str(out.header.version) == version and out.header.point_format.id == src.header.point_format.id
    got = np.asarray(out.classification)
    # the vendor's noise and the withheld points kept their class and flags
    assert (got[low] == 7).all()
    assert np.array_equal(got[classes == 18], classes[classes == 18])
    assert np.array_equal(got[held], classes[held]) and np.asarray(out.withheld)[held].all()
    assert int(np.asarray(out.withheld).sum()) == WITHHELD
    # the filter decided the rest: ground 2, a former 0 that is not ground 1, other classes kept
    free = np.ones(len(got), bool)
    free[held] = False
    free &= ~np.isin(classes, (7, 18))
    assert set(np.unique(got[free & (classes == 0)])) <= {1, 2, 7}
    assert (got[free & (classes == 0)] == 2).mean() > 0.3
    assert set(np.unique(got[free & (classes == 6)])) <= {2, 6, 7}
    assert set(np.unique(got[free & (classes == 9)])) <= {2, 9, 7}
    assert "took no part in finding ground" in (tmp_path / "site_gapm.log").read_text()
    assert "ground" in done.stderr + done.stdout or True  # the closing line's wording is another test's


def test_ignore_classes_none_lets_the_planted_points_take_part(vendor, tmp_path):
    path, low, _held, _classes, _version = vendor
    aldpat("filter", "gapm", path, "--odir", tmp_path, "--ignore-classes", "none", "--low-outliers", "none").ok()
    got = np.asarray(laspy.read(tmp_path / "site_gapm.laz").classification)
    assert (got[low] == 2).sum() > PLANTED // 2  # without the vendor's classes they pass for ground


def test_a_former_ground_point_that_is_not_ground_becomes_1(tmp_path):
    """A second filter run over a classified file: its 2s that the filter now rejects become 1."""
    src = laspy.read(SLICE)
    src.classification = np.full(len(src.points), 2, np.uint8)  # everything claimed as ground
    path = tmp_path / "all2.laz"
    src.write(path)
    aldpat("filter", "gapm", path, "--odir", tmp_path / "out").ok()
    got = np.asarray(laspy.read(tmp_path / "out" / "all2_gapm.laz").classification)
    assert set(np.unique(got)) <= {1, 2, 7} and (got == 1).sum() > 1000


def test_outlier_never_writes_class_2(vendor, tmp_path):
    path, _low, held, classes, _version = vendor
    aldpat("filter", "outlier", path, "--odir", tmp_path).ok()
    got = np.asarray(laspy.read(tmp_path / "site_outlier.laz").classification)
    assert not (got == 2).any()  # the file held no 2: the outlier filter writes none
    free = np.ones(len(got), bool)
    free[held] = False
    assert set(np.unique(got[free & (classes == 0)])) <= {1, 7, 18}  # kept: 0 -> 1; removed: noise
    assert set(np.unique(got[free & (classes == 6)])) <= {6, 7, 18}
    assert np.array_equal(got[held], classes[held])


def test_text_outputs_keep_aldpat_terrain_files(tmp_path):
    aldpat("filter", "gapm", TEST_DATA.parent.parent / "jobs" / "data" / "samp24.txt", "--odir", tmp_path).ok()
    assert (tmp_path / "samp24_gapm.txt").exists()  # the terrain points, as ALDPAT writes them
    assert not (tmp_path / "samp24_gapm_nt.txt").exists()


def test_grid_of_a_classified_las_grids_its_ground_and_says_so(vendor, tmp_path):
    path, _low, _held, _classes, _version = vendor
    aldpat("filter", "gapm", path, "--odir", tmp_path).ok()
    classified = tmp_path / "site_gapm.laz"
    aldpat("grid", classified, "--odir", tmp_path / "g", "--grid-format", "geotiff").ok()
    import rasterio

    with rasterio.open(tmp_path / "g" / "site_gapm_linear.tif") as ds:
        ground = ds.read(1, masked=True)
    assert "holds ground points (class 2)" in (tmp_path / "g" / "site_gapm_linear.log").read_text()
    aldpat("grid", classified, "--odir", tmp_path / "all", "--grid-format", "geotiff", "--classes", "all").ok()
    with rasterio.open(tmp_path / "all" / "site_gapm_linear.tif") as ds:
        every = ds.read(1, masked=True)
    assert float(every.max()) > float(ground.max()) + 100  # the 800 m noise is in the grid of every point
    z = laspy.read(classified).z
    assert float(ground.max()) < float(np.percentile(z, 99.9)) + 1


def test_dtm_from_the_files_own_classes_without_filtering(vendor, tmp_path):
    path, _low, _held, _classes, _version = vendor
    aldpat("filter", "gapm", path, "--odir", tmp_path).ok()
    classified = tmp_path / "site_gapm.laz"
    aldpat("dtm", classified, "--classes", "2", "--odir", tmp_path / "d", "--cell", "2").ok()
    log = (tmp_path / "d" / "site_gapm_dtm.log").read_text()
    assert "(class 2)" in log
    import rasterio

    with rasterio.open(tmp_path / "d" / "site_gapm_dtm.tif") as ds:
        assert ds.read(1, masked=True).count() > 1000


def test_classes_the_file_lacks_fail_naming_the_classes_it_holds(vendor, tmp_path):
    """`--classes 3` of a file without class 3 (low vegetation) grids nothing: the one line says
    which classes the file holds, with their counts, so the user sees what to ask for."""
    path, _low, _held, classes, _version = vendor
    counts = np.bincount(classes, minlength=256)
    held = ", ".join(f"{c} ({n:,})" for c, n in enumerate(counts) if n)
    for command in (["grid", path, "--classes", "3"], ["grid", path, "--classes", "3,4", "--chunk", "100"],
                    ["dtm", path, "--classes", "3"]):
        done = aldpat(*command, "--odir", tmp_path / command[0], "--cell", "2")
        assert done.returncode == 1 and f"it holds classes {held}" in done.stderr, done.stderr


def test_dtm_of_a_vendor_file_has_no_pit_at_the_planted_noise(vendor, tmp_path):
    """The planted class-7 points, 15 m under the points they copy, are no ground of the DTM (the
    low-outlier test off, so that the classes alone keep them out); with every class taking part
    they dig pits there."""
    import rasterio

    path, low, _held, _classes, _version = vendor
    src = laspy.read(path)
    at = {}
    for label, extra in (("kept", []), ("taken", ["--ignore-classes", "none"])):
        aldpat("dtm", path, "--odir", tmp_path / label, "--cell", "2", "--low-outliers", "none", *extra).ok()
        with rasterio.open(tmp_path / label / "site_dtm.tif") as ds:
            rows, cols = rasterio.transform.rowcol(ds.transform, np.asarray(src.x)[low], np.asarray(src.y)[low])
            at[label] = ds.read(1)[np.asarray(rows), np.asarray(cols)]
    deeper = at["kept"] - at["taken"]
    assert (deeper > 5).mean() > 0.5, np.sort(deeper)  # pits where the vendor's noise takes part
    assert np.nanmin(at["kept"] - (np.asarray(src.z)[low] + 15.0)) > -60  # sanity: the same place


def test_thin_lowest_never_keeps_the_vendors_noise_or_withheld_points(vendor, tmp_path):
    """``thin --method lowest`` kept each cell's lowest point whatever its class: every planted
    class-7 point, 15 m under the ground, was its cell's point, and so every pit the noise digs
    went into the thinned file (and withheld points with it). Set-aside points take no part and
    are not written, as in the filters; ``--ignore-classes none`` lets the classes take part."""
    path, low, _held, _classes, _version = vendor
    src = laspy.read(path)
    aldpat("thin", path, "--cell", "2", "--odir", tmp_path / "kept").ok()
    thinned = laspy.read(tmp_path / "kept" / "site_thin.laz")
    intensity = np.asarray(thinned.intensity)  # each point's row in the source
    classes = np.asarray(thinned.classification)
    assert not np.isin(classes, (7, 18)).any() and not np.asarray(thinned.withheld).any()
    assert len(thinned.points) > 1000
    # every cell a kept point stands in still gets the lowest of its points taking part
    part = ~np.isin(np.asarray(src.classification), (7, 18)) & ~np.asarray(src.withheld).astype(bool)
    column, row = (np.floor(np.asarray(v) / 2).astype(np.int64) for v in (src.x, src.y))
    cell = column * 1_000_003 + row
    order = np.lexsort((np.asarray(src.z), cell))
    order = order[part[order]]
    first = order[np.r_[True, cell[order][1:] != cell[order][:-1]]]
    np.testing.assert_array_equal(np.sort(np.asarray(src.z)[first]), np.sort(np.asarray(thinned.z)))
    aldpat("thin", path, "--cell", "2", "--ignore-classes", "none", "--odir", tmp_path / "taken").ok()
    taken = laspy.read(tmp_path / "taken" / "site_thin.laz")
    assert np.isin(np.asarray(taken.intensity), low).sum() > PLANTED // 2  # the old result: noise kept
    assert not np.isin(intensity, low).any()


def test_text_to_las_is_valid_las_named_as_ours(tmp_path):
    """convert and filter from text: return 1 of 1 on every point and in the header's counts, the
    generating software aldpat's; --crs is written, and a LAS or GeoTIFF without a CRS says so."""
    from aldpat import __version__

    samp = TEST_DATA.parent.parent / "jobs" / "data" / "samp24.txt"
    done = aldpat("convert", samp, "--out-format", "laz", "--odir", tmp_path / "c").ok()
    las = laspy.read(tmp_path / "c" / "samp24.laz")
    n = len(las.points)
    assert (np.asarray(las.return_number) == 1).all() and (np.asarray(las.number_of_returns) == 1).all()
    assert las.header.number_of_points_by_return[0] == n and las.header.generating_software == f"aldpat {__version__}"
    assert done.stderr.count("written without a CRS") == 1
    # a LAS from another program's LAS names aldpat too
    aldpat("filter", "gapm", SLICE, "--odir", tmp_path / "f").ok()
    assert laspy.read(tmp_path / "f" / "csite1_slice_gapm.laz").header.generating_software.startswith("aldpat ")
    # filter of text to LAS takes --crs
    with_crs = aldpat("filter", "pm", samp, "--out-format", "laz", "--crs", "EPSG:32632", "--odir", tmp_path / "p").ok()
    out = laspy.read(tmp_path / "p" / "samp24_pm.laz")
    assert out.header.parse_crs().to_epsg() == 32632 and "without a CRS" not in with_crs.stderr
    assert set(np.unique(out.classification)) <= {1, 2, 7}  # a LAS output of text is classified too
    dtm = aldpat("dtm", samp, "--odir", tmp_path / "d", "--cell", "2").ok()
    assert dtm.stderr.count("written without a CRS") == 1


def test_info_is_a_technicians_first_look(vendor):
    """LAS version and point format, software, class and return histograms, withheld points, and
    one warning line for the planted 800 m noise."""
    import json

    path, _low, _held, classes, version = vendor
    done = aldpat("info", path, "--json").ok()
    rec = json.loads(done.stdout)
    assert rec["las_version"] == version and rec["point_format"] == (6 if version == "1.4" else 1)
    assert rec["classes"] == {str(c): int(n) for c, n in zip(*np.unique(classes, return_counts=True), strict=False)}
    assert sum(rec["returns"].values()) == rec["count"] and set(rec["returns"]) == {"1", "2"}
    assert rec["withheld"] == WITHHELD and rec["software"]
    assert done.stderr.count("far outside the bulk of the file") == 1 and "high noise?" in done.stderr
    plain = aldpat("info", SLICE).ok()
    assert "far outside" not in plain.stderr and "classes  0: 12,379" in plain.stdout


def test_info_names_a_stray_point_that_stretches_the_extent(tmp_path):
    """One wrong x of 1e12 among a strip's points makes every grid of the file span the gap:
    info says so in one line (and nothing for the strip alone)."""
    rng = np.random.default_rng(3)
    x, y = 500000 + rng.uniform(0, 300, 2000), 4000000 + rng.uniform(0, 100, 2000)
    rows = np.column_stack([x, y, 100 + rng.normal(0, 0.2, 2000)])
    np.savetxt(tmp_path / "strip.txt", rows, fmt="%.2f")
    assert "far outside" not in aldpat("info", tmp_path / "strip.txt").ok().stderr
    rows[700, 0] = 1e12
    np.savetxt(tmp_path / "stray.txt", rows, fmt="%.2f")
    done = aldpat("info", tmp_path / "stray.txt").ok()
    lines = [ln for ln in done.stderr.splitlines() if "far outside" in ln]
    assert len(lines) == 1 and "x values lie far outside the bulk" in lines[0] and "1e+12" in lines[0], done.stderr


def test_the_info_sample_is_uniform_and_bounded():
    """Bottom-k sampling over chunks: at most SAMPLE rows whatever the file's size, drawn alike
    from every part of it."""
    from aldpat.tasks.info import SAMPLE, Sample

    sample = Sample()
    for start in range(0, 3_000_000, 100_000):  # thirty chunks
        z = np.arange(start, start + 100_000, dtype=float)
        sample.add(z, z, z)
    rows = sample.rows
    assert len(rows) <= 2 * SAMPLE
    counts = np.histogram(rows[:, 2], bins=3, range=(0, 3_000_000))[0]
    assert counts.min() > 0.9 * counts.mean()  # each third of the file alike
