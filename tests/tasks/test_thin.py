"""thin (manual: Reduce Point Density): lowest, median, centre, integer x y, bounded memory."""

from pathlib import Path

import numpy as np
import pytest

from aldpat.io import spill
from aldpat.tasks import get_task

# two 2 x 2 m cells: cell (0, 0) with four points, cell (1, 0) with three
POINTS = np.array([
    [0.20, 0.30, 5.00, 1],
    [1.10, 0.90, 3.00, 2],   # nearest the centre (1, 1) of cell (0, 0)
    [1.70, 1.80, 4.00, 3],
    [0.40, 1.60, 6.00, 4],
    [2.50, 0.50, 9.00, 5],
    [3.40, 1.40, 8.00, 6],
    [3.90, 0.10, 7.00, 7],
])


@pytest.mark.parametrize("method, kept", [
    ("lowest", [1, 6]),   # z 3 and z 7
    ("median", [2, 5]),   # z sorted 3 4 5 6 -> lower middle 4; 7 8 9 -> 8
    ("center", [1, 5]),   # (1.1, .9) is 0.14 from (1, 1); (3.4, 1.4) is 0.57 from (3, 1)
])
def test_methods_by_hand(tmp_path, method, kept):
    src = tmp_path / "p.txt"
    np.savetxt(src, POINTS, fmt="%.2f %.2f %.2f %d")
    assert get_task("thin")([src], cell=2.0, method=method).exit_code == 0
    assert np.array_equal(np.loadtxt(tmp_path / "p_thin.txt"), POINTS[kept])


def test_integer_xy_rounds_half_away_from_zero(tmp_path):
    src = tmp_path / "p.txt"
    np.savetxt(src, [[10.5, 20.49, 1.0], [-3.5, 7.5, 2.0]], fmt="%.2f")
    assert get_task("thin")([src], cell=100.0, cell_height=1.0, xy="integer").exit_code == 0
    lines = (tmp_path / "p_thin.txt").read_text().splitlines()
    assert lines == ["11 20 1.00", "-4 8 2.00"]  # input order kept


def test_cell_width_and_height_differ(tmp_path):
    src = tmp_path / "p.txt"
    np.savetxt(src, POINTS, fmt="%.2f %.2f %.2f %d")
    # 4 m wide, 1 m tall cells: row 0 (y < 1) holds points 0 1 4 6, row 1 holds 2 3 5
    get_task("thin")([src], cell=4.0, cell_height=1.0)
    assert np.array_equal(np.loadtxt(tmp_path / "p_thin.txt"), POINTS[[1, 2]])


@pytest.mark.parametrize("method", ["lowest", "median", "center"])
def test_spilled_buckets_give_the_same_points(tmp_path, monkeypatch, method):
    rng = np.random.default_rng(11)
    n = 20000
    pts = np.column_stack([rng.uniform(0, 300, n), rng.uniform(0, 200, n), rng.normal(50, 5, n).round(2),
                           rng.integers(0, 255, n)])
    src = tmp_path / "big.txt"
    np.savetxt(src, pts, fmt="%.2f %.2f %.2f %d")
    get_task("thin")([src], cell=1.5, method=method, odir=str(tmp_path / "mem"))
    monkeypatch.setattr(spill, "BUCKET_POINTS", 3000)  # about 7 buckets
    made = []

    class Counted(spill.Spill):
        def __init__(self, folder, k):
            made.append(k)
            super().__init__(folder, k)

    monkeypatch.setattr("aldpat.tasks.thin.Spill", Counted)

    from aldpat.io.text import TextReader

    whole = TextReader.chunks
    monkeypatch.setattr(TextReader, "chunks", lambda self, size=4000: whole(self, 4000))
    get_task("thin")([src], cell=1.5, method=method, odir=str(tmp_path / "disk"))
    a = np.loadtxt(tmp_path / "mem" / "big_thin.txt")
    b = np.loadtxt(tmp_path / "disk" / "big_thin.txt")
    assert made and made[0] >= 5  # the bucket files were used
    assert len(a) == len(b)
    assert np.array_equal(a[np.lexsort(a.T[::-1])], b[np.lexsort(b.T[::-1])])
    assert [p.name for p in (tmp_path / "disk").iterdir() if p.name.startswith(".")] == []  # spill removed


def test_las_input_keeps_its_attributes(tmp_path):
    import laspy

    src = Path(__file__).resolve().parents[1] / "data" / "fsite5_strip.laz"
    assert get_task("thin")([src], cell=10.0, odir=str(tmp_path)).exit_code == 0
    out = laspy.read(tmp_path / "fsite5_strip_thin.laz")
    full = laspy.read(src)
    assert 0 < len(out.points) < len(full.points)
    assert out.header.parse_crs().to_epsg() == 32632
    # each kept point is the lowest of its aligned 10 m cell
    i = np.floor(np.asarray(full.x) / 10).astype(int)
    j = np.floor(np.asarray(full.y) / 10).astype(int)
    lowest = {}
    for a, b, z in zip(i, j, np.asarray(full.z), strict=False):
        lowest[(a, b)] = min(lowest.get((a, b), np.inf), z)
    assert len(out.points) == len(lowest)
    for x, y, z in zip(np.asarray(out.x), np.asarray(out.y), np.asarray(out.z), strict=False):
        assert z == lowest[(int(np.floor(x / 10)), int(np.floor(y / 10)))]


def test_las_through_bucket_files_keeps_records(tmp_path, monkeypatch):
    import laspy

    src = Path(__file__).resolve().parents[1] / "data" / "fsite5_strip.laz"
    get_task("thin")([src], cell=4.0, odir=str(tmp_path / "mem"))
    monkeypatch.setattr(spill, "BUCKET_POINTS", 4000)  # about 6 buckets
    get_task("thin")([src], cell=4.0, odir=str(tmp_path / "disk"))
    a = laspy.read(tmp_path / "mem" / "fsite5_strip_thin.laz")
    b = laspy.read(tmp_path / "disk" / "fsite5_strip_thin.laz")
    key = lambda las: sorted(zip(np.asarray(las.X), np.asarray(las.Y), np.asarray(las.Z),
                                 np.asarray(las.intensity), np.asarray(las.return_number), strict=False))
    assert len(a.points) == len(b.points) and key(a) == key(b)


def test_las_to_text_writes_x_y_z_intensity(tmp_path):
    src = Path(__file__).resolve().parents[1] / "data" / "fsite5_strip.laz"
    assert get_task("thin")([src], cell=20.0, out_format="text",
                            odir=str(tmp_path)).exit_code == 0
    assert np.loadtxt(tmp_path / "fsite5_strip_thin.txt").shape[1] == 4


def test_a_point_on_a_cell_edge_is_in_the_cell_above_it(tmp_path):
    """Cells are [i w, (i + 1) w): 512000.60 lies in [512000.6, 512000.8) of 0.2 m cells. Its
    quotient 512000.6 / 0.2 is 2560002.9999999995 in binary floating point, and it fell into the
    cell below, with 512000.50 (a fifth of exact edges at 0.1 and 0.2 m cells). In a fresh
    process, the lowest point of each cell."""
    from tests.cli.fresh import aldpat

    (tmp_path / "edge.txt").write_text("512000.50 5403000.10 1.00\n512000.60 5403000.10 5.00\n"
                                       "512000.70 5403000.10 9.00\n")
    aldpat("thin", "edge.txt", "--cell", "0.2", "--odir", "out", cwd=tmp_path).ok()
    assert (tmp_path / "out" / "edge_thin.txt").read_text().split("\n")[:2] == [
        "512000.50 5403000.10 1.00", "512000.60 5403000.10 5.00"]
