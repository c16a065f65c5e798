"""Gridding throughput and memory: 10 million points on a 2 km x 2 km tile at 1 m.

    python bench/bench_grid.py                              # every method, 10 M points
    python bench/bench_grid.py --points 2 --methods linear kriging

Targets on this machine: nearest, linear, idw and the binning methods under 60 s,
kriging with local neighbourhoods under 10 minutes. Points (uniform x, y over the tile plus a
20 m buffer; z a rolling terrain with noise) are made once and kept in bench/_work/. Each method
runs in a fresh process; "grid s" is the interpolation alone (wall clock), "cpu s" its processor
time over all threads (the TIN, nearest, idw and kriging use both cores), "write s" the Surfer 7
grid (2001 x 2001 nodes), peak the process's maximum resident memory, points included.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import measure, mib

WORK = Path(__file__).resolve().parent / "_work"
REPO = Path(__file__).resolve().parents[1]
METHODS = ("nearest", "linear", "idw", "min", "max", "mean", "kriging")


def make_points(n: int) -> Path:
    path = WORK / f"grid_points_{n}.npy"
    if path.exists():
        return path
    WORK.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    x = rng.uniform(500000 - 20, 502000 + 20, n)
    y = rng.uniform(4000000 - 20, 4002000 + 20, n)
    z = (200 + 30 * np.sin((x - 500000) / 300) * np.cos((y - 4000000) / 250) + 0.01 * (x - 500000)
         + rng.normal(0, 0.05, n))
    np.save(path, np.column_stack([x, y, z]))
    return path


CODE = """
import sys, time
import numpy as np
sys.path.insert(0, {repo!r})
from aldpat.core.grid_extent import from_bounds
from aldpat.core.interpolate import interpolate
from aldpat.io.surfer import write_surfer
pts = np.load({points!r})
spec = from_bounds(500000, 4000000, 502000, 4002000, 1.0)
t0 = time.perf_counter()
c0 = time.process_time()
vals = interpolate(pts[:, 0], pts[:, 1], pts[:, 2], spec, method={method!r})
cpu = time.process_time() - c0
t1 = time.perf_counter()
write_surfer({out!r}, vals, spec, fmt="surfer7", overwrite=True)
t2 = time.perf_counter()
result = dict(grid=t1 - t0, cpu=cpu, write=t2 - t1, blank=int(np.isnan(vals).sum()))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=float, default=10, help="millions of points (default 10)")
    ap.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS)
    args = ap.parse_args()
    n = int(args.points * 1e6)
    points = make_points(n)
    print(f"{n:,} points, 2 km x 2 km at 1 m (2001 x 2001 nodes), {os.cpu_count()} cores")
    print("load: 1-minute load average after each method (above 2, other processes slow every figure)")
    print(f"{'method':10} {'grid s':>8} {'cpu s':>8} {'write s':>8} {'total s':>8} {'M pts/s':>8} {'peak':>10} "
          f"{'blank':>8} {'load':>5}")
    for method in args.methods:
        out = WORK / f"bench_{method}.grd"
        r = measure(CODE.format(repo=str(REPO), points=str(points), method=method, out=str(out)))
        print(f"{method:10} {r['grid']:8.1f} {r['cpu']:8.1f} {r['write']:8.1f} {r['seconds']:8.1f} {n / r['grid'] / 1e6:8.2f} "
              f"{mib(r['peak_bytes']):>10} {r['blank']:8,} {os.getloadavg()[0]:5.1f}", flush=True)
        out.unlink(missing_ok=True)


if __name__ == "__main__":
    main()
