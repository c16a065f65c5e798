"""Throughput and peak memory of the streaming data-preparation tasks.

    python bench/bench_prep.py                  # 1 M and 10 M points (files under bench/_work/prep/)
    python bench/bench_prep.py --sizes 1 10 50  # 50 M: about 15 GB of temporary files, ~15 min

Synthetic data at a constant density of 2.5 points/m^2 (the area grows with the size, as a real
project does): an ``x y z i`` point file and a 9-column ALTM tape (``t x2 y2 z2 i2 x1 y1 z1 i1``,
a 120 s GPS-time gap every million shots). Each task runs in a fresh process
(``bench/_measure.py``) and reports points/second and peak resident memory; the plain streamed
read of the same file is the floor a streaming task cannot beat. Outputs are deleted after each
measurement. Not part of the test suite.

Run on 2026-11-21, 2 cores shared with other benchmarks (load average 4-5, so every rate,
the read floor included, is 2-4x below a quiet machine; compare each task with its floor):

    operation                     1 M: s  peak     10 M: s  peak     50 M: s  peak
    read x y z i (floor)            1.0  142 MiB      8.4  298 MiB     28.0  313 MiB
    read 9-column tape (floor)      1.1  239 MiB     15.7  527 MiB     50.9  542 MiB
    split-tape                      2.7  360 MiB     17.4  812 MiB    101.0  904 MiB
    separate-returns                5.5  331 MiB     25.8  648 MiB    217.9  661 MiB
    tile 500 m, 20 m buffer         9.8  362 MiB     26.1  701 MiB    216.2  770 MiB
    thin 1 m lowest                 8.5  252 MiB     33.1  505 MiB    104.5  522 MiB
    polygon-extract (comb)          7.2  298 MiB     24.5  774 MiB     47.2  775 MiB

A re-run at 10 M when the load had fallen to about 2.5 (s, peak): read x y z i 2.9 (298 MiB),
read tape 5.6 (527 MiB), split-tape 11.8 (812 MiB), separate-returns 15.7 (648 MiB), tile 15.4
(637 MiB), thin 14.1 (504 MiB), polygon-extract 8.0 (774 MiB): 0.65-1.25 M points/s, two to five
times the bare read, the rest being the writing of the outputs (split-tape writes every byte
back, tile writes each point plus its buffer copies, separate-returns formats two files).

Peak memory is set by the 2-million-row chunk (plus, for split-tape, tile and polygon-extract,
the raw lines of that chunk and one 64 MiB read block, whose alignment with the chunks moves the
peak by up to ~130 MiB): it does not grow with the number of points.
"""

from __future__ import annotations

import argparse
import math
import shutil
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import measure, mib, write_synthetic_points

REPO = Path(__file__).resolve().parents[1]
WORK = Path(__file__).resolve().parent / "_work" / "prep"
DENSITY = 2.5  # points per m^2
X0, Y0 = 500000.0, 5400000.0


def side(n: int) -> float:
    return math.sqrt(n / DENSITY)


def make_points(path: Path, n: int) -> None:
    s = side(n)
    write_synthetic_points(path, n, (X0, X0 + s), (Y0, Y0 + s))


def make_tape(path: Path, n: int) -> None:
    if path.exists():
        return
    rng = np.random.default_rng(1)
    s = side(n)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".part")
    t = 300000.0
    with open(tmp, "w") as fh:
        for start in range(0, n, 1_000_000):
            m = min(1_000_000, n - start)
            times = t + 1e-4 * np.arange(m)
            t = times[-1] + 120.0  # the laser is off between strips
            x, y = X0 + rng.uniform(0, s, m), Y0 + rng.uniform(0, s, m)
            z2 = rng.uniform(200, 400, m)
            z1 = z2 + rng.exponential(3.0, m)
            block = np.column_stack([times, x, y, z2, rng.integers(0, 255, m), x + 0.01, y + 0.01, z1,
                                     rng.integers(0, 255, m)])
            fh.write(("%.4f %.2f %.2f %.2f %d %.2f %.2f %.2f %d\n" * m) % tuple(block.ravel().tolist()))
    tmp.rename(path)


def write_polygon(path: Path, n: int) -> None:
    """A concave 12-vertex polygon (a comb) over about half of the area."""
    s = side(n)
    pts = [(0.05, 0.05), (0.95, 0.05), (0.95, 0.95), (0.8, 0.95), (0.8, 0.3), (0.65, 0.3), (0.65, 0.95),
           (0.5, 0.95), (0.5, 0.3), (0.35, 0.3), (0.35, 0.95), (0.05, 0.95)]
    path.write_text("".join(f"{X0 + a * s:.2f},{Y0 + b * s:.2f}\n" for a, b in pts))


def task_code(task: str, inputs: str, **kwargs) -> str:
    return (f"import sys; sys.path.insert(0, {str(REPO)!r})\n"
            "from aldpat.tasks import get_task\n"
            f"r = get_task({task!r})([{inputs!r}], **{kwargs!r})\n"
            "assert r.exit_code == 0, [x.error for x in r.results]\n"
            "result = dict(outputs=len(r.outputs), written=sum(w.count or 0 for w in r.outputs))")


def read_code(path: Path, **kwargs) -> str:
    return (f"import sys; sys.path.insert(0, {str(REPO)!r})\n"
            "from aldpat.io.registry import open_points\n"
            f"n = sum(len(c) for c in open_points({str(path)!r}, **{kwargs!r}).chunks())\nresult = dict(n=n)")


def row(name: str, n: int, r: dict) -> str:
    return (f"{name:34} {n:>11,} {r['seconds']:8.1f} s {n / r['seconds'] / 1e6:7.2f} M pts/s "
            f"{mib(r['peak_bytes']):>10}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1, 10], help="millions of points")
    ap.add_argument("--only", nargs="+", default=None, help="tasks to run (default: all)")
    args = ap.parse_args()
    print(f"{'operation':34} {'points':>11} {'time':>10} {'rate':>15} {'peak RSS':>10}", flush=True)
    for size in args.sizes:
        n = size * 1_000_000
        pts, tape = WORK / f"points_{size}m.txt", WORK / f"tape_{size}m.txt"
        make_points(pts, n)
        make_tape(tape, n)
        poly = WORK / f"comb_{size}m.txt"
        write_polygon(poly, n)
        out = WORK / f"out_{size}m"
        runs = [
            ("read x y z i (floor)", read_code(pts)),
            ("read 9-column tape (floor)", read_code(tape, layout="altm9")),
            ("split-tape", task_code("split-tape", str(tape), odir=str(out))),
            ("separate-returns", task_code("separate-returns", str(tape), odir=str(out))),
            ("tile 500 m, 20 m buffer", task_code("tile", str(pts), odir=str(out), width=500.0, height=500.0,
                                                   buffer=20.0)),
            ("thin 1 m lowest", task_code("thin", str(pts), odir=str(out), cell=1.0)),
            ("polygon-extract (comb)", task_code("polygon-extract", str(pts), odir=str(out), polygon=str(poly))),
        ]
        for name, code in runs:
            if args.only and not any(o in name for o in args.only):
                continue
            shutil.rmtree(out, ignore_errors=True)
            print(row(name, n, measure(code)), flush=True)
        shutil.rmtree(out, ignore_errors=True)


if __name__ == "__main__":
    main()
