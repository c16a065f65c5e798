"""``--dry-run`` refuses what the run refuses, with the same one-line message, before a point is read.

Every rule that can refuse a combination of options runs when the parameters are resolved (the
params class's own check, a task's ``check``) or where the task plans its outputs (a format an
output cannot have): so ``aldpat COMMAND ... --dry-run`` and ``aldpat run
--dry-run`` on a worksheet holding the same job see it, and the run refuses it the same way
before reading anything. Each case runs three ways in a fresh process: the command, the command
with ``--dry-run``, and a worksheet job with ``aldpat run --dry-run``.
"""

from __future__ import annotations

import re

import pytest

from tests.cli.fresh import DATA, aldpat, aldpat_batch

SAMPLE = DATA / "samp24.txt"

#: (command line after ``aldpat``, the refusal): each a combination of options the run refuses
REFUSED = [
    (["filter", "gapm", "--auto", "--chunk", "50"],
     r"chunk: a chunk holds only some of the points, and --auto derives the cell and windows from all the points"),
    (["filter", "pm", "--data-mode", "center", "--chunk", "50"],
     r"chunk: --data-mode center writes one point per cell of the whole file; run it whole"),
    (["filter", "atin", "--data-mode", "center", "--chunk", "50"],
     r"chunk: --data-mode center writes one point per cell of the whole file; run it whole"),
    (["filter", "pm", "--chunk", "1"], r"--chunk 1 m with a \d+ m buffer copies every point into [\d,]+ chunks"),
    (["filter", "slope", "--chunk", "10", "--chunk-buffer", "500"],
     r"--chunk 10 m with a 500 m buffer copies every point into 10,201 chunks"),
    (["filter", "etew", "--chunk", "50", "--chunk-buffer", "inf"], r"chunk_buffer: must be at least 0, got inf"),
    (["filter", "pm", "--chunk", "50", "--chunk-buffer", "ten"], r"chunk_buffer: expected metres or auto, got 'ten'"),
    (["filter", "pm", "--catalog"], r"catalog: takes the inputs together in chunks; give --chunk SIZE too"),
    (["grid", "--chunk", "1", "--chunk-buffer", "40"], r"--chunk 1 m with a 40 m buffer copies every point into 6,561"),
    (["dtm", "--auto", "--algorithm", "pm"], r"auto: derives gapm's parameters; --algorithm is pm"),
    (["tile", "--width", "10", "--buffer", "5000"], r"buffer: a buffer of 5000 reaches more than 4.5 tiles of 10 "),
    # rules on what an output can be, checked where each task plans its outputs
    (["split-tape", "--out-format", "las"],
     r"strips keep the tape's 9-column text layout; --out-format las/laz does not apply"),
    (["convert", "--tape"], r"--tape writes LAS/LAZ \(--out-format las or laz\); separate-returns makes text files"),
    (["tile", "--append", "--out-format", "laz"],
     r"--append works on text tiles only \(LAS/LAZ files cannot be appended to\)"),
]


def _job(words: list[str]) -> str:
    """The worksheet job of a command line: ``--key value`` as ``key = "value"``, a flag as true."""
    task, rest = words[0], words[1:]
    lines = ["[[job]]", f'task = "{task}"']
    if task == "filter":
        lines.append(f'algorithm = "{rest.pop(0)}"')
    lines += ['inputs = ["samp24.txt"]', 'odir = "out"']
    while rest:
        key = rest.pop(0)[2:].replace("-", "_")
        value = "true" if not rest or rest[0].startswith("--") else f'"{rest.pop(0)}"'
        lines.append(f"{key} = {value}")
    return "\n".join(lines) + "\n"


def test_dry_run_refuses_what_the_run_refuses(tmp_path):
    (tmp_path / "samp24.txt").write_bytes(SAMPLE.read_bytes())
    cases = []
    for i, (words, _) in enumerate(REFUSED):
        (tmp_path / f"job{i}.toml").write_text(_job(words), encoding="utf-8")
        command = [*words[:2 if words[0] == "filter" else 1], "samp24.txt", *words[2 if words[0] == "filter" else 1:],
                   "--odir", "out"]
        cases += [{"args": command, "cwd": tmp_path}, {"args": [*command, "--dry-run"], "cwd": tmp_path},
                  {"args": ["run", f"job{i}.toml", "--dry-run"], "cwd": tmp_path}]
    done = aldpat_batch(cases)
    for i, (_, message) in enumerate(REFUSED):
        run, dry, sheet = done[3 * i:3 * i + 3]
        for case in (run, dry, sheet):
            assert case["status"] == 2, (case["args"], case["status"], case["stderr"])
            assert case["stderr"].count("\n") == 1, case["stderr"]  # one line
            assert case["stdout"] == "", case["stdout"]
        assert re.fullmatch(rf"aldpat: error: {message}.*\n", run["stderr"]), run["stderr"]
        assert dry["stderr"] == run["stderr"]  # the same message
        assert sheet["stderr"] == run["stderr"].replace("aldpat: error: ", f"aldpat: error: {tmp_path / f'job{i}.toml'}: "
                                                         "job 1: ")
    # nothing written: no output, no log, no scratch folder
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["samp24.txt", *(f"job{i}.toml" for i in
                                                                                 range(len(REFUSED)))])


@pytest.mark.parametrize("words", [["filter", "gapm", "--auto"], ["filter", "pm", "--chunk", "100"]])
def test_dry_run_shows_the_jobs_and_writes_nothing(tmp_path, words):
    (tmp_path / "samp24.txt").write_bytes(SAMPLE.read_bytes())
    done = aldpat(*words[:2], "samp24.txt", *words[2:], "--odir", "out", "--dry-run", cwd=tmp_path).ok()
    lines = done.stdout.splitlines()
    assert lines[:3] == [f"# aldpat {' '.join(words[:2])}: 1 job(s) as they would run; nothing read or written",
                         "# job 1: samp24.txt", f"#   writes out/samp24_{words[1]}.txt"]
    assert "odir = out    # cli" in lines and f"{words[2][2:]} = {'true' if len(words) == 3 else '100'}    # cli" in lines
    assert sorted(p.name for p in tmp_path.iterdir()) == ["samp24.txt"]


def test_a_worksheet_gives_dtm_its_algorithm(tmp_path):
    """``algorithm`` names a filter task's filter; of ``dtm`` it is a parameter like any other, so
    the job table a worksheet log replays (which spells it out) loads again."""
    (tmp_path / "samp24.txt").write_bytes(SAMPLE.read_bytes())
    (tmp_path / "w.toml").write_text('[[job]]\ntask = "dtm"\nalgorithm = "pm"\ninputs = ["samp24.txt"]\n',
                                     encoding="utf-8")
    done = aldpat("run", "w.toml", "--dry-run", cwd=tmp_path).ok()
    assert 'algorithm = "pm"    # worksheet' in done.stdout.splitlines()


def test_dry_run_says_which_outputs_the_run_would_find_there_and_an_odir_that_is_a_file(tmp_path):
    """``--dry-run`` said "writes out/samp24_pm.txt", exit 0, of an output the run then refused
    ("output exists"), and an ``--odir`` naming a file was taken until each job failed to make it
    ("cannot create output folder: File exists"). The dry run now names the existing output with
    the run's exit status, and an ``--odir`` that is a file is a usage error before anything runs."""
    (tmp_path / "samp24.txt").write_bytes(SAMPLE.read_bytes())
    aldpat("filter", "pm", "samp24.txt", "--odir", "out", cwd=tmp_path).ok()
    dry = aldpat("filter", "pm", "samp24.txt", "--odir", "out", "--dry-run", cwd=tmp_path)
    run = aldpat("filter", "pm", "samp24.txt", "--odir", "out", cwd=tmp_path)
    assert dry.returncode == run.returncode == 1
    assert "out/samp24_pm.txt: output exists (use --overwrite" in dry.stderr
    assert "out/samp24_pm.txt: output exists (use --overwrite" in run.stderr
    aldpat("filter", "pm", "samp24.txt", "--odir", "out", "--dry-run", "--overwrite", cwd=tmp_path).ok()
    (tmp_path / "afile").write_text("mine\n")
    for extra in ([], ["--dry-run"]):
        done = aldpat("filter", "pm", "samp24.txt", "--odir", "afile", *extra, cwd=tmp_path)
        assert done.returncode == 2 and "--odir afile is a file, not a folder" in done.stderr, done.stderr
    assert (tmp_path / "afile").read_text() == "mine\n"


def test_dry_run_refuses_an_input_of_no_point_format_as_the_run_does(tmp_path):
    """``--dry-run`` of a named ``pic.png`` said "writes pic_gapm.png", exit 0, and the run then
    refused the input by its extension alone. The dry run says the run's line with its exit
    status, reading nothing; ``--format las`` is taken as the run takes it, and a grid is an
    input of ``preview``."""
    (tmp_path / "samp24.txt").write_bytes(SAMPLE.read_bytes())
    (tmp_path / "pic.png").write_bytes(b"\x89PNG\r\n\x1a\n")
    dry = aldpat("filter", "gapm", "samp24.txt", "pic.png", "--odir", "out", "--dry-run", cwd=tmp_path)
    run = aldpat("filter", "gapm", "samp24.txt", "pic.png", "--odir", "out", cwd=tmp_path)
    said = "pic.png: unknown extension '.png' (point files are .txt .xyz .csv .pts .las .laz; use --format"
    assert dry.returncode == run.returncode == 1
    assert said in dry.stderr and said in run.stderr and "samp24" not in dry.stderr
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["samp24_gapm.log", "samp24_gapm.txt"]
    given = aldpat("filter", "gapm", "pic.png", "--format", "las", "--odir", "o2", "--dry-run", cwd=tmp_path).ok()
    assert "unknown extension" not in given.stderr and not (tmp_path / "o2").exists()
    (tmp_path / "dtm.vrt").write_text("<VRTDataset/>\n")  # preview reads grids as well as points
    assert "unknown extension" not in aldpat("preview", "dtm.vrt", "--dry-run", cwd=tmp_path).ok().stderr
