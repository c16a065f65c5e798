"""Which returns should take part in finding ground: ``--returns all``, ``last`` or ``first``.

    python bench/bench_returns.py                 # gapm's defaults
    python bench/bench_returns.py --auto          # gapm --auto

The seven ISPRS samples are x y z text without return numbers, so they cannot tell the choices
apart; the raw sites in ``isprs-sites/`` (``bench/data_paths.py``) carry the first and the last
pulse of every shot. Samples 51 and 53 are cut from site 5's *last* pulse: 99.9 % of their points
are, to the centimetre, last-pulse points of ``FSite5_orig-utm.laz`` (this command prints the
share). (Sample 12's points are not in ``CSite1_red2-utm.laz``, a reduced copy of site 1, so site 1
cannot be scored this way.)

For each such sample the site is cut to the sample's extent and encoded as a vendor would
deliver it: a shot whose first and last pulse lie within 1 m of each other (:data:`SAME_PULSE`) is one point, return
1 of 1; any other shot is two points, 1 of 2 and 2 of 2. The filter runs on every point of the cut
with each ``--returns`` choice (through :func:`aldpat.ground`, which is what ``aldpat filter``
runs), and the sample's labels score the last-pulse points: Type I, Type II and total error as
``aldpat evaluate`` gives them. Also printed: how many first returns of two-return shots (canopy,
building edges: points a surface lies above) the filter calls ground with ``all``, and what share
of the sample's labelled points took part with ``first`` (a last return of two never does).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

BENCH = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH.parent))
sys.path.insert(0, str(BENCH))

from data_paths import ISPRS_SITES
from isprs import DATA, score

#: (sample, the site it is cut from)
PAIRS = (("samp51", "FSite5_orig-utm.laz"), ("samp53", "FSite5_orig-utm.laz"))

#: A shot whose two pulses lie this close (m, 3D) has one return. On site 5, 58 % of shots have
#: their pulses within 5 cm, 85.0 % within 10 cm and 86.4 % within any distance from 20 cm to 3 m:
#: the pulses of one return differ by centimetres of ranging noise, a receiver separates two
#: returns only metres apart; 1 m lies on that plateau.
SAME_PULSE = 1.0

CHOICES = ("all", "last", "first")


def _key(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """A point's position to the centimetre as one sortable record."""
    cm = np.stack([np.round(np.asarray(v, np.float64) * 100).astype(np.int64) for v in (x, y, z)], axis=1)
    return np.ascontiguousarray(cm).view([("x", np.int64), ("y", np.int64), ("z", np.int64)]).ravel()


def vendor_cut(site: Path, box: tuple[float, float, float, float]):
    """The site's shots inside ``box`` as a vendor's LAS: x, y, z, return number, number of
    returns; the last-pulse point of every shot comes first in the arrays' second half."""
    import laspy

    las = laspy.read(site)
    n = len(las.x) // 2  # shot k: point k (first pulse), point n + k (last pulse)
    x, y, z = (np.asarray(v, np.float64) for v in (las.x, las.y, las.z))
    first = slice(0, n)
    last = slice(n, 2 * n)
    x0, y0, x1, y1 = box
    inside = (x[last] >= x0) & (x[last] <= x1) & (y[last] >= y0) & (y[last] <= y1)
    gap = np.sqrt((x[first] - x[last]) ** 2 + (y[first] - y[last]) ** 2 + (z[first] - z[last]) ** 2)
    single = gap < SAME_PULSE
    two = inside & ~single
    one = inside & single
    # last pulses of every shot inside (1 of 1 or 2 of 2), then first pulses of two-return shots
    lx = np.concatenate([x[last][inside], x[first][two]])
    ly = np.concatenate([y[last][inside], y[first][two]])
    lz = np.concatenate([z[last][inside], z[first][two]])
    n_last = int(inside.sum())
    number = np.concatenate([np.where(one[inside], 1, 2), np.ones(int(two.sum()))]).astype(np.uint8)
    of = np.concatenate([np.where(one[inside], 1, 2), np.full(int(two.sum()), 2)]).astype(np.uint8)
    return lx, ly, lz, number, of, n_last


def as_las(x, y, z, number, of):
    """The points as a LAS 1.4 point format 6 in memory (return numbers as a vendor writes them)."""
    import laspy

    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = np.array([0.01, 0.01, 0.01])
    header.offsets = np.floor(np.array([x.min(), y.min(), z.min()]))
    las = laspy.LasData(header)
    las.x, las.y, las.z = x, y, z
    las.return_number = number
    las.number_of_returns = of
    return las


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--auto", action="store_true", help="gapm --auto instead of its defaults")
    args = parser.parse_args(argv)

    import aldpat

    print(f"gapm {'--auto' if args.auto else 'defaults'}; a shot with pulses within {SAME_PULSE * 100:g} cm "
          "is one return")
    print(f"{'sample':8} {'matched':>9} {'1 of 1':>7} {'2 of 2':>7} | "
          + " | ".join(f"{c:>5}: {'I':>5} {'II':>5} {'total':>5}" for c in CHOICES) + " | firsts ground (all)")
    totals: dict[str, list[float]] = {c: [] for c in CHOICES}
    for sample, site in PAIRS:
        rows = np.loadtxt(DATA / f"{sample}.txt")
        box = (rows[:, 0].min(), rows[:, 1].min(), rows[:, 0].max(), rows[:, 1].max())
        x, y, z, number, of, n_last = vendor_cut(ISPRS_SITES / site, box)
        keys = _key(x[:n_last], y[:n_last], z[:n_last])
        sample_keys = _key(rows[:, 0], rows[:, 1], rows[:, 2])
        order = np.argsort(sample_keys)
        where = np.searchsorted(sample_keys[order], keys)
        where = np.minimum(where, len(order) - 1)
        matched = sample_keys[order][where] == keys
        label = rows[order[where], 3] == 0  # ground in the reference
        share = np.isin(sample_keys, keys).mean() * 100
        las = as_las(x, y, z, number, of)
        cells = []
        for choice in CHOICES:
            ground = aldpat.ground(las, "gapm", returns=choice, auto=args.auto)
            acc = score(label[matched], ground[:n_last][matched])
            totals[choice].append(acc.total)
            cells.append(f"{choice:>5}: {acc.type1:5.2f} {acc.type2:5.2f} {acc.total:5.2f}")
            if choice == "all":
                firsts_ground = int(ground[n_last:].sum())
        print(f"{sample:8} {share:8.1f}% {int((of[:n_last] == 1).sum()):7d} {int((of[:n_last] == 2).sum()):7d} | "
              + " | ".join(cells) + f" | {firsts_ground} of {len(x) - n_last}")
    print("mean total: " + ", ".join(f"{c} {np.mean(v):.2f} %" for c, v in totals.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
