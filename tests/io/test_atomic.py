import os

import pytest

from aldpat.errors import OutputError, OutputExistsError
from aldpat.io.atomic import TMP_MARK, atomic_output


def test_output_appears_only_when_complete(tmp_path):
    target = tmp_path / "out.txt"
    with atomic_output(target) as tmp:
        tmp.write_text("partial")
        assert not target.exists() and TMP_MARK in tmp.name
    assert target.read_text() == "partial"


def test_failure_leaves_neither_file_nor_temporary(tmp_path):
    target = tmp_path / "out.txt"
    with pytest.raises(RuntimeError), atomic_output(target) as tmp:
        tmp.write_text("half")
        raise RuntimeError("boom")
    assert os.listdir(tmp_path) == []


def test_existing_output_is_kept_without_overwrite(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("precious")
    with pytest.raises(OutputExistsError, match="use --overwrite"), atomic_output(target):
        pass
    assert target.read_text() == "precious"
    with atomic_output(target, overwrite=True) as tmp:
        tmp.write_text("new")
    assert target.read_text() == "new"


def test_output_folder_that_cannot_be_created(tmp_path):
    # a plain file where the folder should be: fails for every user, root included
    blocker = tmp_path / "taken"
    blocker.write_text("")
    with pytest.raises(OutputError, match="cannot create output folder"), atomic_output(blocker / "sub" / "x.txt"):
        pass


def test_two_writers_of_one_output_one_wins_whole(tmp_path):
    from aldpat.io.atomic import atomic_output as out

    target = tmp_path / "out.txt"
    first, second = out(target), out(target)
    a, b = first.__enter__(), second.__enter__()  # both started before either finished
    a.write_text("first writer")
    b.write_text("second writer")
    first.__exit__(None, None, None)
    with pytest.raises(OutputExistsError, match="another process may have written it"):
        second.__exit__(None, None, None)
    assert target.read_text() == "first writer"
    assert sorted(os.listdir(tmp_path)) == ["out.txt"]


def test_a_set_of_files_is_taken_back_when_one_cannot_be_placed(tmp_path):
    from aldpat.io.atomic import atomic_outputs

    files = [tmp_path / "a.shp", tmp_path / "a.dbf"]
    with pytest.raises(OutputExistsError), atomic_outputs(files) as tmps:
        for t in tmps:
            t.write_text("x")
        files[1].write_text("written meanwhile by someone else")
    assert sorted(os.listdir(tmp_path)) == ["a.dbf"] and files[1].read_text().startswith("written")


def test_temporaries_of_a_killed_process_are_removed_on_the_next_write(tmp_path):
    import subprocess
    import sys

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                          text=True, check=True).stdout.strip()
    stale = tmp_path / f"out{TMP_MARK}{dead}.txt"
    stale.write_text("left by SIGKILL")
    other = tmp_path / f"other{TMP_MARK}{dead}.txt"
    other.write_text("another output's: not ours to remove")
    with atomic_output(tmp_path / "out.txt") as tmp:
        tmp.write_text("done")
    assert sorted(os.listdir(tmp_path)) == ["other" + TMP_MARK + dead + ".txt", "out.txt"]


def test_a_full_disk_names_the_output_and_leaves_nothing(tmp_path):
    from aldpat.io.atomic import as_output_error

    target = tmp_path / "out.txt"
    with pytest.raises(OutputError, match=r"out.txt: cannot write this output: no space left on device"), \
            atomic_output(target) as tmp:
        tmp.write_text("partial")
        raise OSError(28, "No space left on device", str(tmp))
    assert os.listdir(tmp_path) == []
    assert as_output_error(ValueError("a bug"), target) is None  # not every failure is the disk's


def test_a_folder_sweep_leaves_the_temporaries_of_running_writers(tmp_path):
    import subprocess
    import sys

    from aldpat.io.atomic import remove_stale_temporaries_in

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                          text=True, check=True).stdout.strip()
    (tmp_path / f"a{TMP_MARK}{dead}-1.txt").write_text("killed writer")
    running = tmp_path / f"b{TMP_MARK}{os.getppid()}-1.laz"  # our parent: alive
    running.write_text("still being written")
    (tmp_path / "c.txt").write_text("an output")
    remove_stale_temporaries_in(tmp_path)
    assert sorted(os.listdir(tmp_path)) == sorted([running.name, "c.txt"])
