"""The progress bar a user sees in a terminal: one step per job and one per chunk."""

from __future__ import annotations

import os
import pty
import re
import subprocess

from tests.cli.fresh import DATA, TEST_DATA, aldpat, aldpat_command


def in_a_terminal(*args, cwd) -> tuple[int, str]:
    """Run ``aldpat ARGS`` with a pseudo-terminal as stdin, stdout and stderr; what it drew."""
    master, slave = pty.openpty()
    proc = subprocess.Popen(aldpat_command() + [str(a) for a in args], stdin=slave, stdout=slave, stderr=slave,
                            cwd=cwd, close_fds=True)
    os.close(slave)
    drawn = b""
    while True:
        try:
            part = os.read(master, 65536)
        except OSError:  # the terminal closed with the process
            break
        if not part:
            break
        drawn += part
    os.close(master)
    return proc.wait(timeout=300), drawn.decode(errors="replace")


def test_the_bar_counts_the_chunks_of_one_file(tmp_path):
    code, drawn = in_a_terminal("filter", "pm", DATA / "samp24.txt", "--chunk", "20", "--window-series", "1,2,4,8",
                                "--low-outlier-reach", "4", "--odir", tmp_path, cwd=tmp_path)
    assert code == 0, drawn
    counts = set(re.findall(r"(\d+)/(\d+)", drawn))
    assert ("29", "29") in counts  # 28 chunks and their job: the bar's last refresh
    assert all(total == "29" for _, total in counts if total != "1")  # total 1 before the chunks are planned
    assert "Traceback" not in drawn


def test_a_worksheet_shows_each_jobs_bar(tmp_path):
    sheet = tmp_path / "chunks.toml"
    sheet.write_text(f'[[job]]\ntask = "filter"\nalgorithm = "pm"\ninputs = ["{DATA / "samp24.txt"}"]\n'
                     f'odir = "out"\nchunk = 20.0\nwindow_series = [1, 2, 4, 8]\nlow_outlier_reach = 4.0\n')
    code, drawn = in_a_terminal("run", sheet, cwd=tmp_path)
    assert code == 0, drawn
    assert ("29", "29") in set(re.findall(r"(\d+)/(\d+)", drawn))  # the job's 28 chunks and the job
    assert "job 1 filter pm: Done" in drawn


def passes_drawn(drawn: str, label: str) -> list[str]:
    """The passes a run of one job showed, in order (``label: pass`` lines of the bar)."""
    plain = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", drawn)
    seen: list[str] = []
    for m in re.finditer(rf"{re.escape(label)}: ([a-z +]+?)\s+━", plain):
        if not seen or seen[-1] != m.group(1):
            seen.append(m.group(1))
    return seen


def test_one_big_file_shows_its_passes_then_what_it_did(tmp_path):
    """A file read whole shows read, grid, filter, classify, write; a LAS/LAZ filtered in two
    streaming passes shows them as its two passes around the filter, with its points counted."""
    code, drawn = in_a_terminal("filter", "gapm", DATA / "samp24.txt", "--odir", tmp_path, cwd=tmp_path)
    assert code == 0, drawn
    assert passes_drawn(drawn, "filter gapm") == ["read", "grid", "filter", "classify", "write"]
    assert "0/1" not in drawn  # a run of one job does not count its one job
    assert re.search(r"samp24\.txt: 7,492 points, \d+\.\d % ground, \d+\.\d s -> \S*samp24_gapm\.txt", drawn)

    code, drawn = in_a_terminal("filter", "gapm", TEST_DATA / "fsite5_strip.laz", "--odir", tmp_path, cwd=tmp_path)
    assert code == 0, drawn
    assert passes_drawn(drawn, "filter gapm") == ["read + grid", "filter", "classify + write"]
    assert "20,643 of 20,643 points" in drawn


def test_without_a_terminal_no_bar_and_one_line_per_input_unless_quiet(tmp_path):
    done = aldpat("dtm", DATA / "samp24.txt", "--cell", "2", "--crs", "EPSG:32632", "--odir", tmp_path).ok()
    assert "━" not in done.stderr and done.stdout == ""
    assert re.fullmatch(r"samp24\.txt: 7,492 points, \d+\.\d % ground -> [\d,]+ nodes \(\d+\.\d % blank\), "
                        r"\d+\.\d s -> \S*samp24_dtm\.tif\n", done.stderr), done.stderr
    quiet = aldpat("dtm", DATA / "samp24.txt", "--cell", "2", "--crs", "EPSG:32632", "--odir", tmp_path, "--overwrite",
                   "-q").ok()
    assert quiet.stderr == ""
