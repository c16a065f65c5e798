"""Every rule relating parameters is checked before any input is read: ``aldpat run --dry-run``
exits 2 naming the job and the key (the params classes' ``check()`` hook, run by ``resolve``)."""

from __future__ import annotations

import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from aldpat.errors import ParamError
from aldpat.params import resolve
from aldpat.tasks import get_task

ALDPAT = [sys.executable, "-m", "aldpat"]

#: (task, keys of the second job, text the message must hold after "job 2: ")
BAD = [
    ("filter pm", {"window_series": [3, 2]}, "window_series: half windows must be strictly ascending"),
    ("filter pm", {"window_series": [1, 2], "threshold_series": [0.5]}, "threshold_series: expected one value"),
    ("filter pm", {"window_series": [1, 2], "min_window": 5}, "min_window: 5 leaves no window"),
    ("filter pm2d", {"window_series": [3, 2]}, "window_series: half windows must be strictly ascending"),
    ("filter gapm", {"window_series": [3, 2], "cluster_thresholds": [0.3, 0.5]},
     "window_series: half windows must be strictly ascending"),
    ("filter gapm", {"cluster_thresholds": [0.3]}, "cluster_thresholds: expected one value per window"),
    ("filter etew", {"min_z": 5.0, "max_z": 1.0}, "min_z: 5 is above max_z 1"),
    ("filter slope", {"min_distance": 9.0, "search_radius": 8.0}, "min_distance: 9 must be below search_radius"),
    ("filter ipf", {"window_series": [5.0, 10.0]}, "window_series: must not grow"),
    ("filter multipass", {"threshold_series": [0.3]}, "threshold_series: expected one value per window"),
    ("filter cluster-pm", {"threshold_series": [0.3]}, "threshold_series: expected one value per window"),
    ("grid", {"bounds": [10.0, 0.0, 0.0, 10.0]}, "bounds: maximum must exceed minimum"),
    ("grid", {"bounds": [0.0, 0.0, 10.0, 10.0], "tile_params": "tile_parameter.txt"},
     "bounds: give either --tile-params or --bounds"),
    ("grid", {"grid_format": "surfer6", "nodata": -9999.0}, "nodata: applies to surfer7 and GeoTIFF grids"),
    ("tile", {"bounds": [10.0, 0.0, 0.0, 10.0]}, "bounds: maximum below minimum"),
    ("ortho-height", {}, "geoid: required"),
    ("ortho-height", {"geoid": "no_such_grid.gtx"}, "geoid: "),
    ("ortho-height", {"geoid": "GEOID", "to_crs": "EPSG:999999"}, "to_crs: unknown CRS"),
    ("ortho-height", {"geoid": "GEOID", "crs": "61N"}, "crs: UTM zone must be 1..60"),
    ("convert", {"crs": "EPSG:999999"}, "crs: unknown CRS"),
    ("grd2bin", {"crs": "not a crs"}, "crs: unknown CRS"),
    ("shapefile", {"crs": "EPSG:999999"}, "crs: unknown CRS"),
    ("thin", {"crs": "\u00b2\u00b2\u00b2"}, "crs: unknown CRS"),  # digits to str.isdigit, not to int
    ("separate-returns", {"utm_zone": "99"}, "utm_zone: expected auto, none or a zone number"),
]


def _toml(value) -> str:
    if isinstance(value, str):
        return f'"{value}"'
    return repr(value)


def worksheet(folder, task: str, keys: dict) -> str:
    name, _, algo = task.partition(" ")
    lines = [f'task = "{"filter" if algo else name}"'] + ([f'algorithm = "{algo}"'] if algo else [])
    lines += ['inputs = ["a.txt"]'] + [f"{k} = {_toml(v)}" for k, v in keys.items()]
    return textwrap.dedent("""
        [[job]]
        task = "info"
        inputs = ["a.txt"]

        [[job]]
        """) + "\n".join(lines) + "\n"


@pytest.mark.parametrize("task, keys, message", BAD, ids=[f"{t}-{'-'.join(k)}" for t, k, _ in BAD])
def test_dry_run_names_job_and_key(tmp_path, samp24, task, keys, message):
    shutil.copy(samp24, tmp_path / "a.txt")
    keys = {k: (str(_geoid()) if v == "GEOID" else v) for k, v in keys.items()}
    (tmp_path / "job.toml").write_text(worksheet(tmp_path, task, keys))
    proc = subprocess.run(ALDPAT + ["run", str(tmp_path / "job.toml"), "--dry-run"], check=False, capture_output=True,
                          text=True, cwd=tmp_path)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert f"job 2: {message}" in proc.stderr, proc.stderr


def test_a_path_holding_a_nul_is_refused_naming_job_and_key(tmp_path, samp24):
    """TOML can hold a NUL ("\\u0000"); no file name can (it was an internal error)."""
    shutil.copy(samp24, tmp_path / "a.txt")
    (tmp_path / "job.toml").write_text(worksheet(tmp_path, "grid", {"tile_params": "tp\\u0000.txt"}))
    proc = subprocess.run(ALDPAT + ["run", str(tmp_path / "job.toml")], check=False, capture_output=True, text=True,
                          cwd=tmp_path)
    assert proc.returncode == 2 and "job 2: tile_params: '" in proc.stderr, proc.stderr
    assert "tp\\x00.txt' is a name holding a NUL character" in proc.stderr, proc.stderr


@pytest.mark.parametrize("value, message", [("-3", "cell: -3 is out of range (must be > 0)"),
                                            ('"x"', "cell: expected a number, got 'x'")])
def test_a_bad_settings_value_is_said_to_come_from_settings(tmp_path, samp24, value, message):
    """A ``[settings]`` value every job takes was reported as "job 1: cell: ...", sending the
    user to a job that does not name it; a job's own value is still its job's."""
    shutil.copy(samp24, tmp_path / "a.txt")
    sheet = tmp_path / "job.toml"
    sheet.write_text(f'[settings]\ncell = {value}\n\n[[job]]\ntask = "grid"\ninputs = ["a.txt"]\n')
    proc = subprocess.run(ALDPAT + ["run", str(sheet), "--dry-run"], check=False, capture_output=True, text=True,
                          cwd=tmp_path)
    assert proc.returncode == 2 and f"job 1: [settings] {message}" in proc.stderr, proc.stderr
    sheet.write_text(f'[[job]]\ntask = "grid"\ninputs = ["a.txt"]\ncell = {value}\n')
    proc = subprocess.run(ALDPAT + ["run", str(sheet), "--dry-run"], check=False, capture_output=True, text=True,
                          cwd=tmp_path)
    assert proc.returncode == 2 and f"job 1: {message}" in proc.stderr, proc.stderr


def _geoid() -> Path:
    return Path(__file__).resolve().parents[1] / "data" / "egm96_15_nga1.gtx"


def test_the_same_rules_hold_on_the_command_line(tmp_path, samp24):
    """One check, whatever the entry: the command line stops with exit 2 before reading a file."""
    proc = subprocess.run(ALDPAT + ["filter", "pm", str(tmp_path / "never_read.txt"), "--window-series", "3,2"],
                          check=False, capture_output=True, text=True)
    assert proc.returncode == 2 and "window_series: half windows must be strictly ascending" in proc.stderr
    proc = subprocess.run(ALDPAT + ["shapefile", str(tmp_path / "never_read.txt"), "--crs", "17N", "--output",
                                    str(tmp_path / "x.shp")], check=False, capture_output=True, text=True)
    assert "unknown CRS" not in proc.stderr  # 17N is a CRS for every task, as for grd2bin


def test_resolve_runs_the_hook_with_its_prefix():
    with pytest.raises(ParamError, match=r"^job 7: min_z: 5 is above max_z 1$"):
        resolve(get_task("filter etew").params, [("worksheet", {"min_z": 5, "max_z": 1})], where="job 7: ")
    ok = resolve(get_task("convert").params, [("cli", {"crs": "17N"})]).values
    assert ok.crs == "17N"
