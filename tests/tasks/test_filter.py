"""``aldpat filter ALGO``: outputs, result modes, marks, data modes, LAS attributes."""

import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

from aldpat.filters import FILTERS, ground_filter
from aldpat.filters.pm import PMParams
from aldpat.jobs.registry import get_task
from aldpat.jobs.resolve import resolve_run

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("name", sorted(FILTERS))
def test_every_registered_filter_is_a_subcommand(name, runner, cli):
    out = runner.invoke(cli, ["filter", name, "--help"])
    assert out.exit_code == 0, out.output
    assert "--result" in out.output and "--marks" in out.output and "--cell" in out.output
    assert get_task("filter", name).params is FILTERS[name].params


def test_terrain_and_nonterrain_split_every_point(runner, cli, samp24, tmp_path):
    out = runner.invoke(cli, ["filter", "pm", str(samp24), "--odir", str(tmp_path), "--result", "both",
                              "--window-series", "1,2,4,8", "--marks"])
    assert out.exit_code == 0, out.output
    data = np.loadtxt(samp24)
    terrain = np.loadtxt(tmp_path / "samp24_pm.txt")
    nonterrain = np.loadtxt(tmp_path / "samp24_pm_nt.txt")
    assert len(terrain) + len(nonterrain) == len(data)
    # same classes as the library call; marks column last: 0 in terrain, positive elsewhere
    res = ground_filter(data[:, 0], data[:, 1], data[:, 2], "pm", PMParams(window_series=(1, 2, 4, 8)))
    assert len(terrain) == res.is_ground.sum()
    # a low outlier's mark is MARK_LOW_OUTLIER (-9000)
    assert (terrain[:, -1] == 0).all() and ((nonterrain[:, -1] > 0) | (nonterrain[:, -1] == -9000)).all()
    assert set(nonterrain[:, -1].astype(int)) <= {1, 2, 4, 8, -9000}
    assert np.allclose(np.sort(terrain[:, 2]), np.sort(data[res.is_ground, 2]))
    log = (tmp_path / "samp24_pm.log").read_text()
    assert "window_series        = 1,2,4,8    (cli)" in log


def test_result_modes_choose_the_files(runner, cli, samp24, tmp_path):
    assert runner.invoke(cli, ["filter", "etew", str(samp24), "--odir", str(tmp_path),
                               "--result", "nonterrain"]).exit_code == 0
    assert (tmp_path / "samp24_etew_nt.txt").exists() and not (tmp_path / "samp24_etew.txt").exists()
    # an existing output is an error without --overwrite (exit status 1)
    out = runner.invoke(cli, ["filter", "etew", str(samp24), "--odir", str(tmp_path), "--result", "nonterrain"])
    assert out.exit_code == 1
    assert runner.invoke(cli, ["filter", "etew", str(samp24), "--odir", str(tmp_path), "--result", "nonterrain",
                               "--overwrite"]).exit_code == 0


def test_classified_text_scores_like_the_terrain_output(runner, cli, samp24, tmp_path):
    args = ["filter", "pm2d", str(samp24), "--odir", str(tmp_path)]
    assert runner.invoke(cli, args + ["--result", "classified"]).exit_code == 0
    cls = np.loadtxt(tmp_path / "samp24_pm2d.txt")
    assert len(cls) == 7492 and {1.0, 2.0} <= set(cls[:, -1]) <= {1.0, 2.0, 7.0}  # 7: low outliers
    a = runner.invoke(cli, ["evaluate", str(tmp_path / "samp24_pm2d.txt"), "--reference", str(samp24),
                            "--mode", "classified", "--json"])
    assert runner.invoke(cli, args + ["--suffix", "_t"]).exit_code == 0
    b = runner.invoke(cli, ["evaluate", str(tmp_path / "samp24_t.txt"), "--reference", str(samp24), "--json"])
    ja, jb = json.loads(a.output), json.loads(b.output)
    assert ja["points"] == jb["points"] == 7492
    assert [ja[k] for k in ("type1", "type2", "total")] == [jb[k] for k in ("type1", "type2", "total")]


def test_las_keeps_attributes_and_gets_classes_and_marks(runner, cli, samp24, tmp_path):
    import laspy

    assert runner.invoke(cli, ["convert", str(samp24), "--out-format", "laz", "--odir", str(tmp_path)]).exit_code == 0
    src = tmp_path / "samp24.laz"
    out = runner.invoke(cli, ["filter", "pmcircle", str(src), "--result", "classified", "--marks"])
    assert out.exit_code == 0, out.output
    las_in = laspy.read(src)
    las = laspy.read(tmp_path / "samp24_pmcircle.laz")
    assert len(las.points) == len(las_in.points)
    assert np.array_equal(np.asarray(las.intensity), np.asarray(las_in.intensity))
    assert np.array_equal(np.asarray(las.x), np.asarray(las_in.x))
    classes = np.asarray(las.classification)
    marks = np.asarray(las["mark"])
    assert {1, 2} <= set(np.unique(classes)) <= {1, 2, 7}
    assert np.array_equal(classes == 2, marks == 0) and np.array_equal(classes == 7, marks == -9000)
    # terrain output of a LAS is LAS with the same attributes
    assert runner.invoke(cli, ["filter", "pmcircle", str(src), "--suffix", "_g", "--result", "terrain"]).exit_code == 0
    g = laspy.read(tmp_path / "samp24_g.laz")
    assert len(g.points) == int((classes == 2).sum())


@pytest.mark.parametrize("kind, refused", [(np.float32, False), (np.uint8, True)])
def test_marks_over_an_input_s_own_mark_dimension_are_said(tmp_path, kind, refused):
    """A LAS's own ``mark`` (a vendor's extra bytes, an earlier ``--marks``) was replaced by the
    filter's without a word, and a uint8 one took -9000 and windows wrapped."""
    import laspy

    from tests.cli.fresh import TEST_DATA, aldpat

    las = laspy.read(TEST_DATA / "fsite5_pit.laz")
    las.add_extra_dim(laspy.ExtraBytesParams(name="mark", type=kind))
    las.mark = np.full(len(las.points), 5, kind)
    las.write(tmp_path / "own.laz")
    done = aldpat("filter", "pm", tmp_path / "own.laz", "--marks", "--odir", tmp_path / "out")
    if refused:
        assert done.returncode == 1 and "own.laz: its own dimension mark (uint8) cannot hold the filter's marks" \
            in done.stderr, done.stderr
        assert not (tmp_path / "out" / "own_pm.laz").exists()
    else:
        assert done.returncode == 0 and "own.laz: its own dimension mark is replaced by the filter's marks" \
            in done.stderr, done.stderr
        out = laspy.read(tmp_path / "out" / "own_pm.laz")
        assert np.array_equal(np.asarray(out.classification) == 2, np.asarray(out.mark) == 0)


def test_center_mode_writes_one_point_per_cell_at_its_centre(runner, cli, samp24, tmp_path):
    out = runner.invoke(cli, ["filter", "pm", str(samp24), "--odir", str(tmp_path), "--data-mode", "center",
                              "--cell", "2", "--result", "both"])
    assert out.exit_code == 0, out.output
    t = np.loadtxt(tmp_path / "samp24_pm.txt")
    nt = np.loadtxt(tmp_path / "samp24_pm_nt.txt")
    pts = np.vstack([t, nt])
    # centres of 2 m cells aligned to multiples of 2: odd coordinates
    assert np.allclose(pts[:, 0] % 2, 1.0) and np.allclose(pts[:, 1] % 2, 1.0)
    assert len(np.unique(pts[:, :2], axis=0)) == len(pts)
    data = np.loadtxt(samp24)
    cells = np.unique(np.floor(data[:, :2] / 2), axis=0)
    assert len(pts) == len(cells)


def test_params_file_and_python_call(runner, cli, samp24, tmp_path):
    toml = tmp_path / "pm.toml"
    toml.write_text('window_series = [1, 2, 4]\nthreshold_series = [0.3, 0.6, 1.2]\ndirection = "x"\n')
    out = runner.invoke(cli, ["filter", "pm", str(samp24), "--params", str(toml), "--odir", str(tmp_path / "a")])
    assert out.exit_code == 0, out.output
    assert "threshold_series     = 0.3,0.6,1.2    (params file)" in (tmp_path / "a" / "samp24_pm.log").read_text()
    report = get_task("filter", "pm")([samp24], window_series=[1, 2, 4], threshold_series=[0.3, 0.6, 1.2],
                                      direction="x", odir=str(tmp_path / "b"), result="both")
    assert report.exit_code == 0
    assert sum(w.count for w in report.outputs) == 7492
    a = np.loadtxt(tmp_path / "a" / "samp24_pm.txt")
    b = np.loadtxt(tmp_path / "b" / "samp24_pm.txt")
    assert np.array_equal(a, b)


def test_bad_input_is_one_line_and_others_go_on(runner, cli, samp24, tmp_path):
    bad = tmp_path / "bad.txt"
    bad.write_text("1 2 3\n4 5 x\n")
    out = runner.invoke(cli, ["filter", "pm", str(bad), str(samp24), "--odir", str(tmp_path)])
    assert out.exit_code == 1
    assert "bad.txt" in out.output and "Traceback" not in out.output
    assert (tmp_path / "samp24_pm.txt").exists()


PARAM_FILES = sorted((REPO / "jobs" / "params").glob("*.toml"))


@pytest.mark.parametrize("path", PARAM_FILES, ids=[p.name for p in PARAM_FILES])
def test_shipped_parameter_files_are_valid(path):
    """Every jobs/params/<algo>[-variant].toml names only its filter's keys, within bounds."""
    algo = max((a for a in FILTERS if path.stem == a or path.stem.startswith(a + "-")), key=len)
    task = get_task("filter", algo)
    data = tomllib.loads(path.read_text())
    run = resolve_run(task, [("params file", data)])
    for key in data:
        assert run.params.sources.get(key) == "params file"


def test_the_summary_of_a_noise_filter_counts_its_noise_not_ground(tmp_path):
    """``filter outlier`` said "97.1 % ground" of a file it wrote no ground point to: it finds
    noise, and says the share of noise its output holds (whole and in chunks); a one-point output
    is "1 point", not "1 points"."""
    import laspy

    from tests.cli.fresh import aldpat

    strip = REPO / "tests" / "data" / "fsite5_strip.laz"
    for extra in ([], ["--chunk", "200"]):
        done = aldpat("filter", "outlier", str(strip), "--odir", "out", "--overwrite", *extra, cwd=tmp_path).ok()
        written = laspy.read(tmp_path / "out" / "fsite5_strip_outlier.laz").classification
        share = 100 * np.isin(written, (7, 18)).sum() / len(written)
        assert f"20,643 points, {share:.1f} % noise" in done.stderr and "% ground" not in done.stderr, done.stderr
    (tmp_path / "one.txt").write_text("1 2 3\n")
    done = aldpat("convert", "one.txt", "--out-format", "laz", "--odir", "out", cwd=tmp_path).ok()
    assert "(1 point)" in done.stderr, done.stderr
