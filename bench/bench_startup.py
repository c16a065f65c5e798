"""What every ``aldpat`` command costs before and after its work: start-up and exit, on a small file.

    python bench/bench_startup.py                       # 10 runs of each command
    python bench/bench_startup.py --against 5b81c3c     # and the package of that revision, runs alternating

Each row is a command users type, on ``tests/data/fsite5_strip.laz`` (20,643 points, in the
repository), timed in a fresh process: ``aldpat --version`` (the imports and the exit alone),
``aldpat info``, ``aldpat filter gapm`` (the compiled loops loaded from numba's cache) and
``aldpat grid``. With ``--against REV`` the package of REV (extracted under ``bench/_work/`` as
``bench_pdal.py`` does) runs each command right after this tree's run of it, so that the machine's
drift falls on both alike; the table gives the median and the least of each, and the median
difference of the pairs. A batch of tiles, a test suite and a notebook's shell calls pay these
costs once per command.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(HERE))

from bench_pdal import WORK, aldpat_env, load, revision_tree

STRIP = REPO / "tests" / "data" / "fsite5_strip.laz"
ROWS = {
    "version": ["--version"],
    "info": ["info", "{strip}"],
    "filter-gapm": ["filter", "gapm", "{strip}", "--result", "classified", "--odir", "{odir}", "--overwrite", "-q"],
    "grid": ["grid", "{strip}", "--cell", "1", "--odir", "{odir}", "--overwrite", "-q"],
}
LABELS = {"version": "aldpat --version", "info": "aldpat info", "filter-gapm": "aldpat filter gapm",
          "grid": "aldpat grid"}


def wall(args: list[str], env: dict, odir: Path) -> float:
    """Seconds of one fresh ``python -m aldpat ARGS`` (from ``bench/_work``: the current folder's
    package would be imported whatever PYTHONPATH says)."""
    cmd = [sys.executable, "-m", "aldpat", *(a.format(strip=STRIP, odir=odir) for a in args)]
    start = time.perf_counter()
    done = subprocess.run(cmd, env=env, cwd=WORK, capture_output=True, text=True, check=False)
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} -> {done.returncode}\n{done.stderr[-2000:]}")
    return seconds


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=10, help="runs of each command (default 10)")
    ap.add_argument("--against", metavar="REV", help="also the package of git revision REV, runs alternating")
    ap.add_argument("--rows", nargs="+", choices=tuple(ROWS), default=list(ROWS))
    args = ap.parse_args()

    WORK.mkdir(parents=True, exist_ok=True)
    odir = WORK / "out_startup"
    shutil.rmtree(odir, ignore_errors=True)
    trees = {"this tree": aldpat_env(REPO)}
    if args.against:
        tree, sha = revision_tree(args.against)
        trees[sha] = aldpat_env(tree)
    for env in trees.values():  # a first run compiles what is not cached yet: not timed
        for row in args.rows:
            wall(ROWS[row], env, odir)

    commit = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True, check=False).stdout.strip()
    print(f"# {STRIP.name}, {args.runs} runs of each command, {os.cpu_count()} cores; commit {commit}; "
          f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; load before {load()}")
    names = list(trees)
    header = " | ".join(f"{n}: median | least" for n in names)
    print(f"\n| command | {header} |" + (" median of the pairs' differences |" if len(names) == 2 else ""))
    print("|---|" + "---|---|" * len(names) + ("---|" if len(names) == 2 else ""))
    for row in args.rows:
        times: dict[str, list[float]] = {n: [] for n in names}
        for _ in range(max(1, args.runs)):
            for name in names:
                times[name].append(wall(ROWS[row], trees[name], odir))
        cells = " | ".join(f"{statistics.median(t):.3f} s | {min(t):.3f} s" for t in times.values())
        line = f"| `{LABELS[row]}` | {cells} |"
        if len(names) == 2:
            diffs = [a - b for a, b in zip(times[names[0]], times[names[1]], strict=True)]
            line += f" {statistics.median(diffs):+.3f} s |"
        print(line)
    print(f"\nload after {load()}")


if __name__ == "__main__":
    main()
