"""aldpat run: validation before anything runs, order, statuses, --only/--set/--dry-run,
--resume, and a log that replays the run."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import textwrap

import pytest

from aldpat.errors import UsageError
from aldpat.worksheet.model import load_worksheet
from aldpat.worksheet.runner import BLOCKED, DONE, FAILED, SKIPPED, run_worksheet

ALDPAT = [sys.executable, "-m", "aldpat"]


@pytest.fixture
def project(tmp_path, samp24):
    (tmp_path / "raw").mkdir()
    shutil.copy(samp24, tmp_path / "raw" / "a.txt")
    shutil.copy(samp24, tmp_path / "raw" / "b.txt")
    return tmp_path


def sheet(folder, body: str, name="job.toml"):
    p = folder / name
    p.write_text(textwrap.dedent(body))
    return p


CONVERT_THEN_INFO = """
    [[job]]
    task = "convert"
    inputs = ["raw/*.txt"]
    odir = "laz"
    out_format = "laz"

    [[job]]
    task = "info"
    inputs = ["laz/*.laz"]
"""


@pytest.mark.parametrize("body, message", [
    ('[[job]]\ntask = "convert"\ninputs = ["raw/a.txt"]\nfeilds = "xyz"\n',
     "job 1: unknown key 'feilds'; did you mean 'fields'?"),
    ('[[job]]\ntask = "convert"\ninputs = ["raw/a.txt"]\njobs = "two"\n', "job 1: jobs: expected a whole number"),
    ('[[job]]\ntask = "convert"\ninputs = ["raw/a.txt"]\njobs = -1\n', "job 1: jobs: -1 is out of range"),
    ('[[job]]\ntask = "convert"\ninputs = ["raw/zzz.txt"]\n', "job 1: inputs: "),
    ('[[job]]\ntask = "convrt"\ninputs = ["raw/a.txt"]\n', "job 1: unknown task 'convrt'; did you mean 'convert'?"),
    # a named input of no point format: refused now, not by the job after a dry run said "Ready"
    ('[[job]]\ntask = "thin"\ninputs = ["raw/a.txt", "job.toml"]\n',
     "job.toml: unknown extension '.toml' (point files are .txt .xyz .csv .pts .las .laz; use --format"),
    (('[[job]]\ntask = "info"\ninputs = ["raw/a.txt"]\n[[job]]\ntask = "evaluate"\ninputs = ["raw/a.txt"]\n'
     'reference = "raw/a.txt"\nmode = "clasified"\n'), "job 2: mode: 'clasified' is not one of"),
    ('[[jobs]]\ntask = "info"\n', "unknown top-level key 'jobs'; did you mean 'job'?"),
    ('[settings]\ndelimeter = "comma"\n[[job]]\ntask = "info"\ninputs = ["raw/a.txt"]\n',
     "settings: unknown key 'delimeter'; did you mean 'delimiter'?"),
    ('[[job]]\ntask = "info"\ninputs = ["raw/a.txt"\n', "TOML syntax error"),
    ("depth = " + "[" * 50_000 + "]" * 50_000 + "\n", "TOML nested too deep to read"),
    # valid TOML of the wrong shape: once Python's own words ("dictionary update sequence ..."),
    # naming neither the worksheet nor the key
    ('settings = "x"\n[[job]]\ntask = "info"\ninputs = ["raw/a.txt"]\n', "job.toml: settings: expected a table"),
    ('[[settings]]\njobs = 1\n[[job]]\ntask = "info"\ninputs = ["raw/a.txt"]\n',
     "settings: expected a table ([settings] and its keys below it), got an array of tables"),
    ('job = ["a", "b"]\n', "job.toml: job 1: expected a [[job]] table of keys, got 'a'"),
    ('job = [1, 2]\n', "job 1: expected a [[job]] table of keys, got 1"),
    ('[[job]]\ntask = 3\ninputs = ["raw/a.txt"]\n', 'job 1: task: expected a task name such as "thin", got 3'),
])
def test_validation_names_job_and_key_before_anything_runs(project, body, message):
    p = sheet(project, body)
    with pytest.raises(UsageError, match=re.escape(message)):
        load_worksheet(p)
    proc = subprocess.run(ALDPAT + ["run", str(p)], check=False, capture_output=True, text=True)
    assert proc.returncode == 2 and message in proc.stderr and "Traceback" not in proc.stderr
    assert not (project / "laz").exists()


def test_jobs_run_in_order_and_later_jobs_read_earlier_outputs(project):
    ws = load_worksheet(sheet(project, CONVERT_THEN_INFO))
    assert ws.jobs[1].depends_on == {1}
    statuses = run_worksheet(ws)
    assert [s.state for s in statuses] == [DONE, DONE]
    assert sorted(p.name for p in (project / "laz").iterdir()) == ["a.laz", "a.log", "b.laz", "b.log"]
    assert [r.records[0]["count"] for r in statuses[1].results] == [7492, 7492]


def test_a_failed_job_blocks_only_the_jobs_that_read_its_outputs(project):
    (project / "raw" / "broken.txt").write_text("1 2 3\n4 5\n")
    body = CONVERT_THEN_INFO + '\n[[job]]\ntask = "info"\ninputs = ["raw/a.txt"]\n'
    body = body.replace('inputs = ["raw/*.txt"]', 'inputs = ["raw/broken.txt"]')
    (project / "other").mkdir()
    shutil.copy(project / "raw" / "a.txt", project / "other" / "c.txt")
    body = body.replace('inputs = ["raw/a.txt"]', 'inputs = ["other/c.txt"]')
    statuses = run_worksheet(load_worksheet(sheet(project, body)))
    assert [s.state for s in statuses] == [FAILED, BLOCKED, DONE]
    assert "broken.txt:2: expected 3 columns, found 2" in statuses[0].message
    assert "failed job 1" in statuses[1].message


def test_only_set_and_dry_run(project):
    p = sheet(project, CONVERT_THEN_INFO)
    ws = load_worksheet(p, overrides=["job.1.out_format=las", "job.2.json=true"])
    assert ws.jobs[0].run.output.values.out_format == "las"
    assert ws.jobs[0].run.output.sources["out_format"] == "worksheet"
    statuses = run_worksheet(ws, only={1})
    assert [s.state for s in statuses] == [DONE, SKIPPED]
    assert (project / "laz" / "a.las").exists()
    proc = subprocess.run(ALDPAT + ["run", str(p), "--dry-run", "--set", "job.1.suffix=_dry"],
                          check=False, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert "[[job]]" in proc.stdout and 'suffix = "_dry"    # worksheet' in proc.stdout
    assert not any("_dry" in x.name for x in (project / "laz").iterdir())
    with pytest.raises(UsageError, match="expected job.N.key=value"):
        load_worksheet(p, overrides=["job1.odir=x"])


@pytest.mark.parametrize("args, message", [
    (["--only", "0"], "--only '0': jobs are numbered from 1"),
    (["--only", "\u00b2"], "expected job numbers such as 2 or 2,3"),  # a digit to str.isdigit, not to int
    (["--set", "job.\u00b2.cell=2"], "expected job.N.key=value"),
    (["--set", "job.0.cell=2"], "--set job.0: the worksheet has 2 jobs"),
    # in the words a task's own -j is refused in (click's three-line usage block before)
    (["-j", "-1"], "aldpat: error: jobs: -1 is out of range (must be >= 0)"),
])
def test_run_options_naming_no_job_or_a_negative_count_are_refused_in_one_line(project, args, message):
    p = sheet(project, CONVERT_THEN_INFO)
    proc = subprocess.run(ALDPAT + ["run", str(p), *args], check=False, capture_output=True, text=True)
    assert proc.returncode == 2 and message in proc.stderr, proc.stderr
    assert len(proc.stderr.splitlines()) == 1 and not (project / "laz").exists()


def test_resume_skips_unchanged_jobs_and_reruns_changed_ones(project):
    p = sheet(project, CONVERT_THEN_INFO)
    run_worksheet(load_worksheet(p))
    mtime = os.stat(project / "laz" / "a.laz").st_mtime_ns
    statuses = run_worksheet(load_worksheet(p), resume=True)
    assert [s.state for s in statuses] == [SKIPPED, SKIPPED]
    assert os.stat(project / "laz" / "a.laz").st_mtime_ns == mtime
    # a changed parameter re-runs the job (its outputs exist: overwrite is needed and given)
    statuses = run_worksheet(load_worksheet(p, overrides=["job.1.overwrite=true", "job.1.fields=xyz"]), resume=True)
    assert statuses[0].state == DONE
    # a changed input re-runs too
    with open(project / "raw" / "b.txt", "a") as fh:
        fh.write("513866.46\t5403124.79\t310.77\t0\n")
    statuses = run_worksheet(load_worksheet(p, overrides=["job.1.overwrite=true", "job.1.fields=xyz"]), resume=True)
    assert statuses[0].state == DONE and statuses[1].state == DONE


def test_resume_after_a_kill_finishes_the_interrupted_job(project):
    p = sheet(project, CONVERT_THEN_INFO)
    ws = load_worksheet(p)
    # what a kill in the middle of job 1 leaves: a state saying Running, one output renamed in
    # place, a stray temporary file
    from aldpat.worksheet.runner import _save_state, fingerprint, state_path

    (project / "laz").mkdir()
    run_worksheet(load_worksheet(sheet(project, CONVERT_THEN_INFO.replace("raw/*.txt", "raw/a.txt"), "tmp.toml")))
    (project / "laz" / "b.aldpat-tmp999.laz").write_bytes(b"half")
    _save_state(ws, {"1": {"status": "Running", "fingerprint": fingerprint(ws.jobs[0])}})
    assert state_path(ws).exists()
    statuses = run_worksheet(load_worksheet(p), resume=True)
    assert [s.state for s in statuses] == [DONE, DONE]
    assert sorted(x.name for x in (project / "laz").iterdir()) == ["a.laz", "a.log", "b.laz", "b.log"]


def test_a_killed_job_edited_before_its_resume_keeps_a_users_file_where_it_now_writes(project):
    """A killed job resumed after the worksheet was edited (another odir) is another job: its
    outputs are not the killed run's, and a file of the user's where it now writes stays."""
    from aldpat.worksheet.runner import _save_state, fingerprint

    p = sheet(project, CONVERT_THEN_INFO)
    _save_state(load_worksheet(p), {"1": {"status": "Running", "fingerprint": fingerprint(load_worksheet(p).jobs[0])}})
    (project / "kept").mkdir()
    (project / "kept" / "a.laz").write_text("the user's own file\n")
    edited = sheet(project, CONVERT_THEN_INFO.replace('odir = "laz"', 'odir = "kept"').replace("laz/*.laz", "kept/*.laz"))
    statuses = run_worksheet(load_worksheet(edited), resume=True)
    assert statuses[0].state == FAILED and "a.laz: output exists" in statuses[0].message
    assert (project / "kept" / "a.laz").read_text() == "the user's own file\n"


def test_log_replays_the_run(project):
    p = sheet(project, CONVERT_THEN_INFO)
    run_worksheet(load_worksheet(p))
    log = (project / "job.log").read_text()
    assert "# job 1: Done" in log and 'out_format = "laz"    # worksheet' in log
    assert 'delimiter = "space"    # default' in log
    replay = project / "replay.toml"
    replay.write_text(log.replace(str(project / "laz"), str(project / "laz2")))
    statuses = run_worksheet(load_worksheet(replay))
    assert [s.state for s in statuses] == [DONE, DONE]
    a = (project / "laz" / "a.laz").read_bytes()
    b = (project / "laz2" / "a.laz").read_bytes()
    assert len(a) == len(b)


def test_run_from_the_command_line_reports_statuses(project):
    p = sheet(project, CONVERT_THEN_INFO)
    proc = subprocess.run(ALDPAT + ["run", str(p)], check=False, capture_output=True, text=True, cwd="/")
    assert proc.returncode == 0, proc.stderr
    assert "job 1 convert: Running" in proc.stderr and "job 1 convert: Done: 2 outputs" in proc.stderr
    assert "job 2 info: Done" in proc.stderr and "7,492" in proc.stdout


def test_resume_after_a_kill_replaces_only_what_the_killed_job_wrote(project):
    """A job recorded as Running (its run was killed) may replace the outputs it finds when resumed,
    as they are its own -- but not when the worksheet was edited meanwhile to point it at someone
    else's files, nor files that were there before the killed run started."""
    from aldpat.worksheet.runner import _save_state, fingerprint

    killed = load_worksheet(sheet(project, CONVERT_THEN_INFO.replace('odir = "laz"', 'odir = "old"')
                                  .replace("laz/*.laz", "old/*.laz")))
    ws_path = sheet(project, CONVERT_THEN_INFO)  # edited after the kill: another odir
    (project / "laz").mkdir()
    (project / "laz" / "a.laz").write_bytes(b"someone else's file")
    _save_state(killed, {"1": {"status": "Running", "fingerprint": fingerprint(killed.jobs[0])}})
    proc = subprocess.run(ALDPAT + ["run", str(ws_path), "--resume"], check=False, capture_output=True, text=True)
    assert proc.returncode == 1 and "Traceback" not in proc.stderr
    assert "a.laz: output exists" in proc.stderr and "--set job.1.overwrite=true" in proc.stderr
    assert (project / "laz" / "a.laz").read_bytes() == b"someone else's file"
    # the same job, killed, but a.laz was there before it started: still not its own
    ws = load_worksheet(ws_path)
    _save_state(ws, {"1": {"status": "Running", "fingerprint": fingerprint(ws.jobs[0]),
                           "existed": [str(project / "laz" / "a.laz")]}})
    proc = subprocess.run(ALDPAT + ["run", str(ws_path), "--resume"], check=False, capture_output=True, text=True)
    assert proc.returncode == 1 and (project / "laz" / "a.laz").read_bytes() == b"someone else's file"
    # what the killed job wrote itself is replaced: the run finishes
    (project / "laz" / "a.laz").unlink()
    run_worksheet(load_worksheet(sheet(project, CONVERT_THEN_INFO.replace("raw/*.txt", "raw/b.txt"), "b.toml")))
    _save_state(ws, {"1": {"status": "Running", "fingerprint": fingerprint(ws.jobs[0]), "existed": []}})
    statuses = run_worksheet(load_worksheet(ws_path), resume=True)
    assert [s.state for s in statuses] == [DONE, DONE]


BOUNDARY_THEN = """
    [settings]
    overwrite = true

    [[job]]
    task = "strip-boundary"
    inputs = ["raw/a.txt"]
    odir = "bounds"

    [[job]]
    task = "{task}"
    inputs = ["{inputs}"]
    {key} = "{value}"

    [[job]]
    task = "merge-boundary"
    inputs = ["bounds/a_Bound.txt"]
    output = "{victim}"
"""


@pytest.mark.parametrize("task, inputs, key, value, victim, message", [
    ("info", "raw/b.txt", "json", "true", "job.toml", "would replace the worksheet itself"),
    ("info", "raw/b.txt", "json", "true", "job.state.json", "would replace the worksheet's run state"),
    ("info", "raw/b.txt", "json", "true", "job.log.2", "would replace a log of the worksheet's earlier runs"),
    ("polygon-extract", "raw/b.txt", "polygon", "poly.txt", "poly.txt", "poly.txt, which job 2 reads"),
    ("thin", "raw/b.txt", "params", "thin.toml", "thin.toml", "thin.toml, which job 2 reads"),
    ("info", "@list.txt", "json", "true", "list.txt", "list.txt, which job 2 reads"),
])
def test_no_job_replaces_the_worksheet_its_files_or_what_a_job_reads(project, task, inputs, key, value, victim,
                                                                     message):
    """The worksheet, the files its run keeps beside it, a job's parameter file and the files its
    path parameters read are read by the run: no job's output replaces them, with or without
    --overwrite (merge-boundary writes any name it is given)."""
    (project / "poly.txt").write_text("513800,5403000\n514000,5403000\n514000,5403200\n")
    (project / "thin.toml").write_text("cell = 5.0\n")
    (project / "list.txt").write_text("raw/a.txt\n")
    body = BOUNDARY_THEN.format(task=task, inputs=inputs, key=key, value=value, victim=victim)
    body = body.replace('json = "true"', "json = true")
    p = sheet(project, body)
    before = {name: (project / name).read_bytes() for name in ("job.toml", "poly.txt", "thin.toml", "list.txt")}
    proc = subprocess.run(ALDPAT + ["run", str(p)], check=False, capture_output=True, text=True)
    assert proc.returncode == 2 and message in proc.stderr and "Traceback" not in proc.stderr, proc.stderr
    assert len(proc.stderr.splitlines()) == 1 and not (project / "bounds").exists()
    assert {name: (project / name).read_bytes() for name in before} == before


def test_a_tilde_is_the_home_folder_in_every_path_of_a_worksheet(project, tmp_path_factory):
    """``odir = "~/out"`` made a folder named ``~`` in the folder the run was started from (the
    inputs' ``~`` was expanded, the other paths' not); it is the home folder now, as a shell makes
    it. ``$HOME`` is not expanded: a worksheet is data, not a shell line."""
    home, elsewhere = tmp_path_factory.mktemp("home"), tmp_path_factory.mktemp("cwd")
    shutil.copy(project / "raw" / "a.txt", home / "a.txt")
    p = sheet(project, """
        [[job]]
        task = "thin"
        inputs = ["~/a.txt"]
        odir = "~/out"
        cell = 5.0
    """)
    env = {**os.environ, "HOME": str(home)}
    proc = subprocess.run(ALDPAT + ["run", str(p)], check=False, capture_output=True, text=True, cwd=elsewhere, env=env)
    assert proc.returncode == 0, proc.stderr
    assert (home / "out" / "a_thin.txt").is_file() and list(elsewhere.iterdir()) == []
    p = sheet(project, '[[job]]\ntask = "thin"\ninputs = ["$HOME/a.txt"]\ncell = 5.0\n')
    proc = subprocess.run(ALDPAT + ["run", str(p)], check=False, capture_output=True, text=True, cwd=elsewhere, env=env)
    assert proc.returncode == 2 and "$HOME/a.txt: no such file" in proc.stderr


def test_a_merge_output_of_no_point_format_is_refused_before_the_first_job(project):
    """``merge -o x.toml`` passed ``--dry-run`` and a worksheet's check, and failed only when it
    came to write ("unknown extension '.toml'"), after the jobs before it had run."""
    proc = subprocess.run(ALDPAT + ["merge", "raw/a.txt", "-o", "x.toml", "--dry-run"], check=False,
                          capture_output=True, text=True, cwd=project)
    assert proc.returncode == 2 and "output x.toml: a merged point file's extension is its format" in proc.stderr
    p = sheet(project, CONVERT_THEN_INFO + '\n[[job]]\ntask = "merge"\ninputs = ["laz/*.laz"]\noutput = "all.toml"\n')
    proc = subprocess.run(ALDPAT + ["run", str(p)], check=False, capture_output=True, text=True)
    assert proc.returncode == 2 and "job 3: output" in proc.stderr and "all.toml: a merged point file's" in proc.stderr
    assert len(proc.stderr.splitlines()) == 1 and not (project / "laz").exists()


def test_a_named_pipe_nothing_writes_to_is_refused_not_waited_for(project):
    """``aldpat run fifo.toml`` (or ``params = "fifo.toml"``, an ``@fifo`` input list) waited for
    ever for a writer; it is refused in one line. A pipe something writes to is read as before."""
    os.mkfifo(project / "fifo.toml")
    proc = subprocess.run(ALDPAT + ["run", str(project / "fifo.toml")], check=False, capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 2 and "fifo.toml: TOML file is a named pipe that nothing writes to" in proc.stderr
    p = sheet(project, '[[job]]\ntask = "thin"\ninputs = ["raw/a.txt"]\nparams = "fifo.toml"\n')
    proc = subprocess.run(ALDPAT + ["run", str(p)], check=False, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and "job 1: params:" in proc.stderr and "named pipe" in proc.stderr
    proc = subprocess.run(ALDPAT + ["thin", "@fifo.toml", "--dry-run"], check=False, capture_output=True, text=True,
                          timeout=60, cwd=project)
    assert proc.returncode == 1 and "input list is a named pipe that nothing writes to" in proc.stderr
    proc = subprocess.run(["bash", "-c", f"{' '.join(ALDPAT)} thin raw/a.txt --params <(echo 'cell = 7.0') --dry-run"],
                          check=False, capture_output=True, text=True, timeout=60, cwd=project)
    assert proc.returncode == 0 and "cell = 7    # params file" in proc.stdout, proc.stderr


def test_resume_after_a_job_is_inserted_or_removed_skips_the_unchanged_jobs(project):
    """The run state knew a job by its number: a job inserted before the others made ``--resume``
    run each of them again, under its new number -- each failed on its own outputs ("output
    exists") and blocked the jobs reading them. A job that finished unchanged is found by what it
    runs now, under any number, and the state keeps it under its new one."""
    p = sheet(project, CONVERT_THEN_INFO)
    assert [s.state for s in run_worksheet(load_worksheet(p))] == [DONE, DONE]
    mtime = os.stat(project / "laz" / "a.laz").st_mtime_ns
    sheet(project, '[[job]]\ntask = "info"\ninputs = ["raw/b.txt"]\n' + textwrap.dedent(CONVERT_THEN_INFO))
    proc = subprocess.run(ALDPAT + ["run", str(p), "--resume"], check=False, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert "job 2 convert: Skipped" in proc.stderr and "job 3 info: Skipped" in proc.stderr
    sheet(project, CONVERT_THEN_INFO)  # and removed again
    assert [s.state for s in run_worksheet(load_worksheet(p), resume=True)] == [SKIPPED, SKIPPED]
    assert os.stat(project / "laz" / "a.laz").st_mtime_ns == mtime


def test_resume_replaces_what_a_changed_job_wrote_itself_and_nothing_else(project):
    """A job run again by --resume because its input changed (or an upstream job made its inputs
    anew) failed on its own outputs of the last run ("output exists") and blocked the jobs
    reading them, unless the worksheet said overwrite: resuming after mending a raw file needed
    --overwrite on every job. It replaces what it wrote itself, unchanged since; a file of
    anyone else's or changed since is refused as ever."""
    p = sheet(project, CONVERT_THEN_INFO.replace('task = "info"\n    inputs = ["laz/*.laz"]',
                                                 'task = "thin"\n    inputs = ["laz/*.laz"]\n    odir = "thin"\n'
                                                 '    cell = 5.0'))
    assert [s.state for s in run_worksheet(load_worksheet(p))] == [DONE, DONE]
    with open(project / "raw" / "a.txt", "a") as fh:
        fh.write("513866.46\t5403124.79\t310.77\t0\n")
    proc = subprocess.run(ALDPAT + ["run", str(p), "--resume"], check=False, capture_output=True, text=True)
    assert proc.returncode == 0 and "job 2 thin: Done" in proc.stderr, proc.stderr
    assert laspy_count(project / "laz" / "a.laz") == 7493
    (project / "thin" / "b_thin.laz").write_bytes(b"edited by hand")
    os.utime(project / "raw" / "b.txt")
    proc = subprocess.run(ALDPAT + ["run", str(p), "--resume"], check=False, capture_output=True, text=True)
    assert proc.returncode == 1 and "b_thin.laz: output exists" in proc.stderr, proc.stderr
    assert (project / "thin" / "b_thin.laz").read_bytes() == b"edited by hand"


def laspy_count(path) -> int:
    import laspy

    return laspy.open(path).header.point_count


def test_resume_after_a_kill_and_an_inserted_job_finishes_the_killed_one(project):
    """The job a kill left Running is found by what it runs when a job inserted before it has
    renumbered it: it finishes, replacing what it had written, instead of failing on it."""
    from aldpat.worksheet.runner import _save_state, fingerprint

    ws = load_worksheet(sheet(project, CONVERT_THEN_INFO))
    run_worksheet(load_worksheet(sheet(project, CONVERT_THEN_INFO.replace("raw/*.txt", "raw/a.txt"), "a.toml")))
    _save_state(ws, {"1": {"status": "Running", "fingerprint": fingerprint(ws.jobs[0]), "existed": []}})
    p = sheet(project, '[[job]]\ntask = "info"\ninputs = ["raw/b.txt"]\n' + textwrap.dedent(CONVERT_THEN_INFO))
    statuses = run_worksheet(load_worksheet(p), resume=True)
    assert [s.state for s in statuses] == [DONE, DONE, DONE], [s.message for s in statuses]
    assert sorted(x.name for x in (project / "laz").iterdir()) == ["a.laz", "a.log", "b.laz", "b.log"]


def test_a_run_again_beside_its_inputs_does_not_take_its_outputs_for_inputs(project):
    """Outputs are written beside their inputs by default, so the folder or pattern of the next
    run holds them: ``convert raw/`` run again took ``a.laz`` for an input whose output ``a.laz``
    (from ``a.txt``) would replace it, and refused the run, ``--overwrite`` or not; a worksheet so
    laid out could not be run again or resumed. Files found in a folder or by a pattern that
    the run writes from its other inputs are left out, in one line; one named on its own is still
    refused."""
    args = ["convert", str(project / "raw"), "--out-format", "text", "--suffix", "_c"]
    assert subprocess.run(ALDPAT + args, check=False, capture_output=True, text=True).returncode == 0
    for again in ([], ["--overwrite"]):
        proc = subprocess.run(ALDPAT + args + again, check=False, capture_output=True, text=True)
        assert "not taken as inputs: a_c.txt, b_c.txt, which this run writes from its other inputs" in proc.stderr
        assert "would replace the input" not in proc.stderr, proc.stderr
        assert proc.returncode == (0 if again else 1), proc.stderr  # without --overwrite: "output exists"
    assert not list((project / "raw").glob("*_c_c.txt"))
    named = [str(project / "raw" / n) for n in ("a.txt", "a_c.txt")]
    proc = subprocess.run(ALDPAT + ["convert", *named, "--out-format", "text", "--suffix", "_c", "--overwrite"],
                          check=False, capture_output=True, text=True)
    assert proc.returncode == 2 and "would replace the input" in proc.stderr, proc.stderr
    # a file of the user's bearing an output's name, no aldpat log saying it wrote it, is an input
    (project / "raw" / "b_c.log").unlink()
    proc = subprocess.run(ALDPAT + args + ["--overwrite"], check=False, capture_output=True, text=True)
    assert proc.returncode == 2 and "output " in proc.stderr and "would replace the input" in proc.stderr
    assert "b_c.txt" in proc.stderr, proc.stderr
    p = sheet(project, '[[job]]\ntask = "convert"\ninputs = ["raw/*.txt"]\nout_format = "text"\nsuffix = "_w"\n')
    assert [s.state for s in run_worksheet(load_worksheet(p))] == [DONE]
    assert [s.state for s in run_worksheet(load_worksheet(p), resume=True)] == [SKIPPED]
    assert [s.state for s in run_worksheet(load_worksheet(p))] == [DONE]  # its own outputs, unchanged: replaced


def test_a_failed_batch_is_resumed_and_a_plain_run_keeps_the_records(project):
    """A job that failed on one bad input recorded nothing of the outputs it did write, so after
    mending the input ``--resume`` failed on them ("output exists") for ever; a plain run deleted
    the run state before its first job, so one that then failed left ``--resume`` nothing to go
    by. A failed job records what it wrote, a plain run replaces the worksheet's own unchanged
    outputs and keeps the records, and a file changed by hand is still never replaced."""
    (project / "raw" / "c.txt").write_text("1 2 3\n4 5 x\n")
    p = sheet(project, CONVERT_THEN_INFO.replace('task = "info"\n    inputs = ["laz/*.laz"]',
                                                 'task = "thin"\n    inputs = ["laz/*.laz"]\n    odir = "thin"\n'
                                                 '    cell = 5.0'))
    assert [s.state for s in run_worksheet(load_worksheet(p))] == [FAILED, BLOCKED]
    assert (project / "laz" / "a.laz").exists() and not (project / "laz" / "c.laz").exists()
    (project / "raw" / "c.txt").write_text("1 2 3\n4 5 6\n7 8 10\n")
    proc = subprocess.run(ALDPAT + ["run", str(p), "--resume"], check=False, capture_output=True, text=True)
    assert proc.returncode == 0 and "job 2 thin: Done" in proc.stderr, proc.stderr
    assert [s.state for s in run_worksheet(load_worksheet(p), resume=True)] == [SKIPPED, SKIPPED]
    assert [s.state for s in run_worksheet(load_worksheet(p))] == [DONE, DONE]  # a plain run again
    assert [s.state for s in run_worksheet(load_worksheet(p), resume=True)] == [SKIPPED, SKIPPED]
    (project / "laz" / "b.laz").write_bytes(b"edited by hand")
    assert [s.state for s in run_worksheet(load_worksheet(p))] == [FAILED, BLOCKED]
    assert (project / "laz" / "b.laz").read_bytes() == b"edited by hand"
    (project / "laz" / "b.laz").unlink()  # the others are still the worksheet's own
    assert [s.state for s in run_worksheet(load_worksheet(p))] == [DONE, DONE]
