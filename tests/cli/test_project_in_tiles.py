"""A project in tiles, as a user runs it in fresh processes: tile -> filter (the folder) -> dtm
--mosaic -> merge, on slices of two real ISPRS sites.

``tests/data/fsite5_strip.laz`` is a strip of FSite5 (steep, wooded); ``tests/data/csite1_slice.laz``
holds the points of CSite1_red2-utm.laz (the ISPRS test site CSite1 as the PDAL data repository
stores it, first and last returns, urban) with x in 512500..512800 and y in 5403500..5403800.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import laspy
import numpy as np
import pytest
import rasterio

from tests.cli.fresh import REPO, TEST_DATA, aldpat, aldpat_command, leftovers

SITES = {"fsite5": TEST_DATA / "fsite5_strip.laz", "csite1": TEST_DATA / "csite1_slice.laz"}


def stored(las) -> np.ndarray:
    """Every point as one sortable record of what the file stores of it."""
    fields = [las.X, las.Y, las.Z, las.intensity, las.return_number, las.number_of_returns]
    return np.sort(np.rec.fromarrays(fields))


def shared_nodes(tifs: list[Path]) -> tuple[int, int]:
    """(nodes held by two rasters or more, of them those whose values differ in any bit)."""
    seen: dict[tuple[int, int], set[bytes]] = {}
    held: dict[tuple[int, int], int] = {}
    for path in tifs:
        with rasterio.open(path) as ds:
            band = ds.read(1)
            cols, rows = np.meshgrid(np.arange(ds.width), np.arange(ds.height))
            xs, ys = rasterio.transform.xy(ds.transform, rows.ravel(), cols.ravel())
            for x, y, v in zip(np.round(xs, 3), np.round(ys, 3), band.ravel(), strict=False):
                key = (round(float(x) * 1000), round(float(y) * 1000))
                seen.setdefault(key, set()).add(v.tobytes())
                held[key] = held.get(key, 0) + 1
    shared = [k for k, n in held.items() if n > 1]
    return len(shared), sum(len(seen[k]) > 1 for k in shared)


@pytest.mark.parametrize("site", sorted(SITES))
def test_tile_filter_dtm_mosaic_merge(tmp_path, site):
    source = shutil.copy(SITES[site], tmp_path / "site.laz")
    aldpat("tile", source, "--width", "100", "--height", "100", "--buffer", "20", "--odir", "tiles",
           cwd=tmp_path).ok()
    tiles = sorted((tmp_path / "tiles").glob("tile_*.laz"))
    assert len(tiles) >= 6
    for tile in tiles:  # corners on the 100 m lattice, named by the core's lower-left corner
        assert all(float(v) % 100 == 0 for v in tile.stem.split("_")[1:])

    # the folder as it is: tile_parameter.txt and the log beside the tiles are no inputs
    done = aldpat("filter", "gapm", "tiles", "-j", "2", "--result", "classified", "--odir", "ground",
                  cwd=tmp_path).ok()
    assert "tile_parameter" not in done.stderr
    assert len(list((tmp_path / "ground").glob("*_gapm.laz"))) == len(tiles)

    done = aldpat("dtm", "tiles", "-j", "2", "--cell", "2", "--odir", "dtm", "--mosaic", "dtm.vrt",
                  cwd=tmp_path).ok()
    tifs = sorted((tmp_path / "dtm").glob("*_dtm.tif"))
    without = [ln for ln in done.stderr.splitlines() if "no grid written" in ln]
    assert tifs and len(tifs) + len(without) == len(tiles)
    shared, differ = shared_nodes(tifs)
    assert shared > 100 and differ == 0
    with rasterio.open(tmp_path / "dtm.vrt") as vrt:  # from where the command ran, not in dtm/
        assert sorted(Path(f).name for f in vrt.files[1:]) == [t.name for t in tifs]
        mosaic = vrt.read(1, masked=True)
        for tif in tifs:
            with rasterio.open(tif) as ds:
                row, col = vrt.index(*ds.xy(0, 0))
                part = ds.read(1, masked=True)
                window = mosaic[row:row + ds.height, col:col + ds.width]
                assert np.array_equal(window.mask, part.mask)
                assert window.filled(0).tobytes() == part.filled(0).tobytes()

    aldpat("merge", "ground", "-o", "site_gapm.laz", cwd=tmp_path).ok()
    original, merged = laspy.read(source), laspy.read(tmp_path / "site_gapm.laz")
    assert merged.header.point_count == original.header.point_count
    assert np.array_equal(stored(original), stored(merged))  # each input point exactly once
    own = np.concatenate([laspy.read(p).points.array[np.asarray(laspy.read(p).tile_buffer) == 0]
                          for p in sorted((tmp_path / "ground").glob("*_gapm.laz"))])
    assert np.array_equal(np.sort(own["raw_classification"]), np.sort(merged.points.array["raw_classification"]))
    assert (merged.classification == 2).mean() > 0.2
    assert leftovers(tmp_path) == [] and not list(tmp_path.rglob(".aldpat-scratch-*"))


def readme_block(title: str) -> list[str]:
    """The commands of the README's first ``sh`` block after the heading ``title``."""
    text = (REPO / "README.md").read_text(encoding="utf-8")
    section = text[text.index(title):]
    block = re.search(r"```sh\n(.*?)```", section, re.DOTALL)
    assert block is not None
    return [line.split("  #")[0].strip() for line in block.group(1).splitlines() if line.strip()]


def test_the_readme_workflow_runs_as_written(tmp_path):
    """The README's project in tiles, line by line, on FSite5's strip as ``site.laz``."""
    import os
    import subprocess

    shutil.copy(SITES["fsite5"], tmp_path / "site.laz")
    bindir = str(Path(aldpat_command()[0]).parent)
    env = dict(os.environ, PATH=bindir + os.pathsep + os.environ.get("PATH", ""))
    lines = readme_block("### A project in tiles")
    assert [line.split()[1] for line in lines] == ["tile", "filter", "dtm", "grid", "merge"]
    for line in lines:
        proc = subprocess.run(line, shell=True, cwd=tmp_path, env=env, capture_output=True, text=True,
                              timeout=300, check=False)
        assert proc.returncode == 0 and "Traceback" not in proc.stderr, f"{line}\n{proc.stderr}"
    assert (tmp_path / "dtm" / "dtm.vrt").exists() and (tmp_path / "site_gapm.laz").exists()
    assert list((tmp_path / "grids").glob("tile_*_gapm_idw.grd"))


def test_a_tile_that_cannot_be_read_fails_with_the_tiles_that_need_it_and_no_other(tmp_path):
    """One truncated tile among ten: it fails in one line of its own; each tile within the buffer
    of it fails in one line naming it, and each tile needing the ground classes of one of those
    in one line naming that one (their shared edges wait for the tile to be mended); the tiles
    farther away are made. Nothing is said twice."""
    from tests.cli.fresh import DATA

    aldpat("tile", DATA / "samp24.txt", "--width", "30", "--height", "40", "--out-format", "laz", "--odir", "tiles",
           cwd=tmp_path).ok()
    bad = tmp_path / "tiles" / "tile_513720_5403120.laz"
    data = bad.read_bytes()
    bad.write_bytes(data[:len(data) * 2 // 3])
    done = aldpat("dtm", "tiles", "--cell", "1", "--buffer", "10", "--odir", "dtm", cwd=tmp_path)
    assert done.returncode == 1
    lines = [ln for ln in done.stderr.splitlines() if ln.startswith("aldpat:") and "without a CRS" not in ln]
    assert lines[0] == ("aldpat: tiles/tile_513720_5403120.laz: truncated or corrupt LAS/LAZ (IoError: failed to "
                        "fill whole buffer)")
    points = re.findall(r"(tile_\d+_\d+)\.laz: needs the points of its neighbouring tile tile_513720_5403120\.laz "
                        r"within 10 m", done.stderr)
    assert sorted(points) == ["tile_513720_5403160", "tile_513750_5403120", "tile_513750_5403160"]
    classes = re.findall(r"(tile_\d+_\d+)\.laz: needs the ground classes of its neighbouring tile "
                         r"tile_513750_5403120\.laz", done.stderr)
    assert sorted(classes) == ["tile_513780_5403120", "tile_513780_5403160"]
    assert lines[-1] == "aldpat: 6 of 10 inputs failed" and len(lines) == 7, done.stderr
    assert sorted(p.name for p in (tmp_path / "dtm").glob("*.tif")) == [
        f"tile_{x}_{y}_dtm.tif" for x in (513810, 513840) for y in (5403120, 5403160)]
    assert leftovers(tmp_path) == []


def test_a_tile_holding_no_points_is_a_tile_without_data_not_one_that_cannot_be_read(tmp_path):
    """A LAS tile of zero points (a tile emptied by an earlier filter or a delivery's placeholder)
    failed as "no points in file", and with it every tile within the buffer of it and every tile
    needing their ground classes: 6 of 10. It adds no points now: every tile is made, the empty one
    from its neighbours' points near its edges, as identical on the shared edges as any; ``merge``
    of the tiles leaves it out with a warning, as lasmerge does."""
    from tests.cli.fresh import DATA

    aldpat("tile", DATA / "samp24.txt", "--width", "30", "--height", "40", "--out-format", "laz", "--odir", "tiles",
           cwd=tmp_path).ok()
    empty = tmp_path / "tiles" / "tile_513720_5403120.laz"
    las = laspy.read(empty)
    las.points = las.points[:0]
    las.write(empty)
    aldpat("dtm", "tiles", "--cell", "1", "--buffer", "10", "--odir", "dtm", cwd=tmp_path).ok()
    tifs = sorted((tmp_path / "dtm").glob("*.tif"))
    assert len(tifs) == 10 and shared_nodes(tifs)[1] == 0
    done = aldpat("merge", "tiles", "-o", "all.laz", cwd=tmp_path).ok()
    assert "tile_513720_5403120.laz: holds no points: nothing of it is merged" in done.stderr
    held = sum(laspy.open(p).header.point_count for p in (tmp_path / "tiles").glob("tile_*.laz"))
    assert 0 < laspy.open(tmp_path / "all.laz").header.point_count <= held


def test_a_buffer_of_many_tiles_is_refused_once_before_anything_runs(tmp_path):
    """As ``tile`` refuses such buffers: with 40 m tiles a 200 m buffer would make every tile's DTM
    or grid read the points of the tiles five tiles around it, the project again for every tile.
    The run is refused in one line (a usage error, as ``--dry-run`` refuses it), not in one
    failed job a tile."""
    sample = REPO / "jobs" / "data" / "samp24.txt"
    aldpat("tile", sample, "--width", "40", "--height", "40", "--buffer", "5", "--odir", "tiles", cwd=tmp_path).ok()
    tiles = sorted((tmp_path / "tiles").glob("tile_*_*.txt"))  # not tile_parameter.txt
    for command in (["dtm", "tiles", "--cell", "1"], ["grid", "tiles", "--cell", "1"],
                    ["grid", "tiles", "--cell", "1", "--dry-run"]):
        done = aldpat(*command, "--buffer", "200", "--odir", "out", cwd=tmp_path)
        assert done.returncode == 2, done.stderr
        refused = [ln for ln in done.stderr.splitlines() if "reaches more than 4.5 tiles of 40 m" in ln]
        assert len(refused) == 1 and "use a --buffer of at most 180" in refused[0], done.stderr
        assert not (tmp_path / "out").exists()
    aldpat("grid", "tiles", "--cell", "1", "--buffer", "180", "--odir", "out", cwd=tmp_path).ok()
    assert len(list((tmp_path / "out").glob("*.grd"))) == len(tiles)


def test_a_rerun_of_dtm_over_tiles_makes_the_missing_dtms(tmp_path):
    """A run over tiles stopped part way, run again as it was: each missing tile's DTM needs the
    ground classes of its neighbours, whose first pass was refused because their DTMs existed, so
    every missing one failed ("needs the ground classes of its neighbouring tile ..."). The first
    pass now runs for every tile; the missing DTMs are made as an uninterrupted run made them,
    those that exist are refused as without --overwrite, and the mosaic says why it waits."""
    aldpat("tile", SITES["fsite5"], "--width", "150", "--height", "150", "--buffer", "20", "--odir", "tiles",
           cwd=tmp_path).ok()
    aldpat("dtm", "tiles", "--cell", "2", "-j", "2", "--odir", "dtm", "--mosaic", "dtm/dtm.vrt", cwd=tmp_path).ok()
    made = sorted((tmp_path / "dtm").glob("*_dtm.tif"))
    assert len(made) >= 4
    before = {p.name: p.read_bytes() for p in made}
    lost = made[1:3]
    for path in [*lost, tmp_path / "dtm" / "dtm.vrt"]:
        path.unlink()
    done = aldpat("dtm", "tiles", "--cell", "2", "-j", "2", "--odir", "dtm", "--mosaic", "dtm/dtm.vrt", cwd=tmp_path)
    assert done.returncode == 1
    assert "needs the ground classes" not in done.stderr, done.stderr
    assert {p.name: p.read_bytes() for p in (tmp_path / "dtm").glob("*_dtm.tif")} == before
    assert f"mosaic not written: {len(made) - 2} of {len(made)} grids exist from an earlier run" in done.stderr
    aldpat("dtm", "tiles", "--cell", "2", "--odir", "dtm", "--mosaic", "dtm/dtm.vrt", "--overwrite", cwd=tmp_path).ok()
    assert (tmp_path / "dtm" / "dtm.vrt").exists()
    assert leftovers(tmp_path) == []


def test_catalog_over_tiles_with_buffers_says_their_copies_are_taken_twice(tmp_path):
    """``filter --catalog`` takes every input as one: tiles made with a buffer hold copies of their
    neighbours' points, which it took as points beside the ones they copy -- 33,429 points of a
    site of 20,643 -- without a word. It says so once, and not of tiles made without buffers."""
    source = shutil.copy(SITES["fsite5"], tmp_path / "site.laz")
    for folder, buffer in (("buffered", "30"), ("plain", "0")):
        aldpat("tile", source, "--width", "250", "--height", "250", "--buffer", buffer, "--odir", folder,
               cwd=tmp_path).ok()
        done = aldpat("filter", "pm", folder, "--catalog", "--chunk", "200", "--odir", f"{folder}_pm",
                      cwd=tmp_path).ok()
        said = [ln for ln in done.stderr.splitlines() if "which --catalog takes as points beside" in ln]
        assert len(said) == (1 if buffer != "0" else 0), done.stderr


def test_a_tile_of_another_crs_is_waited_for_as_one_that_cannot_be_read(tmp_path):
    """A tile of the project replaced by one labelled with another CRS gave its points to its
    neighbours' DTMs as if they were of theirs; each tile within the buffer of it now fails naming
    it and both CRSs, as for a tile that cannot be read, and the tiles farther away are made."""
    import pyproj

    source = shutil.copy(SITES["fsite5"], tmp_path / "site.laz")
    aldpat("tile", source, "--width", "150", "--height", "150", "--buffer", "10", "--odir", "tiles",
           cwd=tmp_path).ok()
    tiles = sorted((tmp_path / "tiles").glob("tile_*.laz"))
    other = tiles[0]  # a corner: the tiles farther away do not wait for it
    las = laspy.read(other)
    header = laspy.LasHeader(point_format=las.header.point_format, version=las.header.version)
    header.scales, header.offsets = las.header.scales, las.header.offsets
    header.add_crs(pyproj.CRS.from_epsg(2056))
    laspy.LasData(header, las.points).write(other)
    done = aldpat("dtm", "tiles", "--cell", "2", "--buffer", "10", "--odir", "dtm", cwd=tmp_path)
    assert done.returncode == 1
    assert re.search(rf"needs the points of its neighbouring tile {other.name} within 10 m, whose CRS "
                     r"\(EPSG:2056\) is not this tile's \(EPSG:32632\)", done.stderr), done.stderr
    assert len(list((tmp_path / "dtm").glob("*.tif"))) > 0
