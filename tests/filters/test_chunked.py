"""``aldpat filter ALGO --chunk SIZE``: chunks with buffers give the whole file's classes.

Known answer: the whole-file run. For ``etew``, ``pm``, ``pm2d``, ``pmcircle`` and ``slope``
(marks that depend only on the cells within their windows or search radius) the outputs must be byte-identical with the
automatic buffer; a buffer smaller than the windows' reach must show (the test would be empty
otherwise). The others are measured against the whole file.
"""

from __future__ import annotations

import filecmp
from pathlib import Path

import laspy
import numpy as np
import pytest

from aldpat.errors import UsageError
from aldpat.filters.chunked import chunk_plan
from aldpat.filters.registry import FILTERS
from aldpat.io.chunks import ChunkLattice, spill_chunks
from aldpat.io.table import PointTable
from aldpat.tasks import get_task

REPO = Path(__file__).resolve().parents[2]
SAMPLE = REPO / "jobs" / "data" / "samp24.txt"  # 122 m x 72 m, about 1 point/m2
STRIP = REPO / "tests" / "data" / "fsite5_strip.laz"  # 600 m x 220 m, 0.16 points/m2

#: windows small enough that sample 24 is many chunks wide with the buffer they need; the
#: low-outlier test's terrain reach cut to 4 m for the same reason (at its 20 m default a 20 m
#: chunk would copy each point into more chunks than a run allows)
_NEAR = {"low_outlier_reach": 4.0}
SMALL = {"pm": {"window_series": (1, 2, 4, 8), **_NEAR}, "pm2d": {"window_series": (1, 2, 4, 8), **_NEAR},
         "pmcircle": {"window_series": (1, 2, 4, 8), **_NEAR}, "etew": {"loop_times": 4, **_NEAR},
         "slope": {"search_radius": 8.0, **_NEAR}}


def run(algorithm: str, source: Path, odir: Path, **options):
    report = get_task("filter", algorithm)([source], odir=str(odir), result="classified", marks=True, **options)
    assert report.exit_code == 0, [r.error for r in report.results]
    return report


@pytest.mark.parametrize("algorithm", sorted(SMALL))
def test_bounded_filters_give_the_whole_files_bytes(tmp_path, algorithm):
    options = SMALL[algorithm]
    run(algorithm, SAMPLE, tmp_path / "whole", **options)
    run(algorithm, SAMPLE, tmp_path / "chunks", chunk=20.0, jobs=2, **options)  # buffer (31 / 9 m) > chunk
    name = f"samp24_{algorithm}.txt"
    assert filecmp.cmp(tmp_path / "whole" / name, tmp_path / "chunks" / name, shallow=False)
    log = (tmp_path / "chunks" / f"samp24_{algorithm}.log").read_text()
    assert "28 chunks of 20 m" in log
    # with a buffer short of the windows' reach the chunks' edges go wrong: the buffer is what works
    run(algorithm, SAMPLE, tmp_path / "short", chunk=20.0, chunk_buffer="2", **options)
    whole = np.loadtxt(tmp_path / "whole" / name)
    short = np.loadtxt(tmp_path / "short" / name)
    assert (whole[:, -2] != short[:, -2]).sum() > 10


def test_a_file_smaller_than_one_chunk_and_chunks_without_points(tmp_path):
    rows = np.loadtxt(SAMPLE)
    x0 = rows[:, 0].min()
    gap = rows[(rows[:, 0] < x0 + 30) | (rows[:, 0] > x0 + 75)]  # a 45 m wide gap: chunks with no points
    np.savetxt(tmp_path / "gap.txt", gap, fmt=["%.2f", "%.2f", "%.2f", "%d"])
    for source, chunk in ((SAMPLE, 1000.0), (tmp_path / "gap.txt", 20.0)):
        run("pm", source, tmp_path / "whole", **SMALL["pm"], overwrite=True)
        run("pm", source, tmp_path / "chunks", chunk=chunk, **SMALL["pm"], overwrite=True)
        name = f"{source.stem}_pm.txt"
        assert filecmp.cmp(tmp_path / "whole" / name, tmp_path / "chunks" / name, shallow=False), source
    assert not list(tmp_path.rglob(".aldpat-scratch-*"))  # the chunks' files are gone


@pytest.mark.parametrize("algorithm", sorted(set(FILTERS) - set(SMALL)))
def test_the_other_filters_agree_on_a_real_strip(tmp_path, algorithm):
    run(algorithm, STRIP, tmp_path / "whole")
    run(algorithm, STRIP, tmp_path / "chunks", chunk=120.0, jobs=2)  # the automatic buffer (gapm: 500 m)
    whole = laspy.read(tmp_path / "whole" / f"fsite5_strip_{algorithm}.laz")
    chunks = laspy.read(tmp_path / "chunks" / f"fsite5_strip_{algorithm}.laz")
    for dim in whole.point_format.dimension_names:  # same points, same order, same attributes
        if dim not in ("classification", "mark"):  # the classes and marks are compared below
            np.testing.assert_array_equal(np.asarray(chunks[dim]), np.asarray(whole[dim]), err_msg=dim)
    agree = float((np.asarray(whole.classification) == np.asarray(chunks.classification)).mean())
    # measured on this strip in 100 m chunks: gapm 99.79 %, atin 99.84 %, ipf 99.97 %, poly2 and
    # multipass 99.995 %, the others 100 %; the bound below is the lowest of them, rounded down
    assert agree >= 0.997, agree


def test_point_filters_take_their_own_buffer_with_auto(tmp_path):
    """slope: its search radius and two cells; ipf and poly2: three first windows; atin: the
    manual's Tile Buffer; each with twice the low-outlier test's terrain (20 m at 1 m cells)."""
    buffers = {name: chunk_plan(name, FILTERS[name].params(chunk=100.0)).lattice.buffer
               for name in ("slope", "ipf", "poly2", "atin")}
    assert buffers == {"slope": 50.0, "ipf": 130.0, "poly2": 160.0, "atin": 140.0}
    bare = {name: chunk_plan(name, FILTERS[name].params(low_outliers=None, chunk=100.0)).lattice.buffer
            for name in ("slope", "ipf", "poly2", "atin")}
    assert bare == {"slope": 10.0, "ipf": 90.0, "poly2": 120.0, "atin": 100.0}
    wide = FILTERS["ipf"].params(init_window_length=50.0, cell=2.0, chunk=100.0)
    assert chunk_plan("ipf", wide).lattice.buffer == 150.0 + 40.0
    report = get_task("filter", "slope")([SAMPLE], odir=str(tmp_path), chunk=50.0)
    assert report.exit_code == 0
    assert "with 50 m buffers" in (tmp_path / "samp24_slope.log").read_text()


def test_a_filter_without_reach_or_buffer_asks_for_metres(monkeypatch):
    import dataclasses

    monkeypatch.setitem(FILTERS, "slope", dataclasses.replace(FILTERS["slope"], buffer=None))
    with pytest.raises(UsageError, match="give the buffer in metres"):
        chunk_plan("slope", FILTERS["slope"].params(chunk=100.0))
    assert chunk_plan("slope", FILTERS["slope"].params(chunk=100.0, chunk_buffer="25")).lattice.buffer == 25.0


def test_chunks_are_whole_cells_on_the_files_lattice():
    plan = chunk_plan("gapm", FILTERS["gapm"].params(chunk=100.0, chunk_buffer="10"))
    assert plan.cells == 133 and plan.lattice.size == pytest.approx(99.75)  # 0.75 m cells
    assert plan.buffer_cells == 14 and plan.lattice.buffer == pytest.approx(10.5)


def test_spill_puts_each_point_in_its_chunk_and_in_the_buffers_around_it(tmp_path):
    x = np.array([5.0, 9.5, 10.5, 25.0, 15.0])
    y = np.array([5.0, 5.0, 5.0, 25.0, 9.0])
    table = PointTable({"x": x, "y": y, "z": np.arange(5.0)})
    with spill_chunks([table.take(slice(0, 2)), table.take(slice(2, 5))], ChunkLattice(10.0, 1.0),
                      tmpdir=tmp_path) as spilled:
        assert spilled.points == 5 and spilled.chunks == [(0, 0), (1, 0), (2, 2)]
        assert spilled.read(0, 0)["row"].tolist() == [0, 1, 2]  # 10.5 lies in (0, 0)'s buffer
        assert spilled.read(1, 0)["row"].tolist() == [1, 2, 4]  # 9.5 in (1, 0)'s; 15, 9 its own
        assert spilled.read(1, 1)["row"].tolist() == [4]  # a chunk with buffer points only...
        assert spilled.read(2, 2)["row"].tolist() == [3]
        folder = spilled.folder
    assert not folder.exists()


def test_a_catalog_of_tiles_gives_the_whole_files_classes(tmp_path):
    """Tiles without buffers of their own, taken together: each tile's output holds the whole
    file's classes of its points, which the tiles filtered one by one do not."""
    rows = np.loadtxt(SAMPLE)
    xm, ym = (rows[:, :2].min(axis=0) + rows[:, :2].max(axis=0)) / 2
    tiles = []
    for i, west in enumerate((True, False)):
        for j, south in enumerate((True, False)):
            keep = ((rows[:, 0] < xm) == west) & ((rows[:, 1] < ym) == south)
            tiles.append((tmp_path / f"t{i}{j}.txt", keep))
            np.savetxt(tiles[-1][0], rows[keep], fmt=["%.2f", "%.2f", "%.2f", "%d"])
    run("pm", SAMPLE, tmp_path / "whole", **SMALL["pm"])
    whole = np.loadtxt(tmp_path / "whole" / "samp24_pm.txt")
    report = get_task("filter", "pm")([p for p, _ in tiles], odir=str(tmp_path / "catalog"), result="classified",
                                      marks=True, chunk=20.0, catalog=True, **SMALL["pm"])
    assert report.exit_code == 0 and len(report.results) == 1  # one job for the catalog
    alone = get_task("filter", "pm")([p for p, _ in tiles], odir=str(tmp_path / "alone"), result="classified",
                                     marks=True, **SMALL["pm"])
    assert alone.exit_code == 0
    differ = 0
    for path, keep in tiles:
        got = np.loadtxt(tmp_path / "catalog" / f"{path.stem}_pm.txt")
        np.testing.assert_array_equal(got, whole[keep])
        differ += int((np.loadtxt(tmp_path / "alone" / f"{path.stem}_pm.txt")[:, -2] != whole[keep][:, -2]).sum())
    assert differ > 10  # tiles filtered alone go wrong at their edges


class Recorder:
    """A run's progress as :func:`aldpat.jobs.run.run_task` tells it."""

    def __init__(self):
        self.jobs, self.done, self.planned, self.finished = 0, 0, 0, 0

    def started(self, jobs: int) -> None:
        self.jobs += jobs

    def job_done(self, result) -> None:
        self.done += 1

    def units(self, kind: str, n: int, name: str = "") -> None:
        if kind == "planned":
            self.planned += n
        elif kind == "finished":
            self.finished += n


@pytest.mark.parametrize("jobs", [1, 2])
def test_each_chunk_is_a_unit_of_the_runs_progress(tmp_path, jobs):
    from aldpat.jobs.run import run_task

    progress = Recorder()
    options = {"odir": str(tmp_path), "chunk": 20.0, "jobs": jobs, **SMALL["pm"]}
    report = run_task(get_task("filter", "pm"), [SAMPLE], [("python", options)], progress=progress)
    assert report.exit_code == 0
    assert (progress.jobs, progress.done) == (1, 1)
    assert progress.planned == progress.finished == 28  # "28 chunks of 20 m", as the log says
    # a whole-file run has no units inside its one job
    whole = Recorder()
    run_task(get_task("filter", "pm"), [SAMPLE], [("python", {"odir": str(tmp_path / "whole")})], progress=whole)
    assert (whole.jobs, whole.done, whole.planned) == (1, 1, 0)


def test_the_progress_bar_grows_with_the_units_and_counts_them():
    import io

    from rich.console import Console
    from rich.progress import Progress

    from aldpat.cli.progress import _Bar

    with Progress(console=Console(file=io.StringIO(), force_terminal=True)) as rich_bar:
        task_id = rich_bar.add_task("filter pm", total=None)
        bar = _Bar(rich_bar, task_id, "filter pm")
        bar.started(2)
        bar.units("planned", 5)
        bar.units("finished", 5)
        bar.job_done(None)
        state = rich_bar.tasks[0]
        assert (state.total, state.completed) == (7, 6)


@pytest.mark.parametrize("algorithm", ["etew", "pm", "pm2d", "pmcircle", "slope"])
def test_chunks_have_the_files_grid_edges(tmp_path, algorithm):
    """On the sparse strip (0.16 points/m2: most 1 m cells empty) a chunk's own points often stop
    short of the file's edge, so a grid on them alone would start a cell or two later than the
    file's, and an opening at a grid's edge sees other cells than one inside the grid: chunks get
    the file's cells and edges there, and the classes are the whole file's, byte for byte."""
    run(algorithm, STRIP, tmp_path / "whole")
    run(algorithm, STRIP, tmp_path / "chunks", chunk=100.0, jobs=2)
    name = f"fsite5_strip_{algorithm}.laz"
    whole = laspy.read(tmp_path / "whole" / name)
    chunks = laspy.read(tmp_path / "chunks" / name)
    np.testing.assert_array_equal(np.asarray(chunks.classification), np.asarray(whole.classification))
    np.testing.assert_array_equal(np.asarray(chunks["mark"]), np.asarray(whole["mark"]))


def test_only_a_filter_needing_every_point_says_so():
    """The filter's own hook, not a parameter's name, says a run needs every point at once."""
    from aldpat.filters.streamed import streamable

    auto = FILTERS["gapm"].params(auto=True)
    assert "--auto" in FILTERS["gapm"].needs_every_point(auto)
    assert not streamable("gapm", auto)
    assert all(spec.needs_every_point(spec.params()) is None for spec in FILTERS.values())


def test_ground_filter_takes_every_point_it_is_given():
    """From Python (a notebook), :func:`ground_filter` filters the points it is given at once:
    params needing every point (gapm's ``auto``) are derived from them, as ``aldpat filter gapm
    --auto`` derives them from a file, and ``chunk`` with them is refused in the command's words."""
    from aldpat.errors import ParamError
    from aldpat.filters import ground_filter
    from aldpat.filters.gapm import with_auto

    x, y, z = np.loadtxt(SAMPLE, usecols=(0, 1, 2), unpack=True)
    gapm = FILTERS["gapm"].params
    with pytest.raises(ParamError, match="chunk: a chunk holds only some of the points, and --auto derives"):
        ground_filter(x, y, z, "gapm", gapm(auto=True, chunk=50.0))
    told: list[str] = []
    derived = ground_filter(x, y, z, "gapm", gapm(auto=True), note=told.append).params  # what it ran with
    assert derived == with_auto(gapm(), x, y, z) and derived.window_series != gapm().window_series
    assert len(told) == 1 and told[0].startswith(f"--auto: cell = {derived.cell:g} m, window_series = [1, 2, 4, 8]")
    # chunk alone is how the command splits a file: the points given are filtered together all the same
    plain = FILTERS["pm"].params(chunk=50.0)
    chunked = ground_filter(x, y, z, "pm", plain)
    assert chunked.params is plain  # nothing derived where the filter needs no more than it is given
    assert np.array_equal(chunked.point_marks, ground_filter(x, y, z, "pm").point_marks)


@pytest.mark.parametrize("algorithm, options, message", [
    ("gapm", {"auto": True}, "chunk: a chunk holds only some of the points, and --auto derives"),
    ("pm", {"data_mode": "center"}, "chunk: --data-mode center writes one point per cell"),
    ("slope", {"data_mode": "center"}, "chunk: --data-mode center writes one point per cell"),
    ("pm", {"chunk": 1.0}, r"--chunk 1 m with a \d+ m buffer copies every point into"),
    # a size below a cell is refused at the cell it was rounded to, which the message says it was
    ("gapm", {"chunk": 0.001}, (r"--chunk 0\.75 m with a [\d.]+ m buffer copies every point into [\d,]+ chunks "
                               r"\(at most 100\); .* \(the --chunk 0\.001 m given, rounded to whole cells of 0\.75 m\)")),
])
def test_the_rules_of_chunks_are_checked_with_the_parameters(algorithm, options, message):
    """Refused as the run's parameters are resolved (a worksheet job's number in front), before
    any input is looked at."""
    from aldpat.jobs.resolve import resolve_run

    with pytest.raises(UsageError, match="job 4: " + message):
        resolve_run(get_task("filter", algorithm), [("worksheet", {"chunk": 50.0, **options})], where="job 4: ")
    resolve_run(get_task("filter", algorithm), [("worksheet", {k: v for k, v in options.items() if k != "chunk"})])
