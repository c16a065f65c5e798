"""The demo worksheet's data-preparation chain runs end to end, from any folder."""

import shutil
from pathlib import Path

import numpy as np
import pyproj
import shapefile as pyshp

REPO = Path(__file__).resolve().parents[2]


def test_demo_chain_from_another_folder(tmp_path, runner, cli, monkeypatch):
    work = tmp_path / "jobs"
    shutil.copytree(REPO / "jobs" / "data", work / "data")
    shutil.copytree(REPO / "jobs" / "params", work / "params")
    shutil.copy(REPO / "jobs" / "demo.toml", work / "demo.toml")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    out = runner.invoke(cli, ["run", str(work / "demo.toml")])
    assert out.exit_code == 0, out.output
    demo = work / "demo-out"
    strips = sorted((demo / "strips").glob("*_strip*.txt"))
    assert [len(np.loadtxt(p)) for p in strips] == [2292, 2564, 2588]  # the three synthesised strips
    tape = np.loadtxt(work / "data" / "fsite5_tape.txt")
    assert np.array_equal(np.concatenate([np.loadtxt(p) for p in strips]), tape)
    with pyshp.Reader(str(demo / "strips.shp")) as r:
        assert len(r) == 3 and [rec[0] for rec in r.records()] == [1, 2, 3]
    assert pyproj.CRS.from_wkt((demo / "strips.prj").read_text()).to_epsg() == 32632
    rows = (demo / "tiles" / "tile_parameter.txt").read_text().splitlines()
    assert len(rows) == 6 and all(len(r.split()) == 8 for r in rows)
    assert len(list((demo / "thin").glob("*_thin.txt"))) == 6
    assert len(list((demo / "poly").glob("*_poly.txt"))) == 3
    assert "total       6.15 %" in out.output  # GAPM set 01 on samp24, scored by evaluate
    assert len(list((demo / "ground").glob("tile_*_gapm.txt"))) == 6
    assert len(list((demo / "grids").glob("tile_*_gapm_linear.grd"))) == 6
    assert len(list((demo / "grids").glob("tile_*_gapm_linear.flt"))) == 6
    assert list(elsewhere.iterdir()) == []  # nothing written to the current folder
    again = runner.invoke(cli, ["run", str(work / "demo.toml")])  # overwrite = true in [settings]
    assert again.exit_code == 0, again.output
    assert len((demo / "tiles" / "tile_parameter.txt").read_text().splitlines()) == 6


def test_broward_worksheet_runs_once_tapes_are_dropped_in(tmp_path, runner, cli):
    from tests.tasks.prep_data import tape_rows, write_tape

    shutil.copy(REPO / "jobs" / "broward.toml", tmp_path / "broward.toml")
    before = runner.invoke(cli, ["run", str(tmp_path / "broward.toml"), "--dry-run"])
    assert before.exit_code == 2 and "tapes" in before.output  # no tapes yet: said before anything runs
    (tmp_path / "tapes").mkdir()
    times = np.concatenate([100 + 0.1 * np.arange(300), 500 + 0.1 * np.arange(300)])
    rows = tape_rows(times, seed=2)
    rows[:, [1, 5]] += 67000 + 17_000_000  # Broward, with the zone 17 prefix in x and y
    rows[:, [2, 6]] += 89000 + 170_000_000
    write_tape(tmp_path / "tapes" / "tape01.txt", rows)
    out = runner.invoke(cli, ["run", str(tmp_path / "broward.toml")])
    assert out.exit_code == 0, out.output
    assert len(list((tmp_path / "strips").glob("tape01_strip*.txt"))) == 2
    assert len(list((tmp_path / "returns" / "last").glob("*_2.txt"))) == 2
    last = np.loadtxt(tmp_path / "returns" / "last" / "tape01_strip01_2.txt")
    assert 567000 <= last[:, 0].min() and last[:, 1].max() < 2889200  # zone stripped
    assert [p.name for p in (tmp_path / "tiles").glob("tile_*_*.txt")] == ["tile_566000_2888000.txt"]
    assert (tmp_path / "boundary" / "broward_strips.prj").exists()
    assert len(list((tmp_path / "thin").glob("*_thin.txt"))) == 1
