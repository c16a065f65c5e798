"""split-tape (manual task 1): a new strip where GPS time jumps by more than the interval."""

import numpy as np
import pytest

from aldpat.errors import UsageError
from aldpat.tasks import get_task
from aldpat.tasks.split_tape import strip_starts
from tests.tasks.prep_data import tape_rows, write_tape

# strips of 40, 25 and 30 shots: gaps of 100 s and 61 s; a 60 s pause inside the second strip
TIMES = np.concatenate([
    1000 + 0.5 * np.arange(40),
    1119.5 + 100 + 0.5 * np.arange(10),
    1219.5 + 4.5 + 60 + 0.5 * np.arange(15),
])
TIMES = np.concatenate([TIMES, TIMES[-1] + 61 + 0.5 * np.arange(30)])


def test_strip_starts_by_hand():
    t = np.array([0.0, 1.0, 62.0, 63.0, 123.0])
    assert strip_starts(t, None, 60.0).tolist() == [2]  # 61 s > 60; 60 s is not more than 60
    assert strip_starts(np.array([200.0, 201.0]), 123.0, 60.0).tolist() == [0]
    assert strip_starts(np.array([150.0, 151.0]), 123.0, 60.0).tolist() == []


@pytest.mark.parametrize("order", ["last-first", "first-last"])
def test_split_into_strips_records_unchanged(tmp_path, order):
    rows = tape_rows(TIMES)
    tape = write_tape(tmp_path / "tape.txt", rows, order)
    report = get_task("split-tape")([tape], interval=60.0, order=order, odir=str(tmp_path / "out"))
    assert report.exit_code == 0, report.results[0].error
    names = [p.split("/")[-1] for p in (w.path for w in report.outputs)]
    assert names == ["tape_strip01.txt", "tape_strip02.txt", "tape_strip03.txt"]
    on_disk = np.loadtxt(tape)
    pieces = [np.loadtxt(tmp_path / "out" / n) for n in names]
    assert [len(p) for p in pieces] == [40, 25, 30]
    assert np.array_equal(np.concatenate(pieces), on_disk)  # same records, same order, same columns
    assert (tmp_path / "out" / "tape_strip01.log").exists()


def test_strips_split_across_chunks(tmp_path, monkeypatch):
    from aldpat.io.text import TextReader

    whole = TextReader.chunks
    monkeypatch.setattr(TextReader, "chunks", lambda self, size=5: whole(self, 5))  # both cuts (40, 65) fall on chunk edges
    tape = write_tape(tmp_path / "tape.txt", tape_rows(TIMES))
    report = get_task("split-tape")([tape], odir=str(tmp_path / "out"))
    assert [w.count for w in report.outputs] == [40, 25, 30]
    pieces = [np.loadtxt(w.path) for w in report.outputs]
    assert np.array_equal(np.concatenate(pieces), np.loadtxt(tape))


def test_a_bad_line_leaves_no_strip_files(tmp_path, runner, cli):
    tape = write_tape(tmp_path / "tape.txt", tape_rows(TIMES))
    lines = tape.read_text().splitlines()
    lines[70] = lines[70].replace(" ", " x", 1)
    tape.write_text("\n".join(lines) + "\n")
    out = runner.invoke(cli, ["split-tape", str(tape), "--odir", str(tmp_path / "out")])
    assert out.exit_code == 1
    assert "tape.txt:71" in out.output
    assert list((tmp_path / "out").glob("*.txt")) == []  # neither strips nor temporaries


def test_existing_strips_need_overwrite(tmp_path, runner, cli):
    tape = write_tape(tmp_path / "tape.txt", tape_rows(TIMES))
    args = ["split-tape", str(tape), "--interval", "60"]
    assert runner.invoke(cli, args).exit_code == 0
    again = runner.invoke(cli, args)
    assert again.exit_code == 1 and "exists" in again.output
    assert runner.invoke(cli, args + ["--overwrite"]).exit_code == 0
    assert len(np.loadtxt(tmp_path / "tape_strip01.txt")) == 40


def test_las_output_is_refused_for_tapes(tmp_path):
    """Strips are text: LAS/LAZ strips are refused where the strips are planned, before a line is read."""
    tape = write_tape(tmp_path / "tape.txt", tape_rows(TIMES))
    with pytest.raises(UsageError, match="9-column text layout; --out-format las/laz does not apply"):
        get_task("split-tape")([tape], out_format="las")
    named = write_tape(tmp_path / "tape.las", tape_rows(TIMES))  # a text tape named .las, read as text
    with pytest.raises(UsageError, match=r"cannot take the extension \.las of .*tape\.las; give --out-format text"):
        get_task("split-tape")([named], format="text")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tape.las", "tape.txt"]  # nothing written


def test_strips_are_written_one_open_file_at_a_time(tmp_path):
    """A tape splitting into more strips than a process may open files (a careless --interval)
    is split whole: strips follow one another, and each is closed when the next begins."""
    import resource
    import subprocess

    from tests.cli.fresh import aldpat_command

    n = 300  # strips, each of two pulses; the process below may open 64 files
    t = 318000.0 + np.repeat(np.arange(n) * 10.0, 2) + np.tile([0.0, 0.01], n)
    x = 500000.0 + np.arange(2 * n)
    rows = np.column_stack([t, x, x * 0 + 4e6, x * 0 + 100, x * 0 + 10, x, x * 0 + 4e6, x * 0 + 100.5, x * 0 + 12])
    np.savetxt(tmp_path / "tape.txt", rows, fmt=["%.2f"] + ["%.2f", "%.2f", "%.2f", "%d"] * 2)

    def few_files() -> None:
        resource.setrlimit(resource.RLIMIT_NOFILE, (64, 64))

    proc = subprocess.run([*aldpat_command(), "split-tape", str(tmp_path / "tape.txt"), "--interval", "1", "--odir",
                           str(tmp_path / "strips")], capture_output=True, text=True, preexec_fn=few_files, check=False)
    assert proc.returncode == 0, proc.stderr
    strips = sorted((tmp_path / "strips").glob("tape_strip*.txt"))
    assert len(strips) == n and all(len(p.read_text().splitlines()) == 2 for p in strips)


def test_a_tape_split_again_with_overwrite_replaces_the_whole_set_of_strips(tmp_path):
    """The same tape split again into fewer strips with --overwrite left the earlier run's later
    strips beside the new ones, and ``separate-returns tape_strip*.txt`` took them in without a
    word. In fresh processes: the set is replaced whole, with a warning naming what went, and
    files that only start like a strip (``tape_strip01_1.txt``, separate-returns' output) stay."""
    from tests.cli.fresh import aldpat

    write_tape(tmp_path / "tape.txt", tape_rows(TIMES))
    aldpat("split-tape", "tape.txt", "--interval", "60", "--odir", "strips", cwd=tmp_path).ok()
    assert sorted(p.name for p in (tmp_path / "strips").glob("*.txt")) == [
        "tape_strip01.txt", "tape_strip02.txt", "tape_strip03.txt"]
    (tmp_path / "strips" / "tape_strip01_1.txt").write_text("kept\n")
    write_tape(tmp_path / "tape.txt", tape_rows(TIMES[:40]))  # the first strip alone
    done = aldpat("split-tape", "tape.txt", "--interval", "60", "--odir", "strips", "--overwrite", cwd=tmp_path).ok()
    assert sorted(p.name for p in (tmp_path / "strips").glob("*.txt")) == ["tape_strip01.txt", "tape_strip01_1.txt"]
    assert "2 strips of an earlier run past those of this one removed (tape_strip02.txt, tape_strip03.txt)" \
        in done.stderr
    assert len(np.loadtxt(tmp_path / "strips" / "tape_strip01.txt")) == 40


def test_a_tape_out_of_time_order_is_said(tmp_path):
    """A strip is cut where GPS time jumps forward by more than the interval (manual task 1); a
    tape whose blocks were concatenated out of order jumps back, and its passes went into one
    strip without a word. In a fresh process: a warning naming the shot where time goes back."""
    from tests.cli.fresh import aldpat

    rows = tape_rows(TIMES)
    write_tape(tmp_path / "tape.txt", np.concatenate([rows[40:], rows[:40]]))
    done = aldpat("split-tape", "tape.txt", "--interval", "60", "--odir", "strips", cwd=tmp_path).ok()
    back = TIMES[-1] - TIMES[0]
    assert f"GPS time goes back by {back:g} s at shot 56 (more than the interval): the tape is not in time order" \
        in done.stderr
