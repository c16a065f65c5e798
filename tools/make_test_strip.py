"""Cut the real strip used by the strip-boundary tests: tests/data/fsite5_strip.laz.

    python tools/make_test_strip.py

First returns of ISPRS FSite5 in a 600 m x 220 m window: about
20 600 points, a strip-shaped piece of real terrain with trees and buildings, kept as LAZ
(about 10 bytes a point) so that the repository stays small.
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

OUT = REPO / "tests" / "data" / "fsite5_strip.laz"
WINDOW = (494200.0, 5420300.0, 494800.0, 5420520.0)


def main() -> None:
    las = laspy.read(SITE)
    n = len(las.x) // 2
    first = las.points[:n]
    x, y = np.asarray(first.x), np.asarray(first.y)
    x0, y0, x1, y1 = WINDOW
    keep = (x >= x0) & (x < x1) & (y >= y0) & (y < y1)
    out = laspy.LasData(las.header)
    out.points = first[keep]
    out.write(OUT)
    print(f"{OUT}: {int(keep.sum())} points, {OUT.stat().st_size} bytes")


if __name__ == "__main__":
    main()
