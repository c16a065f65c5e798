"""Ortho-height throughput: geoid undulations with PROJ, and the streaming task end to end.

    python bench/bench_heights.py                 # 10 M points in memory, 2 M-line file
    python bench/bench_heights.py --points 20 --file-points 5

Uses the real EGM96 15' grid (``data_paths.EGM96``). "core" converts arrays in
chunks of 1 M points (UTM 15N -> H = h - N; then also re-projecting to State Plane feet); "task"
runs ``aldpat ortho-height`` on a text file, whose peak memory must not grow with the file.
Each measurement runs in a fresh process.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import measure, mib, write_synthetic_points
from data_paths import EGM96

WORK = Path(__file__).resolve().parent / "_work"
REPO = Path(__file__).resolve().parents[1]
GEOID = str(EGM96)

CORE = """
import sys
import numpy as np
sys.path.insert(0, {repo!r})
from aldpat.core.heights import HeightConverter
conv = HeightConverter("15N", {geoid!r}, to_crs={to_crs!r})
rng = np.random.default_rng(0)
done = 0
while done < {n}:
    m = min(1_000_000, {n} - done)
    x = rng.uniform(700000, 720000, m); y = rng.uniform(4270000, 4290000, m); z = rng.uniform(100, 200, m)
    conv(x, y, z, first=done)
    done += m
result = dict(n=done)
"""

TASK = """
import sys
sys.path.insert(0, {repo!r})
from aldpat.tasks import get_task
report = get_task("ortho-height")([{src!r}], crs="15N", geoid={geoid!r}, odir={odir!r}, overwrite=True)
assert report.exit_code == 0, report.results[0].error
result = dict(n=report.outputs[0].count)
"""


def make_text(n: int) -> Path:
    path = WORK / f"heights_{n}.txt"
    write_synthetic_points(path, n, (700000, 720000), (4270000, 4290000), (100, 200))
    return path
    WORK.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    with open(path, "w") as fh:
        for start in range(0, n, 1_000_000):
            m = min(1_000_000, n - start)
            block = np.column_stack([rng.uniform(700000, 720000, m), rng.uniform(4270000, 4290000, m),
                                     rng.uniform(100, 200, m), rng.integers(0, 255, m)])
            fh.write(("%.2f %.2f %.2f %d\n" * m) % tuple(block.ravel().tolist()))
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=float, default=10, help="millions of points converted in memory")
    ap.add_argument("--file-points", type=float, nargs="+", default=[1, 2], help="millions of lines in the files")
    args = ap.parse_args()
    n = int(args.points * 1e6)
    print(f"{'measurement':44} {'points':>11} {'seconds':>8} {'M pts/s':>8} {'peak':>10}")
    for label, to_crs in (("core: H = h - N", None), ("core: H = h - N, x y -> State Plane ftUS", "EPSG:2236")):
        r = measure(CORE.format(repo=str(REPO), geoid=GEOID, n=n, to_crs=to_crs))
        print(f"{label:44} {n:11,} {r['seconds']:8.2f} {n / r['seconds'] / 1e6:8.2f} {mib(r['peak_bytes']):>10}",
              flush=True)
    for millions in args.file_points:
        m = int(millions * 1e6)
        src = make_text(m)
        r = measure(TASK.format(repo=str(REPO), src=str(src), geoid=GEOID, odir=str(WORK / "ortho")))
        print(f"{'task: ortho-height on ' + src.name:44} {r['n']:11,} {r['seconds']:8.2f} "
              f"{r['n'] / r['seconds'] / 1e6:8.2f} {mib(r['peak_bytes']):>10}", flush=True)


if __name__ == "__main__":
    main()
