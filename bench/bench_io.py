"""Point I/O throughput and memory: ASCII reading, LAS/LAZ read+write.

    python bench/bench_io.py                 # 1 M and 10 M lines (writes files under bench/_work/)
    python bench/bench_io.py --sizes 1 10 50 --loadtxt

Reports points/second and peak memory of each operation, each run in a fresh process. The ASCII
reader streams in chunks, so its peak must stay flat as the file grows; numpy.loadtxt (the
floor the issue names) and plain laspy (the floor for LAS/LAZ) run on the same files.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import measure, mib, write_synthetic_points

WORK = Path(__file__).resolve().parent / "_work"
REPO = Path(__file__).resolve().parents[1]


def row(name: str, n: int, r: dict) -> str:
    return f"{name:38} {n:>11,} {r['seconds']:8.2f} s {n / r['seconds'] / 1e6:8.2f} M pts/s {mib(r['peak_bytes']):>10}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1, 10], help="millions of lines")
    ap.add_argument("--loadtxt", action="store_true", help="also time numpy.loadtxt (slow)")
    args = ap.parse_args()
    print(f"{'operation':38} {'points':>11} {'time':>10} {'rate':>15} {'peak RSS':>10}")
    for size in args.sizes:
        n = size * 1_000_000
        txt = WORK / f"points_{size}m.txt"
        write_synthetic_points(txt, n, (500000, 502000), (5400000, 5402000))
        code = (f"import sys; sys.path.insert(0, {str(REPO)!r})\n"
                "from aldpat.io.registry import open_points\n"
                f"n = sum(len(c) for c in open_points({str(txt)!r}).chunks())\nresult = dict(n=n)")
        print(row("aldpat ASCII read (streamed)", n, measure(code)))
        if args.loadtxt:
            code = f"import numpy as np\na = np.loadtxt({str(txt)!r})\nresult = dict(n=len(a))"
            print(row("numpy.loadtxt (whole file)", n, measure(code)))
        las = WORK / f"points_{size}m.laz"
        code = (f"import sys; sys.path.insert(0, {str(REPO)!r})\n"
                "from aldpat.tasks import get_task\n"
                f"get_task('convert')([{str(txt)!r}], out_format='laz', odir={str(WORK)!r}, overwrite=True)\n"
                "result = dict()")
        print(row("aldpat convert text -> LAZ", n, measure(code)))
        for ext in ("laz", "las"):
            src = las if ext == "laz" else WORK / f"points_{size}m.las"
            if ext == "las" and not src.exists():
                measure(f"import laspy\nlaspy.read({str(las)!r}).write({str(src)!r})\nresult = dict()")
            out = WORK / f"copy_{size}m.{ext}"
            code = (f"import sys; sys.path.insert(0, {str(REPO)!r})\n"
                    "from aldpat.io.registry import open_points, write_points\n"
                    f"r = open_points({str(src)!r})\n"
                    f"with write_points({str(out)!r}, r.names, like=r, overwrite=True) as w:\n"
                    "    for c in r.chunks(): w.write(c)\n"
                    "result = dict()")
            print(row(f"aldpat {ext.upper()} read + write (streamed)", n, measure(code)))
            code = ("import laspy\n"
                    f"with laspy.open({str(src)!r}) as f, laspy.open({str(out)!r}, mode='w', header=f.header) as w:\n"
                    "    for c in f.chunk_iterator(2_000_000): w.write_points(c)\n"
                    "result = dict()")
            print(row(f"plain laspy {ext.upper()} read + write (chunks)", n, measure(code)))


if __name__ == "__main__":
    main()
