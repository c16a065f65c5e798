"""Build the demo ALTM tape jobs/data/fsite5_tape.txt from a real ISPRS test site.

    python tools/make_demo_tape.py [SITE.laz] [OUT.txt]

The ISPRS raw sites (first and last pulse, as LAZ) store first and last pulse of each shot as
return 1 and return 2 in the same order: pulse k of the first half pairs with pulse k of the
second half. A 300 m x 150 m window of FSite5 is cut into three east-west bands of 50 m, each
taken as a flight strip. GPS time is synthesised from shot order (10 ms a shot, as the sites
are thinned) with a 300 s gap between strips, so split-tape finds three strips at its default
60 s interval. Rows are written in the manual's order t x2 y2 z2 i2 x1 y1 z1 i1 (last return
first).
"""

from __future__ import annotations

import sys
from pathlib import Path

import laspy
import numpy as np

REPO = Path(__file__).resolve().parents[1]
# the ISPRS test site FSite5 as LAZ; bench/data_paths.py says where the public data are looked for
sys.path.insert(0, str(REPO / "bench"))
from data_paths import FSITE5 as SITE

OUT = REPO / "jobs" / "data" / "fsite5_tape.txt"
WINDOW = (494200.0, 5420300.0, 494500.0, 5420450.0)  # min x, min y, max x, max y
BAND = 50.0  # strip width (m)
T0 = 318_000.0  # a GPS second of week
SHOT = 0.01  # s between kept shots
GAP = 300.0  # s between strips


def main(site: Path = SITE, out: Path = OUT) -> None:
    las = laspy.read(site)
    n = len(las.x) // 2
    first = np.column_stack([np.asarray(las.x[:n]), np.asarray(las.y[:n]), np.asarray(las.z[:n]),
                             np.asarray(las.intensity[:n])])
    last = np.column_stack([np.asarray(las.x[n:]), np.asarray(las.y[n:]), np.asarray(las.z[n:]),
                            np.asarray(las.intensity[n:])])
    if not (np.all(las.return_number[:n] == 1) and np.all(las.return_number[n:] == 2)):
        raise SystemExit(f"{site}: expected first returns then last returns")
    x0, y0, x1, y1 = WINDOW
    inside = (first[:, 0] >= x0) & (first[:, 0] < x1) & (first[:, 1] >= y0) & (first[:, 1] < y1)
    band = np.floor((first[:, 1] - y0) / BAND).astype(int)
    rows = []
    t = T0
    for b in range(int((y1 - y0) / BAND)):
        keep = np.flatnonzero(inside & (band == b))  # shot order within the strip
        times = t + SHOT * np.arange(len(keep))
        rows.append(np.column_stack([times, last[keep], first[keep]]))
        t = times[-1] + GAP
    table = np.concatenate(rows)
    fmt = "%.2f %.2f %.2f %.2f %d %.2f %.2f %.2f %d"
    np.savetxt(out, table, fmt=fmt)
    print(f"{out}: {len(table)} shots in {len(rows)} strips, {out.stat().st_size} bytes")


if __name__ == "__main__":
    main(*(Path(a) for a in sys.argv[1:3]))
