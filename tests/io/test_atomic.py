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
    with pytest.raises(RuntimeError):
        with atomic_output(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("boom")
    assert os.listdir(tmp_path) == []


def test_existing_output_is_kept_without_overwrite(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("precious")
    with pytest.raises(OutputExistsError, match="use --overwrite"):
        with atomic_output(target):
            pass
    assert target.read_text() == "precious"
    with atomic_output(target, overwrite=True) as tmp:
        tmp.write_text("new")
    assert target.read_text() == "new"


def test_output_folder_that_cannot_be_created(tmp_path):
    # a plain file where the folder should be: fails for every user, root included
    blocker = tmp_path / "taken"
    blocker.write_text("")
    with pytest.raises(OutputError, match="cannot create output folder"):
        with atomic_output(blocker / "sub" / "x.txt"):
            pass
