"""separate-returns (manual task 2): first/last files, stop gap, UTM zone prefixes, fields."""

import laspy
import numpy as np
import pytest

from aldpat.tasks import get_task
from tests.tasks.prep_data import FMT, write_tape

# t x2 y2 z2 i2 x1 y1 z1 i1: first minus last = 0.5, 5.0, 12.0 and 4.99
ROWS = np.array([
    [1.0, 500001.00, 2800001.00, 10.00, 11, 500001.10, 2800001.10, 10.50, 21],
    [2.0, 500002.00, 2800002.00, 10.00, 12, 500002.10, 2800002.10, 15.00, 22],
    [3.0, 500003.00, 2800003.00, 10.00, 13, 500003.10, 2800003.10, 22.00, 23],
    [4.0, 500004.00, 2800004.00, 10.00, 14, 500004.10, 2800004.10, 14.99, 24],
])


@pytest.mark.parametrize("order", ["last-first", "first-last"])
def test_first_and_last_with_stop_gap(tmp_path, order):
    tape = write_tape(tmp_path / "s.txt", ROWS, order)
    report = get_task("separate-returns")([tape], order=order, stop_gap=5.0)
    assert report.exit_code == 0, report.results[0].error
    first = np.loadtxt(tmp_path / "s_1.txt")
    last = np.loadtxt(tmp_path / "s_2.txt")
    assert np.array_equal(first, ROWS[:, 5:9])
    # rows 0 and 3 are within the stop gap: their last return becomes the first (x, y, z, i)
    expected = ROWS[:, 1:5].copy()
    expected[[0, 3]] = ROWS[[0, 3], 5:9]
    assert np.array_equal(last, expected)


def test_fields_xyz_drops_intensity(tmp_path):
    tape = write_tape(tmp_path / "s.txt", ROWS)
    assert get_task("separate-returns")([tape], fields="xyz").exit_code == 0
    assert np.loadtxt(tmp_path / "s_1.txt").shape == (4, 3)


def zoned(zone: int) -> np.ndarray:
    rows = ROWS.copy()
    for c in (1, 5):
        rows[:, c] += zone * 1_000_000
    for c in (2, 6):
        rows[:, c] += zone * 10_000_000
    return rows


@pytest.mark.parametrize("setting", ["auto", "17"])
def test_utm_zone_prefix_is_stripped(tmp_path, setting):
    tape = write_tape(tmp_path / "z.txt", zoned(17))
    assert get_task("separate-returns")([tape], utm_zone=setting).exit_code == 0
    first = np.loadtxt(tmp_path / "z_1.txt")
    assert np.allclose(first[:, :2], ROWS[:, 5:7], atol=1e-6, rtol=0)
    assert (tmp_path / "z_1.txt").read_text().split()[0] == "500001.10"  # decimals kept


def test_utm_zone_none_and_auto_without_prefix_leave_coordinates(tmp_path):
    tape = write_tape(tmp_path / "z.txt", zoned(17))
    assert get_task("separate-returns")([tape], utm_zone="none").exit_code == 0
    assert np.allclose(np.loadtxt(tmp_path / "z_1.txt")[:, :2], zoned(17)[:, 5:7], atol=1e-6, rtol=0)
    plain = write_tape(tmp_path / "p.txt", ROWS)
    assert get_task("separate-returns")([plain], utm_zone="auto").exit_code == 0
    assert np.array_equal(np.loadtxt(tmp_path / "p_1.txt")[:, :2], ROWS[:, 5:7])


def test_wrong_zone_names_the_line(tmp_path):
    rows = zoned(17)
    rows[2, 1] -= 1_000_000  # zone 16 in x of the third record
    tape = write_tape(tmp_path / "z.txt", rows)
    report = get_task("separate-returns")([tape], utm_zone="auto")
    assert report.exit_code == 1
    assert "z.txt:3:" in report.results[0].error and "zone 17" in report.results[0].error
    report = get_task("separate-returns")([write_tape(tmp_path / "y.txt", zoned(17))], utm_zone="18")
    assert report.exit_code == 1 and "y.txt:1:" in report.results[0].error
    assert not (tmp_path / "y_1.txt").exists()


def test_bad_utm_zone_value_is_a_usage_error(tmp_path, runner, cli):
    tape = write_tape(tmp_path / "s.txt", ROWS)
    out = runner.invoke(cli, ["separate-returns", str(tape), "--utm-zone", "61"])
    assert out.exit_code == 2 and "utm_zone" in out.output


def test_a_nine_column_check(tmp_path):
    bad = tmp_path / "b.txt"
    np.savetxt(bad, ROWS[:, :5], fmt=" ".join(FMT.split()[:5]))
    report = get_task("separate-returns")([bad])
    assert report.exit_code == 1 and "expected 9 columns" in report.results[0].error


def test_last_returns_in_their_own_folder(tmp_path):
    tape = write_tape(tmp_path / "s.txt", ROWS)
    report = get_task("separate-returns")([tape], odir=str(tmp_path / "first"), last_odir=str(tmp_path / "last"))
    assert report.exit_code == 0, report.results[0].error
    assert (tmp_path / "first" / "s_1.txt").exists() and (tmp_path / "last" / "s_2.txt").exists()
    assert not (tmp_path / "first" / "s_2.txt").exists()


def test_a_gap_of_exactly_the_stop_gap_is_decided_at_the_tapes_precision(tmp_path):
    # first minus last is exactly 5.00 m as written in every row; 8.04 - 3.04 is 4.999999999999999
    # in binary, 10.00 - 5.00 is 5.0: both must keep their own last return
    rows = np.array([
        [1.0, 500001.00, 2800001.00, 3.04, 11, 500001.10, 2800001.10, 8.04, 21],
        [2.0, 500002.00, 2800002.00, 5.00, 12, 500002.10, 2800002.10, 10.00, 22],
        [3.0, 500003.00, 2800003.00, 3.29, 13, 500003.10, 2800003.10, 8.29, 23],
    ])
    tape = write_tape(tmp_path / "s.txt", rows)
    assert get_task("separate-returns")([tape], stop_gap=5.0).exit_code == 0
    np.testing.assert_array_equal(np.loadtxt(tmp_path / "s_2.txt"), rows[:, 1:5])


def test_returns_further_down_a_tape_keep_their_decimals(tmp_path):
    """The decimals of a tape's first lines were copied once at the start: coordinates further
    down with more (500999.125, 10.9985) were written as 500999.12 and 11.00, to text and LAS."""
    lines = [f"{k + 1.0:.1f} {500001 + k:.2f} 2800001.00 {10 + k * 0.01:.2f} 11 {500001 + k:.2f} 2800001.10 "
             f"{10.5 + k * 0.01:.2f} 21" for k in range(300)]
    lines.append("301.0 500999.125 2800001.00 10.9985 11 500999.125 2800001.10 11.4985 21")
    tape = tmp_path / "t.txt"
    tape.write_text("\n".join(lines) + "\n")
    assert get_task("separate-returns")([tape], stop_gap=0.0).exit_code == 0
    assert (tmp_path / "t_1.txt").read_text().splitlines()[-1] == "500999.125 2800001.10 11.4985 21"
    assert (tmp_path / "t_2.txt").read_text().splitlines()[-1] == "500999.125 2800001.00 10.9985 11"
    out = tmp_path / "las"
    assert get_task("convert")([tape], tape=True, out_format="las", odir=str(out)).exit_code == 0
    las = laspy.read(out / "t.las")
    assert (float(las.x[-1]), float(las.z[-1]), float(las.z[-2])) == pytest.approx((500999.125, 10.9985, 11.4985),
                                                                                   abs=1e-9)
