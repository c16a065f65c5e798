"""merge-boundary (manual task 5) and shapefile (task 6): the 5-column file, polygons, .prj, OGR."""

import itertools
import re

import numpy as np
import pytest
import shapefile as pyshp

from aldpat.errors import InputFormatError
from aldpat.io.merged_boundary import read_merged
from aldpat.io.shapefile import Polygon, read_polygons, write_polygons
from aldpat.tasks import get_task

# two counter-clockwise boundary rings as strip-boundary writes them (closed, x y z i)
RING_A = np.array([[0, 0, 1.5, 7], [100, 0, 1.25, 8], [100, 40, 2, 9], [0, 40, 3, 10], [0, 0, 1.5, 7]], float)
RING_B = np.array([[50, 30, 5, 1], [150, 30, 6, 2], [150, 70, 7, 3], [50, 70, 8, 4], [50, 30, 5, 1]], float)


@pytest.fixture
def bounds(tmp_path):
    a, b = tmp_path / "s1_1_Bound.txt", tmp_path / "s2_1_Bound.txt"
    np.savetxt(a, RING_A, fmt="%.2f %.2f %.2f %d")
    np.savetxt(b, RING_B, fmt="%.2f %.2f %.2f %d")
    return a, b


def test_merged_file_has_five_columns_and_separators(tmp_path, bounds, runner, cli):
    out = runner.invoke(cli, ["merge-boundary", *map(str, bounds), "-o", str(tmp_path / "merged.txt")])
    assert out.exit_code == 0, out.output
    lines = (tmp_path / "merged.txt").read_text().splitlines()
    assert lines[0] == "0.00 0.00 1.50 1 s1_1_Bound.txt"
    assert lines[5] == "-1111"
    assert lines[6] == "50.00 30.00 5.00 2 s2_1_Bound.txt"
    assert len(lines) == 11 and lines[-1].endswith("s2_1_Bound.txt")
    strips = read_merged(tmp_path / "merged.txt")
    assert [(s.index, s.name) for s in strips] == [(1, "s1_1_Bound.txt"), (2, "s2_1_Bound.txt")]
    assert np.array_equal(strips[1].xyz, RING_B[:, :3])


def test_merge_needs_an_output_name(bounds, runner, cli):
    out = runner.invoke(cli, ["merge-boundary", *map(str, bounds)])
    assert out.exit_code == 2 and "output: required (--output on the command line)" in out.output


def test_comma_delimiter_and_names_with_spaces_read_back(tmp_path, bounds):
    odd = tmp_path / "strip one_Bound.txt"
    odd.write_text(bounds[0].read_text())
    get_task("merge-boundary")([odd, bounds[1]], output=str(tmp_path / "m.csv"), delimiter="comma")
    assert (tmp_path / "m.csv").read_text().splitlines()[0] == "0.00,0.00,1.50,1,strip one_Bound.txt"
    assert [s.name for s in read_merged(tmp_path / "m.csv")] == ["strip one_Bound.txt", "s2_1_Bound.txt"]


def test_shapefile_polygons_attributes_orientation_and_prj(tmp_path, bounds):
    get_task("merge-boundary")(bounds, output=str(tmp_path / "merged.txt"))
    report = get_task("shapefile")([tmp_path / "merged.txt"], crs="EPSG:32617")
    assert report.exit_code == 0, report.results[0].error
    with pyshp.Reader(str(tmp_path / "merged.shp")) as r:
        assert r.shapeType == pyshp.POLYGON and len(r) == 2
        assert [tuple(rec) for rec in r.records()] == [(1, "s1_1_Bound.txt"), (2, "s2_1_Bound.txt")]
        ring = r.shape(0).points
        assert ring[0] == ring[-1]  # closed
        assert pyshp.signed_area(ring) < 0  # clockwise outer ring (pyshp: negative = clockwise)
        assert sorted(map(tuple, ring[:-1])) == sorted(map(tuple, RING_A[:-1, :2].tolist()))
    import pyproj

    crs = pyproj.CRS.from_wkt((tmp_path / "merged.prj").read_text())
    assert crs.to_epsg() == 32617 or crs.equals(pyproj.CRS.from_epsg(32617), ignore_axis_order=True)


def test_shapefile_opens_in_ogr_with_its_crs(tmp_path, bounds):
    pyogrio = pytest.importorskip("pyogrio")  # test-only: GDAL/OGR's own reading of the files
    get_task("merge-boundary")(bounds, output=str(tmp_path / "merged.txt"))
    get_task("shapefile")([tmp_path / "merged.txt"], output=str(tmp_path / "strips.shp"), crs="EPSG:32617")
    info = pyogrio.read_info(tmp_path / "strips.shp")
    assert info["features"] == 2 and info["geometry_type"] == "Polygon"
    assert info["crs"] == "EPSG:32617"
    assert list(info["fields"]) == ["strip", "file"]
    assert list(info["total_bounds"]) == [0.0, 0.0, 150.0, 70.0]
    _meta, _, _geometry, fields = pyogrio.raw.read(tmp_path / "strips.shp")
    assert fields[0].tolist() == [1, 2] and fields[1].tolist() == ["s1_1_Bound.txt", "s2_1_Bound.txt"]


def test_holes_are_counter_clockwise_and_read_back(tmp_path):
    outer = np.array([[0, 0], [0, 10], [10, 10], [10, 0]], float)  # given clockwise
    hole = np.array([[3, 3], [3, 6], [6, 6], [6, 3]], float)  # given clockwise too
    write_polygons(tmp_path / "h.shp", [Polygon([outer, hole], (1,))], [("id", "N", 5, 0)])
    with pyshp.Reader(str(tmp_path / "h.shp")) as r:
        shape = r.shape(0)
        parts = list(shape.parts) + [len(shape.points)]
        rings = [shape.points[a:b] for a, b in itertools.pairwise(parts)]
    assert pyshp.signed_area(rings[0]) < 0 and pyshp.signed_area(rings[1]) > 0
    polys = read_polygons(tmp_path / "h.shp")
    assert len(polys) == 1 and len(polys[0]) == 2
    assert not (tmp_path / "h.prj").exists()


def test_existing_shapefile_needs_overwrite(tmp_path, bounds):
    get_task("merge-boundary")(bounds, output=str(tmp_path / "merged.txt"))
    assert get_task("shapefile")([tmp_path / "merged.txt"]).exit_code == 0
    again = get_task("shapefile")([tmp_path / "merged.txt"])
    assert again.exit_code == 1 and "exists" in again.results[0].error
    assert get_task("shapefile")([tmp_path / "merged.txt"], overwrite=True).exit_code == 0


def test_a_comma_in_a_file_name_reads_back(tmp_path):
    """merge-boundary writes space-delimited lines; a comma in a boundary file's name (the last
    column) made the reader split the whole line at commas, so ``shapefile`` could not read what
    ``merge-boundary`` wrote ("expected 5 columns, found 2"). The delimiter is told by the first
    column now."""
    a, b = tmp_path / "strip,A_Bound.txt", tmp_path / "stripB_Bound.txt"
    np.savetxt(a, RING_A, fmt="%.2f %.2f %.2f %d")
    np.savetxt(b, RING_B, fmt="%.2f %.2f %.2f %d")
    merged = tmp_path / "merged.txt"
    assert get_task("merge-boundary")([a, b], output=str(merged)).exit_code == 0
    strips = read_merged(merged)
    assert [s.name for s in strips] == ["strip,A_Bound.txt", "stripB_Bound.txt"]
    assert get_task("shapefile")([merged], crs="EPSG:32632").exit_code == 0
    assert [r[1] for r in pyshp.Reader(str(merged.with_suffix(".shp"))).records()] == [
        "strip,A_Bound.txt", "stripB_Bound.txt"]


def test_a_strip_enclosing_no_area_is_skipped_by_name_and_the_others_written(tmp_path):
    """A strip whose boundary crosses itself to no area (a bow-tie of equal halves) has four
    distinct vertices, passed the check for three, and made the writer refuse the whole file with
    a pyshp traceback, naming no strip; the other strips were not written. In a fresh process:
    a warning naming the strip, the others written."""
    from tests.cli.fresh import aldpat

    merged = tmp_path / "m.txt"
    merged.write_text("0 0 1 1 a.txt\n10 0 1 1 a.txt\n10 10 1 1 a.txt\n0 10 1 1 a.txt\n-1111\n"
                      "0 0 1 3 c.txt\n10 10 1 3 c.txt\n10 0 1 3 c.txt\n0 10 1 3 c.txt\n")
    done = aldpat("shapefile", "m.txt", "--crs", "32632", cwd=tmp_path).ok()
    assert "strip 3 (c.txt): its boundary encloses no area" in done.stderr
    assert [r[1] for r in pyshp.Reader(str(tmp_path / "m.shp")).records()] == ["a.txt"]


@pytest.mark.parametrize("bad, message", [
    ("nan 4000000 100 1 a.txt", r"bad\.txt:2: x = nan is not a plausible coordinate"),
    ("500005 1e300 100 1 a.txt", r"bad\.txt:2: y = 1e300 is not a plausible coordinate"),
    ("500005 4000005 inf 1 a.txt", r"bad\.txt:2: z = inf is not a plausible coordinate"),
    ("500005 4000005 100 inf a.txt", r"bad\.txt:2: strip_index inf is not a whole number of at most 9 digits"),
    ("500005 4000005 100 1e20 a.txt", r"bad\.txt:2: strip_index 1e20 is not a whole number"),
    ("500005 4000005 100 1.5 a.txt", r"bad\.txt:2: strip_index 1.5 is not a whole number"),
])
def test_a_merged_file_line_that_is_no_boundary_point_is_named(tmp_path, bad, message):
    """A NaN or 1e300 corner went into the shapefile as it was, an index of 1e20 was cut to the
    field's ten digits, and an infinite one was an internal error."""
    from tests.cli.fresh import aldpat

    merged = tmp_path / "bad.txt"
    rows = ["500000 4000000 100 1 a.txt", bad, "500010 4000000 100 1 a.txt", "500010 4000010 100 1 a.txt"]
    merged.write_text("\n".join(rows) + "\n")
    with pytest.raises(InputFormatError, match=message):
        read_merged(merged)
    done = aldpat("shapefile", merged, "-o", tmp_path / "out" / "b.shp")
    assert done.returncode == 1 and re.search(message, done.stderr), done.stderr
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_no_usable_strip_is_the_data_s_fault_not_a_usage_error(tmp_path):
    from tests.cli.fresh import aldpat

    merged = tmp_path / "one.txt"
    merged.write_text("500000 4000000 100 1 a.txt\n")
    done = aldpat("shapefile", merged, "-o", tmp_path / "one.shp")
    assert done.returncode == 1 and "one.txt: no strip with a usable boundary" in done.stderr


def test_an_output_named_with_another_extension_is_refused_and_one_without_gets_shp(tmp_path, bounds):
    """``-o m.txt`` wrote m.shp (and its .shx, .dbf) beside it without a word; a name without an
    extension is the shapefile's stem, as pyshp and ogr2ogr take it."""
    from tests.cli.fresh import aldpat

    merged = tmp_path / "merged.txt"
    assert aldpat("merge-boundary", *bounds, "-o", merged).returncode == 0
    done = aldpat("shapefile", merged, "-o", tmp_path / "m.txt")
    assert done.returncode == 2 and "output: a shapefile is named FILE.shp, not '.txt' (m.txt)" in done.stderr
    assert not list(tmp_path.glob("m.*"))
    done = aldpat("shapefile", merged, "-o", tmp_path / "strips")
    assert done.returncode == 0, done.stderr
    assert len(pyshp.Reader(str(tmp_path / "strips.shp")).shapes()) == 2
