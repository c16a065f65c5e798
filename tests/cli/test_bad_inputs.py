"""The bad-input corpus through the real CLI, against every command that reads points.

For every refused case: exit status 1 (2 for a usage error), exactly one stderr line naming the
file (and line) and what is wrong, no traceback, no output and no temporary file for it, and
the good input of the same command still processed. For every accepted case: every point
processed, none dropped or invented.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rasterio

from aldpat.core.interpolate import METHODS
from aldpat.filters.registry import FILTERS
from aldpat.io.atomic import glob_escape
from aldpat.tasks.grid import SURFACE_METHODS
from tests.cli.corpus import Case, degenerate_cases, las_cases, text_cases
from tests.cli.fresh import aldpat, aldpat_batch, count_points, leftovers

GEOID = "geoid.gtx"


def write_world_geoid(path: Path, undulation: float = -30.0) -> Path:
    """A coarse GTX geoid of the whole world with one value: enough for ortho-height to run."""
    rows, cols = 19, 37  # 10-degree nodes
    header = struct.pack(">4d2i", -90.0, -180.0, 10.0, 10.0, rows, cols)
    path.write_bytes(header + np.full(rows * cols, undulation, dtype=">f4").tobytes())
    return path


@pytest.fixture(scope="module")
def corpus(tmp_path_factory) -> dict:
    root = tmp_path_factory.mktemp("corpus")
    points = text_cases(root / "points") + las_cases(root / "las")
    tapes = text_cases(root / "tapes", "altm9")
    degenerate = degenerate_cases(root / "few")
    degenerate_tapes = degenerate_cases(root / "few tapes", "altm9")
    (root / "polygon.txt").write_text("499990,3999990\n500070,3999990\n500070,4000070\n499990,4000070\n")
    write_world_geoid(root / GEOID)
    good = next(c for c in points if c.name == "byte-order mark")
    rows = np.loadtxt(good.path, encoding="utf-8-sig")
    rows[:, 3] = np.arange(len(rows)) % 2  # ISPRS labels: 0 bare earth, 1 object
    np.savetxt(root / "reference.txt", rows, fmt=["%.2f", "%.2f", "%.2f", "%d"])
    return {"root": root, "points": points, "tapes": tapes, "few": degenerate, "few tapes": degenerate_tapes}


# command -> (extra arguments, corpus layout, output suffix of an input's main output or None)
COMMANDS: dict[str, tuple[list[str], str, str | None]] = {
    "info": ([], "points", None),
    "convert": (["--out-format", "laz"], "points", ""),
    "grid": (["--cell", "2"], "points", ""),
    "dtm": (["--cell", "2"], "points", "_dtm"),
    "thin": (["--cell-width", "2", "--cell-height", "2"], "points", "_thin"),
    "polygon-extract": (["--polygon", "{root}/polygon.txt"], "points", "_poly"),
    "strip-boundary": (["--cell-width", "4", "--cell-height", "4"], "points", "_Bound"),
    "ortho-height": (["--crs", "17N", "--geoid", "{root}/" + GEOID], "points", "_Ortho"),
    "evaluate": (["--reference", "{root}/reference.txt"], "points", None),
    "split-tape": ([], "tapes", "_strip01"),
    "separate-returns": ([], "tapes", "_1"),
    **{f"filter {algo}": (["--result", "both"], "points", f"_{algo}") for algo in sorted(FILTERS)},
}


def _args(command: str, corpus: dict, reference: Path) -> list[str]:
    extra, _, _ = COMMANDS[command]
    return command.split() + [a.format(root=corpus["root"], reference=reference) for a in extra]


def _odir(command: str, folder: Path) -> list:
    """``--odir`` for the commands that write files (info and evaluate only print)."""
    return [] if command in ("info", "evaluate") else ["--odir", folder]


def _outputs_of(folder: Path, case: Case) -> list[Path]:
    return [p for p in folder.glob(f"{glob_escape(case.path.stem)}*") if p.suffix != ".log"]


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_refused_inputs_fail_alone_with_one_line(corpus, tmp_path, command):
    _, layout, _ = COMMANDS[command]
    cases = corpus[layout]
    # a LAS of no points is a valid file: info reports its header (with a warning), where every
    # command that reads its points refuses it
    reported = [c for c in cases if command == "info" and c.name == "0-point LAS"]
    refused = [c for c in cases if c.refused and c not in reported]
    accepted = [c for c in cases if not c.refused]
    good = accepted[0]  # the byte-order-mark file: accepted, so it must come out whole
    out = tmp_path / "out"
    done = aldpat(*_args(command, corpus, good.path), *[c.path for c in refused], *[c.path for c in reported],
                  good.path, *_odir(command, out))
    assert done.returncode == 1, done.stderr
    lines = [ln for ln in done.stderr.splitlines() if ln.strip()]
    for case in refused:
        hits = [ln for ln in lines if re.search(case.refused, ln)]
        assert len(hits) == 1, f"{case.name}: expected one line matching {case.refused!r} in\n{done.stderr}"
        if out.exists():
            assert _outputs_of(out, case) == [], f"{case.name}: an output was written for a refused input"
    for case in reported:
        assert f"aldpat: {case.path.name}: holds no points" in lines, done.stderr
    assert f"{len(refused)} of {len(refused) + len(reported) + 1} inputs failed" in done.stderr
    if COMMANDS[command][2] is not None:
        assert _outputs_of(out, good), f"{command}: the good input was not processed\n{done.stderr}"
    assert leftovers(tmp_path) == [] and leftovers(corpus["root"]) == []


@pytest.mark.parametrize("command", sorted(c for c in COMMANDS if COMMANDS[c][1] == "points"))
def test_accepted_inputs_keep_every_point(corpus, tmp_path, command):
    accepted = [c for c in corpus["points"] if not c.refused]
    out = tmp_path / "out"
    extra = ["--json"] if command in ("info", "evaluate") else []
    done = aldpat(*_args(command, corpus, accepted[0].path), *[c.path for c in accepted], *_odir(command, out), *extra)
    assert done.returncode == 0, done.stderr
    if command == "info":
        counts = [json.loads(line)["count"] for line in done.stdout.splitlines() if line.strip()]
        assert counts == [c.count for c in accepted]
    elif command == "convert":
        for case in accepted:
            assert count_points(out / f"{case.path.stem}.laz") == case.count, case.name
    elif command.startswith("filter"):
        algo = command.split()[1]
        for case in accepted:
            ext = case.path.suffix
            ground = count_points(out / f"{case.path.stem}_{algo}{ext}")
            objects = count_points(out / f"{case.path.stem}_{algo}_nt{ext}")
            assert ground + objects == case.count, case.name
    elif command == "polygon-extract":
        for case in accepted:  # the polygon holds every corpus point
            assert count_points(out / f"{case.path.stem}_poly{case.path.suffix}") == case.count, case.name
    elif command == "ortho-height":
        for case in accepted:
            assert count_points(out / f"{case.path.stem}_Ortho{case.path.suffix}") == case.count, case.name
    assert leftovers(tmp_path) == []


def test_accepted_tapes_keep_every_shot(corpus, tmp_path):
    accepted = [c for c in corpus["tapes"] if not c.refused]
    aldpat("separate-returns", *[c.path for c in accepted], "--odir", tmp_path).ok()
    for case in accepted:
        assert count_points(tmp_path / f"{case.path.stem}_1.txt") == count_points(tmp_path / f"{case.path.stem}_2.txt") == case.count
    aldpat("split-tape", *[c.path for c in accepted], "--odir", tmp_path / "strips").ok()
    for case in accepted:
        strips = (tmp_path / "strips").glob(f"{glob_escape(case.path.stem)}_strip*.txt")
        assert sum(count_points(p) for p in strips) == case.count


# Tasks that need more than a point or two: they refuse such files with one line each.
NEEDS_SEVERAL = {"grid": "needs at least 3 distinct points not all on one line",
                 "dtm": "a DTM's TIN of the ground points needs at least 3 distinct points",
                 "strip-boundary": "too few occupied cells for a boundary",
                 # not a point of these files is in the corpus's reference: nothing to score
                 "evaluate": "matches a point of reference.txt"}


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_one_point_and_identical_points(corpus, tmp_path, command):
    _, layout, _ = COMMANDS[command]
    cases = corpus["few tapes" if layout == "tapes" else "few"]
    done = aldpat(*_args(command, corpus, cases[1].path), *[c.path for c in cases], *_odir(command, tmp_path))
    if command in NEEDS_SEVERAL:
        assert done.returncode == 1, done.stderr
        for case in cases:
            named = [ln for ln in done.stderr.splitlines() if case.path.name in ln]
            assert len(named) == 1 and NEEDS_SEVERAL[command] in named[0], done.stderr
            assert _outputs_of(tmp_path, case) == []
    else:
        assert done.returncode == 0, done.stderr
        if command.startswith("filter"):
            algo = command.split()[1]
            for case in cases:
                total = count_points(tmp_path / f"{case.path.stem}_{algo}.txt") + \
                    count_points(tmp_path / f"{case.path.stem}_{algo}_nt.txt")
                assert total == case.count, case.name
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("method", sorted(METHODS))
def test_every_grid_method_on_one_point(corpus, tmp_path, method):
    one = corpus["few"][0].path
    done = aldpat("grid", one, "--method", method, "--odir", tmp_path)
    if method in SURFACE_METHODS:
        assert done.returncode == 1
        assert sum("needs at least 3 distinct points" in ln for ln in done.stderr.splitlines()) == 1
        assert not (tmp_path / f"one_{method}.grd").exists()
    else:
        assert done.returncode == 0, done.stderr
        with rasterio.open(tmp_path / f"one_{method}.grd") as ds:
            assert ds.read(1, masked=True).count() >= 1  # the node at the point has its height


@pytest.mark.parametrize("command", ["info", "filter pm", "tile"])
def test_a_folder_without_point_files_and_a_glob_matching_nothing(corpus, tmp_path, command):
    empty = tmp_path / "no points here"
    empty.mkdir()
    (empty / "notes.doc").write_text("not a point file")
    good = next(c for c in corpus["points"] if c.name == "byte-order mark")
    done = aldpat(*command.split(), empty, str(tmp_path / "nothing_*.txt"), good.path, *_odir(command, tmp_path / "out"))
    assert done.returncode == 1
    assert sum("no points here: folder holds no point files" in ln for ln in done.stderr.splitlines()) == 1
    assert sum("nothing_*.txt: no file matches this pattern" in ln for ln in done.stderr.splitlines()) == 1
    if command != "info":
        assert any((tmp_path / "out").iterdir())  # the good input was still processed


def test_tile_refuses_the_whole_set_when_one_strip_is_bad(corpus, tmp_path):
    """Tiles combine every input: a bad strip stops the run before any tile is written, so no tile
    ever silently lacks part of a strip."""
    good = next(c for c in corpus["points"] if c.name == "byte-order mark")
    refused = [c for c in corpus["points"] if c.refused]
    runs = aldpat_batch([{"args": ["tile", good.path, case.path, "--width", "30", "--height", "30", "--odir",
                                   tmp_path / case.path.stem], "cwd": tmp_path} for case in refused])
    for case, done in zip(refused, runs, strict=True):
        out = tmp_path / case.path.stem
        assert done["status"] == 1, (case.name, done["stderr"])
        assert sum(bool(re.search(case.refused, ln)) for ln in done["stderr"].splitlines()) == 1, done["stderr"]
        assert not out.exists() or list(out.iterdir()) == [], case.name
    accepted = [c for c in corpus["points"] if not c.refused]
    aldpat("tile", *[c.path for c in accepted], "--width", "30", "--height", "30", "--odir", tmp_path / "ok").ok()
    tiles = [p for p in (tmp_path / "ok").glob("tile_*_*") if p.suffix != ".log"]
    rows = np.loadtxt(tmp_path / "ok" / "tile_parameter.txt", usecols=(1, 2, 3, 4))
    assert len(rows) == len(tiles) > 0
    assert leftovers(tmp_path) == []


def _mount_tmpfs(folder: Path, options: str) -> bool:
    folder.mkdir(parents=True, exist_ok=True)
    if os.geteuid() != 0 or not shutil.which("mount"):
        return False
    proc = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(folder)], capture_output=True,
                          check=False)
    return proc.returncode == 0


def _umount(folder: Path) -> None:
    subprocess.run(["umount", str(folder)], capture_output=True, check=False)


# Injected ENOSPC where no tmpfs can be mounted: every write to a temporary output fails, and the
# file system reports no free space, as a full one does.
ENOSPC_RUNNER = """
import builtins, collections, errno, io, os, shutil, sys
Usage = collections.namedtuple("Usage", "total used free")
shutil.disk_usage = lambda path: Usage(1 << 30, 1 << 30, 0)
real_open = io.open
class Full(io.FileIO):
    def write(self, b):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), self.name)
def full_open(file, mode="r", *a, **k):
    if ".aldpat-tmp" in str(file) and any(m in mode for m in "wax"):
        return io.BufferedWriter(Full(file, "w"))
    return real_open(file, mode, *a, **k)
builtins.open = io.open = full_open
sys.argv = ["aldpat"] + sys.argv[1:]
from aldpat.cli.main import main
main()
"""


@pytest.mark.parametrize("command, extra, out_name", [
    ("convert", ["--out-format", "laz"], "big.laz"),
    ("filter pm", [], "big_pm.txt"),
    ("grid", ["--cell", "0.25"], "big_linear.grd"),
    ("tile", ["--width", "20", "--height", "20", "--buffer", "5"], "tile_parameter.txt"),
])
def test_a_full_disk_names_the_output_and_leaves_nothing(tmp_path, command, extra, out_name):
    rng = np.random.default_rng(0)
    big = tmp_path / "big.txt"
    np.savetxt(big, np.c_[rng.uniform(0, 100, 40000), rng.uniform(0, 100, 40000), rng.uniform(0, 5, 40000)],
               fmt="%.3f")
    full = tmp_path / "full"
    mounted = _mount_tmpfs(full, "size=64k")
    try:
        args = [*command.split(), big, *extra, "--odir", full]
        if mounted:
            done = aldpat(*args)
        else:
            proc = subprocess.run([sys.executable, "-c", ENOSPC_RUNNER, *map(str, args)], capture_output=True,
                                  text=True, check=False)
            done = type("Done", (), {"returncode": proc.returncode, "stderr": proc.stderr})()
            assert "Traceback" not in proc.stderr
        assert done.returncode == 1
        # the disk filling up while writing, or (a grid, whose size is known first) refused before
        lines = [ln for ln in done.stderr.splitlines() if "no space left on device" in ln or "of disk in" in ln]
        assert len(lines) == 1 and (out_name in lines[0] or str(full) in lines[0]), done.stderr
        assert "internal error" not in done.stderr, done.stderr
        assert [p.name for p in full.iterdir()] == [] or all(p.suffix == ".log" for p in full.iterdir())
    finally:
        if mounted:
            _umount(full)


def test_a_read_only_output_folder(tmp_path, corpus):
    good = next(c for c in corpus["points"] if c.name == "byte-order mark")
    folder = tmp_path / "ro"
    mounted = _mount_tmpfs(folder, "ro,size=64k")
    if not mounted:
        folder.chmod(0o555)
    try:
        done = aldpat("filter", "pm", good.path, "--odir", folder)
        assert done.returncode == 1
        line = [ln for ln in done.stderr.splitlines() if str(folder) in ln]
        assert len(line) == 1 and ("not writable" in line[0] or "read-only" in line[0]), done.stderr
        assert list(folder.iterdir()) == []
    finally:
        if mounted:
            _umount(folder)
        else:
            folder.chmod(0o755)


@pytest.mark.parametrize("args, message", [
    (["filter", "pm", "{good}", "--window-series", "3,2"], "window_series: half windows must be strictly ascending"),
    (["filter", "pm", "{good}", "--cell", "0"], "cell"),
    (["grid", "{good}", "--bounds", "10", "10", "0", "0"], "bounds: maximum must exceed minimum"),
    (["thin", "{good}", "--cell", "-1"], "cell: -1 is out of range"),
    (["thin", "{good}", "--cell-width", "-1"], "cell: -1 is out of range"),  # the earlier name, renamed
    (["tile", "{good}", "--width", "0"], "width"),
    (["separate-returns", "{good}", "--utm-zone", "99"], "utm_zone"),
    (["convert", "{good}", "-j", "-1"], "jobs"),
    (["evaluate", "{good}"], "reference: required"),
])
def test_bad_parameter_combinations_are_usage_errors(corpus, tmp_path, args, message):
    good = next(c for c in corpus["points"] if c.name == "byte-order mark")
    done = aldpat(*[a.format(good=good.path) for a in args], *_odir(args[0], tmp_path))
    assert done.returncode == 2, done.stderr
    lines = [ln for ln in done.stderr.splitlines() if ln.strip()]
    assert len([ln for ln in lines if message in ln]) >= 1 and len(lines) <= 2, done.stderr
    assert [p for p in tmp_path.iterdir()] == []
