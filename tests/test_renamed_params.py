"""One name per concept: renamed parameters and values still work under their earlier spelling,
with a deprecation message, and give the same results as the names now."""

from __future__ import annotations

import shutil
import subprocess
import sys

import numpy as np
import pytest

from aldpat.errors import ParamError
from aldpat.filters import FILTERS, ground_filter
from aldpat.params import resolve
from aldpat.tasks import get_task

ALDPAT = [sys.executable, "-m", "aldpat"]


def test_thin_cell_width_is_now_cell(tmp_path, samp24):
    shutil.copy(samp24, tmp_path / "a.txt")
    old = subprocess.run(ALDPAT + ["thin", str(tmp_path / "a.txt"), "--cell-width", "3", "--odir",
                                   str(tmp_path / "old")], check=False, capture_output=True, text=True)
    assert old.returncode == 0, old.stderr
    assert "cell_width is now called cell" in old.stderr
    new = subprocess.run(ALDPAT + ["thin", str(tmp_path / "a.txt"), "--cell", "3", "--odir", str(tmp_path / "new")],
                         check=False, capture_output=True, text=True)
    assert new.returncode == 0 and "now called" not in new.stderr
    assert (tmp_path / "old" / "a_thin.txt").read_bytes() == (tmp_path / "new" / "a_thin.txt").read_bytes()


def test_worksheet_keys_are_renamed_too(tmp_path, samp24):
    shutil.copy(samp24, tmp_path / "a.txt")
    (tmp_path / "job.toml").write_text('[[job]]\ntask = "strip-boundary"\ninputs = ["a.txt"]\ncell_width = 4.0\n')
    proc = subprocess.run(ALDPAT + ["run", str(tmp_path / "job.toml"), "--dry-run"], check=False, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert "job 1: cell_width is now called cell" in proc.stderr
    assert "cell = 4" in proc.stdout


def test_both_names_at_once_are_refused():
    with pytest.raises(ParamError, match="cell_width and cell are one parameter"):
        resolve(get_task("thin").params, [("cli", {"cell": 1.0, "cell_width": 2.0})])


def test_slope_height_is_now_cell_height():
    old = resolve(FILTERS["slope"].params, [("worksheet", {"height": 2.0})]).values
    assert old.cell_height == 2.0 and old.cell_shape() == (1.0, 2.0)


@pytest.mark.parametrize("algo", ["cluster-pm", "multipass"])
def test_direction_takes_the_x_y_xy_of_pm_and_tile(algo, caplog):
    params = FILTERS[algo].params
    for old, new in (("row", "x"), ("column", "y"), ("both", "xy")):
        with caplog.at_level("WARNING"):
            got = resolve(params, [("worksheet", {"direction": old})]).values
        assert got.direction == new
        assert f"{old!r} is now spelled {new!r}" in caplog.text
    rng = np.random.default_rng(3)
    x, y = rng.uniform(0, 60, 3000), rng.uniform(0, 60, 3000)
    z = 0.05 * x + np.where((x > 20) & (x < 30) & (y > 20) & (y < 30), 6.0, 0.0)
    a = ground_filter(x, y, z, algo, resolve(params, [("w", {"direction": "row"})]).values).is_ground
    b = ground_filter(x, y, z, algo, resolve(params, [("w", {"direction": "x"})]).values).is_ground
    assert np.array_equal(a, b) and not a.all()
