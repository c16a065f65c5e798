"""``-j 2`` writes byte for byte what ``-j 1`` writes, for every registered task.

Each task runs twice in fresh processes, on two inputs of small real data, into two folders;
every output but the logs (which hold times) must be identical, and so must what info and
evaluate print.
"""

from __future__ import annotations

import filecmp
import shutil
from pathlib import Path

import numpy as np
import pytest

from aldpat.tasks import TASKS
from tests.cli.fresh import DATA, TEST_DATA, aldpat


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> dict[str, list[Path]]:
    root = tmp_path_factory.mktemp("parallel")
    rows = np.loadtxt(DATA / "samp24.txt")
    x0, y0 = rows[:, 0].min(), rows[:, 1].min()
    middle = np.median(rows[:, 0])
    points = []
    for k, part in enumerate([rows[rows[:, 0] < middle], rows[rows[:, 0] >= middle]]):  # west and east halves
        path = root / f"part{k}.txt"
        np.savetxt(path, part, fmt=["%.2f", "%.2f", "%.2f", "%d"])
        points.append(path)
    tapes = [shutil.copy(DATA / "fsite5_tape.txt", root / f"tape{k}.txt") for k in range(2)]
    prep = root / "prep"
    aldpat("separate-returns", *tapes, "--odir", prep).ok()
    firsts = sorted(prep.glob("*_1.txt"))
    aldpat("strip-boundary", *firsts, "--cell-width", "2", "--cell-height", "2", "--odir", prep).ok()
    bounds = sorted(prep.glob("*_Bound.txt"))
    aldpat("merge-boundary", *bounds, "--output", prep / "merged.txt").ok()
    aldpat("grid", *points, "--cell", "4", "--odir", prep).ok()
    geoid = shutil.copy(TEST_DATA / "egm96_15_nga1.gtx", root / "geoid.gtx")
    import pyproj

    e, n = pyproj.Transformer.from_crs("EPSG:4326", "EPSG:32615", always_xy=True).transform(-90.22, 38.63)
    heights = []
    for k in range(2):
        path = root / f"h{k}.txt"
        np.savetxt(path, [[e + k, n, 180.25, 12], [e + 20, n + 10 + k, 181.5, 40]], fmt=["%.2f", "%.2f", "%.2f", "%d"])
        heights.append(path)
    (root / "polygon.txt").write_text(f"{x0},{y0}\n{x0 + 150},{y0}\n{x0 + 150},{y0 + 150}\n{x0},{y0 + 150}\n")
    return {"points": points, "tapes": [Path(t) for t in tapes], "firsts": firsts, "bounds": bounds,
            "merged": [prep / "merged.txt"], "grids": sorted(prep.glob("*.grd")), "heights": heights,
            "geoid": [Path(geoid)], "polygon": [root / "polygon.txt"], "reference": [DATA / "samp24.txt"]}


# task -> (inputs key, extra arguments with {key} placeholders)
ARGS: dict[str, tuple[str, list[str]]] = {
    "convert": ("points", ["--out-format", "laz"]),
    "dtm": ("points", ["--cell", "2", "--crs", "EPSG:32632", "--mosaic", "{odir}/dtm.vrt"]),  # halves: neighbours
    "evaluate": ("points", ["--reference", "{reference}", "--map", "{odir}/{{stem}}.png"]),
    "grd2bin": ("grids", ["--crs", "EPSG:32632"]),
    "grid": ("points", ["--cell", "3"]),
    "info": ("points", ["--json"]),
    "merge": ("points", ["--output", "{odir}/merged.txt"]),
    "merge-boundary": ("bounds", ["--output", "{odir}/merged.txt"]),
    "ortho-height": ("heights", ["--crs", "15N", "--geoid", "{geoid}"]),
    "polygon-extract": ("points", ["--polygon", "{polygon}"]),
    "preview": ("points", ["--size", "200"]),
    "separate-returns": ("tapes", []),
    "shapefile": ("merged", ["--output", "{odir}/strips.shp", "--crs", "EPSG:32632"]),
    "split-tape": ("tapes", []),
    "strip-boundary": ("firsts", ["--cell", "2"]),
    "thin": ("points", ["--cell", "2"]),
    "tile": ("points", ["--width", "50", "--height", "50", "--buffer", "5"]),
}


def _args(key: str, inputs: dict, odir: Path) -> list:
    source, extra = ARGS.get(key, ("points", ["--result", "classified", "--marks"]))
    values = {k: v[0] for k, v in inputs.items()} | {"odir": odir}
    words = [w.format(**values) for w in extra]
    writes = TASKS[key].writes_outputs
    return [*key.split(), *inputs[source], *words, *(["--odir", odir] if writes else [])]


def test_every_task_has_arguments_here():
    assert {k for k in TASKS if not k.startswith("filter ")} <= set(ARGS)


@pytest.mark.parametrize("key", sorted(TASKS))
def test_two_workers_write_what_one_writes(inputs, tmp_path, key):
    one, two = tmp_path / "j1", tmp_path / "j2"
    first = aldpat(*_args(key, inputs, one), "-j", "1").ok()
    second = aldpat(*_args(key, inputs, two), "-j", "2").ok()
    assert first.stdout.replace(str(one), "") == second.stdout.replace(str(two), "")
    if not TASKS[key].writes_outputs and not one.exists():  # evaluate writes only with --map
        return
    names = sorted(str(p.relative_to(one)) for p in one.rglob("*") if p.is_file() and p.suffix != ".log")
    assert names == sorted(str(p.relative_to(two)) for p in two.rglob("*") if p.is_file() and p.suffix != ".log")
    assert names, f"{key} wrote nothing"
    for name in names:
        a, b = one / name, two / name
        if a.name == "tile_parameter.txt":  # names its tiles by absolute path (manual Fig. 8)
            assert a.read_text().replace(str(one), "") == b.read_text().replace(str(two), ""), name
        else:
            assert filecmp.cmp(a, b, shallow=False), f"{key}: {name} differs between -j 1 and -j 2"


def test_a_worker_s_messages_are_the_parent_s(tmp_path):
    """A warning logged in a ``-j 2`` worker went to Python's last-resort handler: without
    "aldpat: ", printed under ``-q``, and a file name's terminal escape reached the terminal."""
    names = ["wide.txt", "red\x1b[31m.txt"]
    for name in names:
        rows = [f"{500000 + k * 0.123:.3f} {4000000 + k * 0.456:.3f} {100 + k * 0.01:.3f}" for k in range(20)]
        (tmp_path / name).write_text("\n".join([*rows, "-9000000.000 9000000.000 0.000"]) + "\n")  # a stray point
    args = ["convert", *[tmp_path / n for n in names], "--out-format", "laz", "--crs", "32617", "-j", "2",
            "--odir", tmp_path / "out", "--overwrite"]
    done = aldpat(*args).ok()
    coarser = [ln for ln in done.stderr.splitlines() if "coarser than the 3 decimals" in ln]
    assert len(coarser) == 4 and all(ln.startswith("aldpat: ") for ln in coarser), done.stderr
    assert "\x1b" not in done.stderr
    assert aldpat(*args, "-q").ok().stderr == ""
