"""The conventions shared by every command: inputs, output place and name, -j, logs."""

from __future__ import annotations

import shutil
from pathlib import Path

import laspy
import numpy as np

from aldpat.jobs.inputs import expand_inputs
from aldpat.tasks import get_task


def _tiles(tmp_path, samp24, n=4):
    folder = tmp_path / "tiles"
    folder.mkdir()
    data = np.loadtxt(samp24)
    for k in range(n):
        np.savetxt(folder / f"tile_{k}.txt", data[k::n], fmt="%.2f %.2f %.2f %d")
    return folder


def test_inputs_as_files_globs_folders_and_lists(tmp_path, samp24):
    folder = _tiles(tmp_path, samp24)
    (folder / "notes.md").write_text("not points")
    listing = tmp_path / "list.txt"
    listing.write_text("# my tiles\ntiles/tile_0.txt\n\ntiles/tile_3.txt\n")
    got, errors = expand_inputs([str(folder / "tile_1.txt"), str(folder / "tile_[12].txt"), str(folder),
                                 "@" + str(listing)])
    assert [p.name for p in got] == ["tile_1.txt", "tile_2.txt", "tile_0.txt", "tile_3.txt"]
    assert errors == []
    _, errors = expand_inputs([str(tmp_path / "nothing_*.txt")])
    assert "no file matches this pattern" in str(errors[0])


def test_a_pattern_walks_folders_once_and_not_through_links(tmp_path, samp24):
    """``**`` as the shell's globstar: every folder below, but a linked folder is not entered, so a
    link back to a parent (common in project trees) cannot make the walk endless."""
    folder = _tiles(tmp_path, samp24, n=2)
    deep = folder / "a" / "b"
    deep.mkdir(parents=True)
    shutil.copy(folder / "tile_0.txt", deep / "tile_9.txt")
    (deep / "up").symlink_to(tmp_path)
    (deep / "up2").symlink_to(folder)
    (folder / ".hidden").mkdir()
    shutil.copy(folder / "tile_0.txt", folder / ".hidden" / "tile_8.txt")
    got, errors = expand_inputs([str(tmp_path / "**" / "tile_*.txt")])
    assert sorted(p.name for p in got) == ["tile_0.txt", "tile_1.txt", "tile_9.txt"] and errors == []
    got, _ = expand_inputs([str(folder / "**")])  # "**" last: every file below, as glob's
    assert sorted(p.name for p in got) == ["tile_0.txt", "tile_1.txt", "tile_9.txt"]
    got, _ = expand_inputs(["tiles/*.txt"], base=tmp_path)
    assert [p.name for p in got] == ["tile_0.txt", "tile_1.txt"]


def test_a_pipe_or_a_device_is_refused_not_waited_on(tmp_path, samp24):
    import os

    pipe = tmp_path / "strip.las"
    os.mkfifo(pipe)
    got, errors = expand_inputs([str(pipe), "/dev/zero", str(samp24)])
    assert [p.name for p in got] == ["samp24.txt"]
    assert [str(e) for e in errors] == [f"{pipe}: is not a regular file (a pipe, a device or a socket)",
                                        "/dev/zero: is not a regular file (a pipe, a device or a socket)"]


def test_a_pattern_matching_too_many_files_is_refused(tmp_path, samp24, monkeypatch):
    from aldpat.jobs import inputs

    folder = _tiles(tmp_path, samp24, n=4)
    monkeypatch.setattr(inputs, "MAX_PATTERN_MATCHES", 3)
    got, errors = expand_inputs([str(folder / "*.txt"), str(folder / "tile_0.txt")])
    assert [p.name for p in got] == ["tile_0.txt"]
    assert len(errors) == 1 and "matches more than 3 files" in str(errors[0])


def test_a_folder_removed_during_a_patterns_walk_does_not_fail_the_pattern(tmp_path, samp24, monkeypatch):
    """pathlib's walk stops at a folder removed under it (another run's scratch folder among the
    tiles): the pattern is walked again, and given up on in one line only if that keeps happening."""
    from aldpat.jobs import inputs

    folder = _tiles(tmp_path, samp24, n=3)
    walk = Path.glob
    vanishing = {"left": 1}

    def glob(self, pattern):
        for k, match in enumerate(walk(self, pattern)):
            if k == 1 and vanishing["left"]:
                vanishing["left"] -= 1
                raise FileNotFoundError(2, "No such file or directory", str(folder / ".aldpat-scratch-1"))
            yield match

    monkeypatch.setattr(Path, "glob", glob)
    got, errors = expand_inputs([str(tmp_path / "**" / "*.txt")])
    assert errors == [] and sorted(p.name for p in got) == ["tile_0.txt", "tile_1.txt", "tile_2.txt"]
    vanishing["left"] = inputs.PATTERN_ATTEMPTS
    got, errors = expand_inputs([str(tmp_path / "**" / "*.txt")])
    expected = (f"{tmp_path / '**' / '*.txt'}: cannot search for this pattern: its folders kept changing while "
                "searched (3 tries)")
    assert got == [] and [str(e) for e in errors] == [expected]


def test_a_folder_gives_its_point_files_and_skips_the_rest(tmp_path, samp24):
    """A project folder as aldpat leaves it: its own side files are skipped without a word, a
    file that is not points is named in one line, and neither fails the run."""
    from tests.cli.fresh import aldpat

    folder = _tiles(tmp_path, samp24, n=2)
    (folder / "with_header.txt").write_text("x y z\n1.5 2.5 3.5\n2 3 4\n4 4 4\n")
    (folder / "tile_parameter.txt").write_text(f"{folder / 'tile_0.txt'} 0 1 0 1 1 1 0\n")
    for side in ("tile_0.log", "dtm.vrt", "tile_0.grd", "run.state.json", "tile_9.aldpat-tmp-1-1.txt",
                 ".hidden.txt"):
        (folder / side).write_text("1 2 3\n")
    (folder / "readme.txt").write_text("Tiles of sample 24, cut for the demo.\nAsk before deleting.\n")
    (folder / "polygon.txt").write_text("513800,5403150\n513850,5403150\n513850,5403190\n")
    (folder / "notes.docx").write_bytes(b"PK\x03\x04")
    skipped: list[str] = []
    got, errors = expand_inputs([str(folder)], skipped=skipped)
    assert [p.name for p in got] == ["tile_0.txt", "tile_1.txt", "with_header.txt"] and errors == []
    assert skipped == [f"{folder}: skipped 3 files that are not point data: notes.docx, polygon.txt, readme.txt"]
    # the pattern of the README's examples matches tile_parameter.txt: skipped too
    got, _ = expand_inputs([str(folder / "tile_*.txt")])
    assert [p.name for p in got] == ["tile_0.txt", "tile_1.txt"]
    done = aldpat("info", folder, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stderr.count("\n") == 1 and "not point data: notes.docx" in done.stderr
    assert "tile_parameter" not in done.stderr and "tile_0.log" not in done.stderr


def test_output_beside_input_by_default_and_suffix_option(tmp_path, samp24):
    src = tmp_path / "a.txt"
    shutil.copy(samp24, src)
    get_task("convert")([src], out_format="laz")
    assert (tmp_path / "a.laz").exists() and (tmp_path / "a.log").exists()
    get_task("convert")([src], out_format="laz", suffix="_copy", odir=str(tmp_path / "new" / "deep"))
    assert (tmp_path / "new" / "deep" / "a_copy.laz").exists()


def test_comma_delimiter_and_fields(tmp_path, samp24):
    get_task("convert")([samp24], out_format="laz", odir=str(tmp_path))
    get_task("convert")([tmp_path / "samp24.laz"], out_format="text", delimiter="comma", fields="xyz",
                        odir=str(tmp_path / "t"))
    first = (tmp_path / "t" / "samp24.txt").read_text().splitlines()[0]
    assert first == "513866.46,5403124.79,310.77"


def test_parallel_results_identical_to_serial(tmp_path, samp24):
    folder = _tiles(tmp_path, samp24, n=6)
    serial = get_task("convert")([folder], out_format="laz", odir=str(tmp_path / "j1"))
    parallel = get_task("convert")([folder], out_format="laz", odir=str(tmp_path / "j2"), jobs=2)
    assert serial.exit_code == parallel.exit_code == 0
    for k in range(6):
        a = laspy.read(tmp_path / "j1" / f"tile_{k}.laz")
        b = laspy.read(tmp_path / "j2" / f"tile_{k}.laz")
        np.testing.assert_array_equal(a.points.array, b.points.array)
    assert [w.path.replace("j2", "j1") for w in parallel.outputs] == [w.path for w in serial.outputs]


def test_job_log_records_parameters_sources_inputs_outputs(tmp_path, samp24):
    p = tmp_path / "p.toml"
    p.write_text('fields = "xyz"\ndelimiter = "comma"\n')
    from click.testing import CliRunner

    from aldpat.cli.main import cli

    out = CliRunner().invoke(cli, ["convert", str(samp24), "--params", str(p), "--delimiter", "space",
                                   "--odir", str(tmp_path), "--out-format", "csv"])
    assert out.exit_code == 0, out.output
    log = (tmp_path / "samp24.log").read_text()
    assert "aldpat 0.1.0" in log and "command: aldpat convert" in log
    assert "fields     = xyz    (params file)" in log
    assert "delimiter  = space    (cli)" in log
    assert "suffix     = none    (default)" in log
    assert f"{samp24}  ({samp24.stat().st_size} bytes)" in log
    assert "samp24.csv  (7492 points)" in log and "wall time:" in log


def test_logs_of_jobs_sharing_an_output_stem_accumulate(tmp_path, samp24):
    get_task("convert")([samp24], out_format="laz", odir=str(tmp_path))
    get_task("convert")([samp24], out_format="csv", odir=str(tmp_path))
    log = (tmp_path / "samp24.log").read_text()
    assert log.count("task: convert") == 2
    assert "samp24.laz  (7492 points)" in log and "samp24.csv  (7492 points)" in log


def test_a_tilde_of_a_user_this_machine_does_not_know_is_a_missing_file(tmp_path):
    """``aldpat info '~nosuchuser/a.txt'`` ended in a traceback ("Could not determine home
    directory", pathlib's RuntimeError); as a shell leaves such a ``~`` as written, it is an input
    that matches nothing, in one line, and the other inputs run."""
    from tests.cli.fresh import DATA, aldpat

    done = aldpat("info", "~nosuchuser/a.txt", "~nosuchuser/*.txt", DATA / "samp24.txt", cwd=tmp_path)
    assert done.returncode == 1 and "7,492" in done.stdout
    assert "~nosuchuser/a.txt: no such file" in done.stderr
    assert "~nosuchuser/*.txt: no file matches this pattern" in done.stderr
