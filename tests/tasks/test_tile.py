"""tile (manual task 7): cores, buffers, directions, tile_parameter.txt, no doubling on re-runs."""

from pathlib import Path

import numpy as np
import pytest

from aldpat.errors import UsageError
from aldpat.tasks import get_task


def make_strips(tmp_path: Path) -> list[Path]:
    """Two overlapping strips on a 1 m lattice with unique z, so every point can be traced."""
    rng = np.random.default_rng(5)
    paths = []
    for k, (x0, x1) in enumerate([(1000, 1250), (1150, 1420)]):
        xs, ys = np.meshgrid(np.arange(x0, x1, 3.0) + 0.5, np.arange(2000, 2170, 3.0) + 0.5)
        n = xs.size
        pts = np.column_stack([xs.ravel(), ys.ravel(), k * 1e5 + np.arange(n) * 0.01, rng.integers(0, 255, n)])
        path = tmp_path / f"strip{k + 1}_2.txt"
        np.savetxt(path, pts, fmt="%.2f %.2f %.2f %d")
        paths.append(path)
    return paths


def read_tiles(folder: Path) -> dict[str, np.ndarray]:
    return {p.name: np.loadtxt(p, ndmin=2) for p in sorted(folder.glob("tile_*_*.txt"))}


@pytest.mark.parametrize("direction", ["xy", "x", "y"])
def test_every_point_in_one_core_and_the_buffers_it_falls_in(tmp_path, direction):
    strips = make_strips(tmp_path)
    out = tmp_path / "tiles"
    report = get_task("tile")(strips, width=100, height=50, buffer=10, direction=direction,
                              bounds=(1000, 2000, 1420, 2170), odir=str(out))
    assert report.exit_code == 0, report.results[0].error
    tiles = read_tiles(out)
    params = [ln.split() for ln in (out / "tile_parameter.txt").read_text().splitlines()]
    assert len(params) == len(tiles)
    everything = np.concatenate([np.loadtxt(p) for p in strips])
    core_hits = np.zeros(len(everything), dtype=int)
    key = {z: k for k, z in enumerate(everything[:, 2].round(2))}
    for row in params:
        path, (x0, x1, y0, y1, w, h, b) = Path(row[0]), map(float, row[1:])
        assert path.parent == out.resolve() and path.name == f"tile_{x0:g}_{y0:g}.txt"  # lower-left corner
        assert b == 10 and w == x1 - x0 and h == y1 - y0
        if direction == "xy":
            assert (w, h) == (100, 50)
        if direction == "x":
            assert (y0, y1) == (2000, 2170) and w == 100
        if direction == "y":
            assert (x0, x1) == (1000, 1420) and h == 50
        data = tiles[path.name]
        # buffered box: exactly the points of all strips inside it
        expected = everything[(everything[:, 0] >= x0 - b) & (everything[:, 0] < x1 + b)
                              & (everything[:, 1] >= y0 - b) & (everything[:, 1] < y1 + b)]
        assert sorted(data[:, 2].round(2)) == sorted(expected[:, 2].round(2))
        core = data[(data[:, 0] >= x0) & (data[:, 0] < x1) & (data[:, 1] >= y0) & (data[:, 1] < y1)]
        for z in core[:, 2].round(2):
            core_hits[key[z]] += 1
    assert (core_hits == 1).all()  # each input point in exactly one tile core


def test_rerun_does_not_double_points(tmp_path):
    strips = make_strips(tmp_path)
    out = tmp_path / "tiles"
    kwargs = {"width": 200, "height": 200, "buffer": 5, "bounds": (1000, 2000, 1400, 2200), "odir": str(out)}
    assert get_task("tile")(strips, **kwargs).exit_code == 0
    first = {k: len(v) for k, v in read_tiles(out).items()}
    again = get_task("tile")(strips, **kwargs)
    assert again.exit_code == 1 and "exists" in again.results[0].error
    assert {k: len(v) for k, v in read_tiles(out).items()} == first  # untouched
    assert list(out.glob("*aldpat-tmp*")) == []
    assert get_task("tile")(strips, overwrite=True, **kwargs).exit_code == 0
    assert {k: len(v) for k, v in read_tiles(out).items()} == first
    # --append is ALDPAT's behaviour, on request: the points are added again
    assert get_task("tile")(strips[:1], append=True, **kwargs).exit_code == 0
    once = {k: len(v) for k, v in read_tiles(out).items()}
    strip1 = np.loadtxt(strips[0])
    added = sum(once.values()) - sum(first.values())
    assert added >= len(strip1)
    assert len((out / "tile_parameter.txt").read_text().splitlines()) == len(first)


def test_default_bounds_are_the_data_extent_and_fields_xyz(tmp_path):
    strips = make_strips(tmp_path)
    report = get_task("tile")(strips, width=1000, height=1000, fields="xyz", odir=str(tmp_path / "t"))
    assert report.exit_code == 0
    tiles = read_tiles(tmp_path / "t")
    assert list(tiles) == ["tile_1000_2000.txt"]  # the corner on the 1000 m lattice, not the data's minimum
    data = tiles["tile_1000_2000.txt"]
    assert data.shape[1] == 3
    assert len(data) == sum(len(np.loadtxt(p)) for p in strips)


def test_the_origin_shifts_the_lattice_and_tiles_without_a_core_point_are_not_written(tmp_path):
    strips = make_strips(tmp_path)  # x 1000.5..1419.5, y 2000.5..2168.5
    report = get_task("tile")(strips, width=200, height=200, buffer=20, origin=(50, 10), odir=str(tmp_path / "t"))
    assert report.exit_code == 0, report.results[0].error
    # x tiles from 850 (holding 1000.5) to 1250 (holding 1419.5), y from 1810 to 2010
    names = sorted(read_tiles(tmp_path / "t"))
    assert names == ["tile_1050_1810.txt", "tile_1050_2010.txt", "tile_1250_1810.txt", "tile_1250_2010.txt",
                     "tile_850_1810.txt", "tile_850_2010.txt"]
    # the area from x 800: the tile 800..1000 would hold buffer points (x < 1030) and no point of its own
    report = get_task("tile")(strips, width=200, height=200, buffer=30, bounds=(800, 2000, 1600, 2200),
                              odir=str(tmp_path / "u"))
    assert report.exit_code == 0, report.results[0].error
    assert sorted(read_tiles(tmp_path / "u")) == ["tile_1000_2000.txt", "tile_1200_2000.txt", "tile_1400_2000.txt"]
    assert len((tmp_path / "u" / "tile_parameter.txt").read_text().splitlines()) == 3


def test_las_tiles_keep_attributes_and_mark_their_buffer_points(tmp_path):
    import laspy

    src = Path(__file__).resolve().parents[1] / "data" / "fsite5_strip.laz"
    report = get_task("tile")([src], width=300, height=300, buffer=20, origin=(494200, 5420300),
                              bounds=(494200, 5420300, 494800, 5420600), odir=str(tmp_path))
    assert report.exit_code == 0, report.results[0].error
    tiles = sorted(tmp_path.glob("tile_*_*.laz"))
    assert [p.name for p in tiles] == ["tile_494200_5420300.laz", "tile_494500_5420300.laz"]
    original = laspy.read(src)
    own = []
    for p in tiles:
        las = laspy.read(p)
        x0, y0 = (float(v) for v in p.stem.split("_")[1:])
        buffer = np.asarray(las.tile_buffer) == 1
        inside = (las.x >= x0) & (las.x < x0 + 300) & (las.y >= y0) & (las.y < y0 + 300)
        assert np.array_equal(buffer, ~inside) and buffer.any()  # the mark is the core's complement
        assert str(las.header.version) == "1.4"  # extra bytes: PDAL reads them from LAS 1.4
        assert las.header.parse_crs().to_epsg() == 32632
        assert np.all(np.asarray(las.return_number) == 1)
        own.append(las.points.array[~buffer])
    assert sum(map(len, own)) == original.header.point_count
    # tiling the tiles again leaves their buffer points out: every point once in a core
    again = get_task("tile")(tiles, width=600, height=300, origin=(494200, 5420300), odir=str(tmp_path / "again"))
    assert again.exit_code == 0
    retiled = laspy.read(tmp_path / "again" / "tile_494200_5420300.laz")
    assert len(retiled.points) == original.header.point_count
    assert "buffer points of the inputs" in (tmp_path / "again" / "tile_parameter.log").read_text()
    with pytest.raises(UsageError, match="--append works on text tiles only"):  # refused before anything runs
        get_task("tile")([src], append=True, out_format="laz", odir=str(tmp_path))


def test_a_las_of_buffer_points_only_is_refused_not_tiled_into_nothing(tmp_path):
    """Buffer copies are left out, their own tiles holding them: a file of nothing else wrote a
    tile_parameter.txt of no tile, exit 0."""
    import laspy

    from tests.cli.fresh import aldpat

    las = laspy.read(Path(__file__).resolve().parents[1] / "data" / "fsite5_strip.laz")
    las.add_extra_dim(laspy.ExtraBytesParams(name="tile_buffer", type=np.uint8))
    las.tile_buffer = np.ones(len(las.points), np.uint8)
    las.write(tmp_path / "marked.laz")
    done = aldpat("tile", tmp_path / "marked.laz", "--width", "300", "--height", "300", "--odir", tmp_path / "t")
    assert done.returncode == 1, done.stderr
    assert "marked.laz: every point is marked tile_buffer" in done.stderr
    assert not (tmp_path / "t" / "tile_parameter.txt").exists()


def test_more_las_tiles_than_may_be_open_are_written_in_groups_alike(tmp_path, monkeypatch):
    """LAS/LAZ tiles keep a writer open each: past OPEN_LAS_TILES they are written that many at a
    time, the input read once a group; the tiles are those of one pass, point for point."""
    import laspy

    from aldpat.tasks import tile

    src = Path(__file__).resolve().parents[1] / "data" / "fsite5_strip.laz"
    args = {"width": 60, "height": 60, "buffer": 5, "origin": (494200, 5420300)}
    assert get_task("tile")([src], odir=str(tmp_path / "one"), **args).exit_code == 0
    monkeypatch.setattr(tile, "OPEN_LAS_TILES", 7)
    opened = []
    real_open = tile.TileSink._open
    monkeypatch.setattr(tile.TileSink, "_open", lambda self, *a: opened.append(
        sum(e["writer"] is not None for e in self.tiles.values())) or real_open(self, *a))
    assert get_task("tile")([src], odir=str(tmp_path / "groups"), **args).exit_code == 0
    assert max(opened) < 7 and len(opened) > 20  # never more than 7 writers open, and many tiles
    one, groups = sorted((tmp_path / "one").glob("tile_*.laz")), sorted((tmp_path / "groups").glob("tile_*.laz"))
    assert [p.name for p in one] == [p.name for p in groups]
    for a, b in zip(one, groups, strict=True):
        assert laspy.read(a).points.array.tobytes() == laspy.read(b).points.array.tobytes()
    assert (tmp_path / "one" / "tile_parameter.txt").read_text().replace("one", "groups") == \
        (tmp_path / "groups" / "tile_parameter.txt").read_text()


def test_the_layout_of_given_bounds_is_checked_with_the_parameters():
    """Over ``--bounds`` the layout depends on the options alone: refused when they are made
    (``--dry-run`` sees it), not when the inputs have been read."""
    from aldpat.errors import ParamError
    from aldpat.tasks.tile import TileParams

    with pytest.raises(ParamError, match=r"bounds: 1e\+09 tiles along one axis"):
        TileParams(bounds=(0.0, 0.0, 1e9, 1e9), width=1.0)
    with pytest.raises(ParamError, match="bounds: a buffer of 500 reaches more than 4.5 tiles of 1 .*up to 1,001 tiles"):
        TileParams(bounds=(0.0, 0.0, 10.0, 10.0), width=1.0, height=1.0, buffer=500.0)
    with pytest.raises(ParamError, match="use a buffer of at most 4.5 or larger tiles"):
        TileParams(bounds=(0.0, 0.0, 10.0, 10.0), width=1.0, height=1.0, buffer=4.6)
    TileParams(bounds=(0.0, 0.0, 10.0, 10.0), width=1.0, height=1.0, buffer=4.5)  # 10 tiles along an axis
    TileParams(width=1.0, buffer=500.0, direction="y")  # x spans the data, whose extent the run reads


def test_append_refuses_another_layout_and_writes_the_sizes_given(tmp_path):
    """``--append`` with tiles of another size took 200 m tiles into a folder of 250 m ones: cores
    overlapping (one point the own point of two tiles), sizes mixed in one tile_parameter.txt,
    200 m points appended into 250 m files. It is refused before any tile is touched; the same
    layout appends as before. The parameter rows carry the sizes as given (333.3, not
    333.29999999998836 from the edges' difference)."""
    from tests.cli.fresh import REPO, aldpat

    sample = REPO / "jobs" / "data" / "samp24.txt"
    aldpat("tile", sample, "--width", "60", "--height", "60", "--buffer", "5", "--odir", "t", cwd=tmp_path).ok()
    before = {p.name: p.read_bytes() for p in (tmp_path / "t").iterdir()}
    done = aldpat("tile", sample, "--width", "50", "--height", "50", "--buffer", "5", "--odir", "t", "--append",
                  cwd=tmp_path)
    assert done.returncode == 2 and "their cores would overlap" in done.stderr
    assert {p.name: p.read_bytes() for p in (tmp_path / "t").iterdir()} == before
    aldpat("tile", sample, "--width", "60", "--height", "60", "--buffer", "5", "--odir", "t", "--append",
           cwd=tmp_path).ok()
    aldpat("tile", sample, "--width", "33.3", "--height", "25", "--origin", "12.345", "-7.7", "--buffer", "7.5",
           "--odir", "odd", cwd=tmp_path).ok()
    rows = (tmp_path / "odd" / "tile_parameter.txt").read_text().splitlines()
    assert all(line.split()[-3:] == ["33.3", "25", "7.5"] for line in rows)


def test_las_inputs_at_finer_scales_are_tiled_exactly(tmp_path):
    """``tile coarse.laz fine.laz``: the tiles took the first input's header, and the second input's
    millimetres were rounded to its centimetres, every point of it moved. The tiles take the finest
    scales that keep every input exact, as ``merge`` does."""
    import laspy

    strip = laspy.read(Path(__file__).resolve().parents[1] / "data" / "fsite5_strip.laz")  # 0.01 m
    x = np.asarray(strip.x)
    east = x >= np.median(x)
    coarse = laspy.LasData(strip.header)
    coarse.points = strip.points[~east]
    coarse.write(tmp_path / "coarse.laz")
    header = laspy.LasHeader(point_format=strip.header.point_format.id, version=strip.header.version)
    header.scales, header.offsets = [0.001] * 3, strip.header.offsets
    fine = laspy.LasData(header)
    fine.x, fine.y, fine.z = x[east] + 0.0037, np.asarray(strip.y)[east] + 0.0041, np.asarray(strip.z)[east]
    fine.write(tmp_path / "fine.laz")
    report = get_task("tile")([tmp_path / "coarse.laz", tmp_path / "fine.laz"], width=300.0, height=300.0,
                              odir=str(tmp_path / "tiles"))
    assert report.exit_code == 0
    tiles = [laspy.read(p) for p in sorted((tmp_path / "tiles").glob("tile_*.laz"))]
    held = {(round(float(a), 4), round(float(b), 4)) for t in tiles for a, b in zip(t.x, t.y, strict=True)}
    for source in (coarse, laspy.read(tmp_path / "fine.laz")):
        assert all((round(float(a), 4), round(float(b), 4)) in held for a, b in zip(source.x, source.y, strict=True))


def test_las_inputs_of_other_extra_dimensions_are_not_tiled_together(tmp_path):
    """The tiles took the first input's extra dimensions: a second input's height_above_ground was
    left out without a word, and, the other way round, the plain input's points were given
    height_above_ground 0 -- a value no one measured. Both orders are refused, naming the files,
    as ``merge`` refuses them, in a fresh process, and no tile is written."""
    import laspy

    from tests.cli.fresh import aldpat

    strip = Path(__file__).resolve().parents[1] / "data" / "fsite5_strip.laz"
    laspy.read(strip).write(tmp_path / "plain.las")
    extra = laspy.read(strip)
    extra.add_extra_dim(laspy.ExtraBytesParams(name="height_above_ground", type=np.float32))
    extra.height_above_ground = np.full(len(extra.points), 0.75, np.float32)
    extra.X = extra.X + 30000  # beside the other strip
    extra.write(tmp_path / "extra.las")
    for order, why in ((["plain.las", "extra.las"], ("extra.las: has height_above_ground (extra bytes), unlike "
                                                    "plain.las")),
                       (["extra.las", "plain.las"], ("plain.las: lacks height_above_ground (extra bytes), unlike "
                                                    "extra.las"))):
        done = aldpat("tile", *order, "--width", "200", "--height", "200", "--odir", "tiles", cwd=tmp_path)
        assert done.returncode == 1, done.stderr
        assert f"{why}: LAS inputs tiled together hold the same extra dimensions" in done.stderr
        assert not (tmp_path / "tiles").exists()


def test_inputs_of_two_crss_are_not_tiled_together(tmp_path):
    """``tile utm.laz swiss.laz`` wrote tiles under the first input's CRS holding the second's
    coordinates too, of another system; as ``merge`` refuses such inputs, ``tile`` does, writing
    nothing."""
    import laspy
    import pyproj

    strip = laspy.read(Path(__file__).resolve().parents[1] / "data" / "fsite5_strip.laz")  # EPSG:32632
    header = laspy.LasHeader(point_format=strip.header.point_format.id, version=strip.header.version)
    header.scales, header.offsets = strip.header.scales, strip.header.offsets
    header.add_crs(pyproj.CRS.from_epsg(2056))
    laspy.LasData(header, strip.points.copy()).write(tmp_path / "swiss.laz")
    strip.write(tmp_path / "utm.laz")
    report = get_task("tile")([tmp_path / "utm.laz", tmp_path / "swiss.laz"], width=300.0, height=300.0,
                              odir=str(tmp_path / "tiles"))
    assert report.exit_code == 1
    assert "swiss.laz: its CRS differs from utm.laz's: tile inputs of one CRS" in report.results[0].error
    assert not (tmp_path / "tiles").exists() or not list((tmp_path / "tiles").iterdir())
