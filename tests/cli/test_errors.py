"""The table of bad inputs and the one line each gets: never a traceback.

Runs the installed console script in a subprocess, as a user would.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.io.test_las import make_las

ALDPAT = [sys.executable, "-m", "aldpat"]


def run(*args, cwd=None):
    proc = subprocess.run(ALDPAT + [str(a) for a in args], check=False, capture_output=True, text=True, cwd=cwd)
    assert "Traceback" not in proc.stderr and "Traceback" not in proc.stdout, proc.stderr
    return proc


def _bad_files(tmp: Path) -> dict[str, tuple[Path, str]]:
    """name -> (file, the message the user must see)."""
    cases = {}
    (tmp / "empty.txt").write_text("")
    cases["empty file"] = (tmp / "empty.txt", "empty.txt: file is empty")
    (tmp / "columns.txt").write_text("1 2 3\n4 5 6\n7 8\n")
    cases["wrong number of columns"] = (tmp / "columns.txt", "columns.txt:3: expected 3 columns, found 2")
    (tmp / "token.txt").write_text("1 2 3\n4 5,5 6\n")
    cases["non-numeric token"] = (tmp / "token.txt", "token.txt:2: not a number: '5,5'")
    (tmp / "nan.txt").write_text("1 2 3\nnan 5 6\n")
    cases["NaN coordinate"] = (tmp / "nan.txt", "nan.txt:2: non-finite value 'nan'")
    (tmp / "inf.csv").write_text("1,2,3\n4,5,-inf\n")
    cases["inf coordinate"] = (tmp / "inf.csv", "inf.csv:2: non-finite value '-inf'")
    make_las(tmp / "whole.laz", n=3000)
    data = (tmp / "whole.laz").read_bytes()
    (tmp / "cut.laz").write_bytes(data[: len(data) // 2])
    cases["truncated LAZ"] = (tmp / "cut.laz", "cut.laz: truncated")
    make_las(tmp / "whole.las", n=3000)
    data = (tmp / "whole.las").read_bytes()
    (tmp / "cut.las").write_bytes(data[: len(data) // 2])
    cases["truncated LAS"] = (tmp / "cut.las", "cut.las: truncated")
    (tmp / "points.foo").write_text("1 2 3\n")
    cases["unknown extension"] = (tmp / "points.foo", "unknown extension '.foo'")
    cases["missing file"] = (tmp / "nowhere.txt", "nowhere.txt: no such file")
    return cases


CASES = ["empty file", "wrong number of columns", "non-numeric token", "NaN coordinate", "inf coordinate",
         "truncated LAZ", "truncated LAS", "unknown extension", "missing file"]


@pytest.mark.parametrize("case", CASES)
def test_bad_input_gives_one_line_and_the_others_are_processed(tmp_path, samp24, case):
    bad, message = _bad_files(tmp_path)[case]
    good = tmp_path / "good.txt"
    shutil.copy(samp24, good)
    proc = run("convert", bad, good, "--out-format", "laz", "--odir", tmp_path / "out")
    assert proc.returncode == 1
    lines = [ln for ln in proc.stderr.splitlines() if message in ln]
    assert len(lines) == 1, proc.stderr
    assert (tmp_path / "out" / "good.laz").exists()  # the good input was still converted
    leftovers = [p.name for p in (tmp_path / "out").iterdir()]
    assert sorted(leftovers) == ["good.laz", "good.log"]  # nothing half-written


def test_existing_output_without_overwrite(tmp_path, samp24):
    first = run("convert", samp24, "--out-format", "laz", "--odir", tmp_path)
    assert first.returncode == 0, first.stderr
    before = (tmp_path / "samp24.laz").read_bytes()
    again = run("convert", samp24, "--out-format", "laz", "--odir", tmp_path)
    assert again.returncode == 1
    assert "samp24.laz: output exists (use --overwrite to replace it, or --suffix to name a second one apart)" \
        in again.stderr
    assert (tmp_path / "samp24.laz").read_bytes() == before
    assert run("convert", samp24, "--out-format", "laz", "--odir", tmp_path, "--overwrite").returncode == 0


@pytest.mark.parametrize("command, made", [
    (["dtm", "{samp24}", "--cell", "2"], "samp24_dtm.tif"),
    (["shapefile", "{bounds}", "-o", "{out}/b.shp"], "b.shp"),
    (["separate-returns", "{tape}"], "tape_2.txt"),
])
def test_an_existing_output_is_refused_before_the_work_and_its_warnings(tmp_path, samp24, command, made):
    """Without --overwrite a job whose output exists is refused before it reads its input: no
    minutes of filtering to end in the refusal, no warning about the CRS of a file it will not
    write, and the other outputs of the input are not made either."""
    out = tmp_path / "out"
    out.mkdir()
    bounds = tmp_path / "bounds.txt"
    bounds.write_text("0 0 1 1 a.txt\n10 0 1 1 a.txt\n10 10 1 1 a.txt\n-1111 -1111 -1111 -1111 -1111\n")
    tape = tmp_path / "tape.txt"
    tape.write_text("".join(f"{t} {x} 0 1 {x} 0 1 5 5\n" for t, x in enumerate(range(100, 110))))
    (out / made).write_text("the user's\n")
    args = [a.format(samp24=samp24, bounds=bounds, tape=tape, out=out) for a in command]
    proc = run(*args, "--odir", out) if "-o" not in args else run(*args)
    assert proc.returncode == 1, proc.stderr
    assert f"{made}: output exists (use --overwrite to replace it" in proc.stderr
    assert "CRS" not in proc.stderr, proc.stderr
    assert (out / made).read_text() == "the user's\n"
    assert sorted(p.name for p in out.iterdir()) == [made]


def test_a_second_choice_of_method_is_refused_with_the_way_to_keep_both(tmp_path, samp24):
    """thin's (and dtm's, preview's) outputs are named by the task, not the method: a second
    method is refused, and the refusal says how to write it beside the first."""
    assert run("thin", samp24, "--cell", "5", "--method", "lowest", "--odir", tmp_path).returncode == 0
    lowest = (tmp_path / "samp24_thin.txt").read_bytes()
    again = run("thin", samp24, "--cell", "5", "--method", "median", "--odir", tmp_path)
    assert again.returncode == 1
    assert "samp24_thin.txt: output exists (use --overwrite to replace it, or --suffix to name a second one " \
        "apart)" in again.stderr
    assert (tmp_path / "samp24_thin.txt").read_bytes() == lowest
    assert run("thin", samp24, "--cell", "5", "--method", "median", "--odir", tmp_path,
               "--suffix", "_thin_median").returncode == 0
    assert (tmp_path / "samp24_thin_median.txt").read_bytes() != lowest
    # a name given whole is not made from the input's: there --suffix would change nothing
    merged = run("merge", samp24, "-o", tmp_path / "samp24_thin.txt")
    assert merged.returncode == 1
    assert "samp24_thin.txt: output exists (use --overwrite to replace it)" in merged.stderr


def test_output_folder_not_writable(tmp_path, samp24):
    (tmp_path / "file").write_text("")
    proc = run("convert", samp24, "--out-format", "laz", "--odir", tmp_path / "file" / "out")
    assert proc.returncode == 1
    assert "cannot create output folder" in proc.stderr


def test_a_run_that_writes_nothing_leaves_no_new_output_folder(tmp_path, samp24):
    """A refused ``thin`` left the empty ``--odir`` (and its new parents) it had made; a folder
    that existed stays, and a run that writes keeps the folder it made."""
    proc = run("thin", samp24, "--cell", "1e-15", "--odir", tmp_path / "new" / "a" / "b")
    assert proc.returncode == 1 and "use a larger cell" in proc.stderr, proc.stderr
    assert not (tmp_path / "new").exists()
    (tmp_path / "kept").mkdir()
    assert run("thin", samp24, "--cell", "1e-15", "--odir", tmp_path / "kept").returncode == 1
    assert (tmp_path / "kept").is_dir()
    assert run("thin", samp24, "--cell", "1", "--odir", tmp_path / "new" / "a").returncode == 0
    assert [p.suffix for p in sorted((tmp_path / "new" / "a").iterdir())] == [".log", ".txt"]


@pytest.mark.parametrize("content, line", [("cell = \n", 1), ("a = 1\nb = [1, 2\n", 2)])
def test_toml_syntax_error_in_a_params_file(tmp_path, samp24, content, line):
    p = tmp_path / "p.toml"
    p.write_text(content)
    proc = run("convert", samp24, "--params", p)
    assert proc.returncode == 2
    assert f"p.toml:{line}: TOML syntax error" in proc.stderr


def test_a_params_file_nested_too_deep_is_one_message(tmp_path, samp24):
    p = tmp_path / "p.toml"
    p.write_text("cell = " + "[" * 50_000 + "]" * 50_000 + "\n")
    proc = run("convert", samp24, "--params", p)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "p.toml: TOML nested too deep to read" in proc.stderr


@pytest.mark.parametrize("content, message", [
    ("cel = 2\n", "p.toml: unknown key 'cel'; did you mean 'cell'?"),
    ("cell = -1\n", "p.toml: cell: -1 is out of range (must be > 0)"),
    ("window_series = [1, 'a']\n", "p.toml: window_series: expected a whole number, got 'a'"),
])
def test_a_bad_key_of_a_params_file_names_the_file(tmp_path, samp24, content, message):
    """Merged with the command line, the file's bad key was said as if typed ("unknown key
    'feilds'"): the file is named, on the command line and in a worksheet."""
    p = tmp_path / "p.toml"
    p.write_text(content)
    proc = run("filter", "pm", samp24, "--params", p, "--odir", tmp_path / "out")
    assert proc.returncode == 2 and f"aldpat: error: {p}: {message.split(': ', 1)[1]}" in proc.stderr, proc.stderr
    (tmp_path / "w.toml").write_text(f'[[job]]\ntask = "filter"\nalgorithm = "pm"\ninputs = ["{samp24}"]\n'
                                     'params = "p.toml"\nodir = "out"\n')
    proc = run("run", tmp_path / "w.toml")
    assert proc.returncode == 2 and f"w.toml: job 1: params: {p}: {message.split(': ', 1)[1]}" in proc.stderr
    assert not (tmp_path / "out").exists()


def test_a_missing_params_file_is_a_usage_error(tmp_path, samp24):
    proc = run("convert", samp24, "--params", tmp_path / "nowhere.toml")
    assert proc.returncode == 2 and "nowhere.toml: no such file" in proc.stderr


def test_usage_errors_exit_2(tmp_path, samp24):
    proc = run("convert", samp24, "--delimiter", "semicolon")
    assert proc.returncode == 2 and "delimiter: 'semicolon' is not one of space, comma" in proc.stderr
    p = tmp_path / "p.toml"
    p.write_text("feilds = 'xyz'\n")
    proc = run("convert", samp24, "--params", p)
    assert proc.returncode == 2 and "unknown key 'feilds'; did you mean 'fields'?" in proc.stderr
    assert run("nosuchcommand").returncode == 2
    assert run("info").returncode == 2  # no inputs: usage help, status 2


@pytest.mark.parametrize("args, name", [
    (["thin", "{samp24}", "--odir", "-q"], "odir: '-q'"),
    (["evaluate", "{samp24}", "--reference", "{samp24}", "--map", "--overwrite"], "map: '--overwrite'"),
    (["merge", "{samp24}", "-o", "--overwrite"], "output: '--overwrite'"),
])
def test_a_path_option_whose_value_was_left_out_takes_no_option_for_a_file(tmp_path, samp24, args, name):
    """click takes the next word for a value left out: ``--odir -q`` made a folder "-q", and
    ``--map --overwrite`` wrote the picture to a file named "--overwrite"."""
    proc = run(*[a.format(samp24=samp24) for a in args], cwd=tmp_path)
    assert proc.returncode == 2 and f"{name} looks like an option, not a file name" in proc.stderr, proc.stderr
    assert list(tmp_path.iterdir()) == []


def test_a_mosaic_is_not_counted_as_an_input(tmp_path, samp24):
    """``grid a.txt bad.txt --mosaic m.vrt`` said "2 of 3 inputs failed": the mosaic counted as a
    third input."""
    bad = tmp_path / "bad.txt"
    bad.write_text("1 2\n")
    proc = run("grid", samp24, bad, "--cell", "5", "--odir", tmp_path / "out", "--mosaic", tmp_path / "out" / "m.vrt")
    assert proc.returncode == 1 and "m.vrt: mosaic not written: 1 of 2 grids failed" in proc.stderr
    assert "aldpat: 1 of 2 inputs failed" in proc.stderr.splitlines(), proc.stderr


@pytest.mark.parametrize("record_id, data, name", [
    (2112, b"NONSENSE WKT\0", "OGC coordinate system WKT"),
    (34735, b"\xff" * 37, "GeoKeyDirectory"),
])
def test_a_crs_record_that_is_no_crs_is_said(tmp_path, record_id, data, name):
    """A CRS record of nonsense was passed over: ``info`` said "crs unknown" and the outputs were
    written without a CRS, the user not told the input had a record at all."""
    import laspy
    import numpy as np

    header = laspy.LasHeader(point_format=6 if record_id == 2112 else 3, version="1.4" if record_id == 2112 else "1.2")
    header.scales, header.offsets = np.array([0.01] * 3), np.array([500000.0, 4000000.0, 0.0])
    header.vlrs.append(laspy.VLR(user_id="LASF_Projection", record_id=record_id, record_data=data))
    las = laspy.LasData(header)
    las.x, las.y, las.z = 500000 + np.arange(20.0), 4000000 + np.arange(20.0), np.arange(20.0)
    las.write(tmp_path / "odd.las")
    proc = run("info", tmp_path / "odd.las")
    assert proc.returncode == 0
    assert f"odd.las: its CRS record ({name}) is no CRS PROJ can read: taken as none" in proc.stderr, proc.stderr
    assert "crs      unknown" in proc.stdout


def test_unknown_command_suggests(tmp_path):
    proc = run("inof")
    assert proc.returncode == 2 and "did you mean 'info'?" in proc.stderr


@pytest.mark.parametrize("args, message", [
    (["evaluate", "{samp24}"], "reference: required (--reference on the command line)"),
    (["merge-boundary", "{samp24}"], "output: required (--output on the command line)"),
    (["polygon-extract", "{samp24}"], "polygon: required (--polygon on the command line)"),
])
def test_a_missing_required_option_is_a_usage_error(samp24, args, message):
    proc = run(*[a.format(samp24=samp24) for a in args])
    assert proc.returncode == 2 and message in proc.stderr


def test_outputs_apart_in_case_only_are_one_file_where_the_folder_folds_case(tmp_path, samp24, monkeypatch):
    """``filter pm d1/A.txt d2/a.txt --odir o`` writes A_pm.txt and a_pm.txt: two files here, one
    on macOS's or Windows' file systems, where the second replaced the first without a word. A run
    and a worksheet are refused where the output folder folds case (found by looking a name up
    with its case swapped: nothing is written to find out), and run as before where it does not."""
    from aldpat.core import paths
    from aldpat.errors import UsageError
    from aldpat.jobs import outputs
    from aldpat.tasks import get_task
    from aldpat.worksheet.model import load_worksheet
    from tests.cli.fresh import aldpat

    for folder, name in (("d1", "A.txt"), ("d2", "a.txt")):
        (tmp_path / folder).mkdir()
        shutil.copy(samp24, tmp_path / folder / name)
    assert not paths.folds_case(str(tmp_path))  # this machine's file system keeps case apart
    aldpat("filter", "pm", "d1/A.txt", "d2/a.txt", "--odir", "o", cwd=tmp_path).ok()
    assert sorted(p.name for p in (tmp_path / "o").glob("*_pm.txt")) == ["A_pm.txt", "a_pm.txt"]

    monkeypatch.setattr(outputs, "folds_case", lambda folder: True)  # as on macOS or Windows
    with pytest.raises(UsageError, match=r"A\.txt and .*a\.txt would both write .*a_pm\.txt \(and .*A_pm\.txt: "
                                         r"names apart in case only are one file there\)"):
        get_task("filter pm")([tmp_path / "d1" / "A.txt", tmp_path / "d2" / "a.txt"], odir=str(tmp_path / "folded"))
    assert not (tmp_path / "folded").exists()
    sheet = tmp_path / "jobs.toml"
    sheet.write_text('[[job]]\ntask = "filter pm"\ninputs = ["d1/A.txt"]\nodir = "w"\n\n'
                     '[[job]]\ntask = "filter pm"\ninputs = ["d2/a.txt"]\nodir = "w"\n')
    with pytest.raises(UsageError, match=r"job 2: output .*a_pm\.txt is also written by job 1 \(as A_pm\.txt\)"):
        load_worksheet(sheet)
