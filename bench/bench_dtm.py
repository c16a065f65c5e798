"""``aldpat dtm``: what the buffer buys, and how fast a project of tiles goes.

``python bench/bench_dtm.py tiles`` -- reads the seven ISPRS samples (``bench/data_paths.py``).
Each sample is made into a DTM at 1 m three ways: whole, cut into 2 x 2 equal tiles with the
default 30 m buffer, and the same tiles with no buffer. Reported per sample: the RMSE of each DTM
at the reference bare-earth points (and the share of them it covers), and the mean absolute
difference of each tiled DTM (its VRT mosaic) from the whole file's.

``python bench/bench_dtm.py speed [--tiles 3] [--cell 1]`` -- reads the raw ISPRS site FSite5
(628,320 points, 1.6 x 1.3 km, first and last pulse), cut into N x N LAZ tiles once under
``bench/_work/``, and runs ``aldpat dtm`` over them in a fresh process with ``-j 1`` and ``-j 2``:
wall time, points per second and peak memory of the process (with ``-j 2`` the workers' own
memory is not in the parent's figure: see the ``-j 1`` row for one job's).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import measure, mib
from data_paths import FSITE5, ISPRS_SAMPLES

WORK = Path(__file__).resolve().parent / "_work"
SAMPLES = ("samp12", "samp21", "samp24", "samp42", "samp51", "samp53", "samp61")


def _dtm(inputs: list[Path], odir: Path, **options) -> None:
    from aldpat.tasks import get_task

    report = get_task("dtm")(inputs, odir=str(odir), grid_format="geotiff", overwrite=True, **options)
    if report.exit_code != 0:
        raise RuntimeError([r.error for r in report.results])


def _at_ground(path: Path, ground: np.ndarray) -> tuple[float, float]:
    import rasterio

    with rasterio.open(path) as ds:
        values = np.array([v[0] for v in ds.sample(ground[:, :2])], float)
        values[values == ds.nodata] = np.nan
    diff = values - ground[:, 2]
    ok = np.isfinite(diff)
    return float(np.sqrt(np.mean(diff[ok] ** 2))), float(ok.mean())


def _gap(a: Path, b: Path) -> float:
    import rasterio

    with rasterio.open(a) as one, rasterio.open(b) as two:
        if one.shape != two.shape or one.bounds != two.bounds:
            raise RuntimeError(f"{a} and {b} are not on the same nodes")
        return float(np.ma.abs(one.read(1, masked=True) - two.read(1, masked=True)).mean())


def run_tiles() -> None:
    print("| sample | RMSE whole | RMSE 2x2 buffered | RMSE 2x2 no buffer | gap buffered | gap no buffer |")
    print("|---|---|---|---|---|---|")
    sums = np.zeros(5)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for name in SAMPLES:
            rows = np.loadtxt(ISPRS_SAMPLES / f"{name}.txt")
            ground = rows[rows[:, 3] == 0]
            folder = root / name
            folder.mkdir()
            np.savetxt(folder / "whole.txt", rows[:, :3], fmt="%.2f")
            xm, ym = (rows[:, :2].min(axis=0) + rows[:, :2].max(axis=0)) / 2
            for i, west in enumerate((True, False)):
                for j, south in enumerate((True, False)):
                    keep = ((rows[:, 0] < xm) == west) & ((rows[:, 1] < ym) == south)
                    np.savetxt(folder / f"tile_{i}{j}.txt", rows[keep, :3], fmt="%.2f")
            tiles = sorted(folder.glob("tile_*.txt"))
            _dtm([folder / "whole.txt"], folder / "whole")
            _dtm(tiles, folder / "buffered", mosaic="m.vrt")
            _dtm(tiles, folder / "unbuffered", mosaic="m.vrt", buffer=0.0)
            whole = folder / "whole" / "whole_dtm.tif"
            figures = [_at_ground(whole, ground), _at_ground(folder / "buffered" / "m.vrt", ground),
                       _at_ground(folder / "unbuffered" / "m.vrt", ground)]
            gaps = [_gap(whole, folder / "buffered" / "m.vrt"), _gap(whole, folder / "unbuffered" / "m.vrt")]
            row = [f[0] for f in figures] + gaps
            sums += row
            cells = [f"{r:.3f} ({c:.1%})" for r, c in figures] + [f"{g:.4f}" for g in gaps]
            print(f"| {name} | " + " | ".join(cells) + " |")
    mean = sums / len(SAMPLES)
    print("| mean | " + " | ".join(f"{v:.3f}" for v in mean[:3]) + " | " + " | ".join(f"{v:.4f}" for v in mean[3:]) + " |")
    print("RMSE in m at the reference bare-earth points (share of them inside the DTM); gap: mean |tiled - whole| in m")


def build_tiles(n: int) -> list[Path]:
    """FSite5 cut into n x n LAZ tiles (made once)."""
    import laspy

    folder = WORK / f"fsite5_{n}x{n}"
    tiles = sorted(folder.glob("tile_*.laz"))
    if len(tiles) == n * n:
        return tiles
    folder.mkdir(parents=True, exist_ok=True)
    las = laspy.read(FSITE5)
    x, y = np.asarray(las.x), np.asarray(las.y)
    xe = np.linspace(x.min(), x.max(), n + 1)
    ye = np.linspace(y.min(), y.max(), n + 1)
    ci = np.clip(np.searchsorted(xe, x, side="right") - 1, 0, n - 1)
    ri = np.clip(np.searchsorted(ye, y, side="right") - 1, 0, n - 1)
    for r in range(n):
        for c in range(n):
            part = laspy.LasData(las.header)
            part.points = las.points[(ri == r) & (ci == c)]
            tmp = folder / f"tile_{r}{c}.part.laz"
            part.write(tmp)
            tmp.rename(folder / f"tile_{r}{c}.laz")
    return sorted(folder.glob("tile_*.laz"))


def run_speed(n: int, cell: float) -> None:
    tiles = build_tiles(n)
    import laspy

    points = sum(laspy.open(t).header.point_count for t in tiles)
    print(f"FSite5 in {n} x {n} LAZ tiles: {points:,} points; aldpat dtm --cell {cell:g} (gapm, 30 m buffer, COG)")
    for jobs in (1, 2):
        with tempfile.TemporaryDirectory() as out:
            code = (
                "from aldpat.tasks import get_task\n"
                f"r = get_task('dtm')({[str(t) for t in tiles]!r}, odir={out!r}, cell={cell!r}, jobs={jobs})\n"
                "assert r.exit_code == 0, [x.error for x in r.results]\n"
                "result = {}\n"
            )
            m = measure(code)
        rate = points / m["seconds"]
        print(f"  -j {jobs}: {m['seconds']:.1f} s, {rate / 1e3:,.0f} k points/s, peak {mib(m['peak_bytes'])}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="command", required=True)
    sub.add_parser("tiles", help="whole vs buffered vs unbuffered tiles on the seven ISPRS samples")
    sp = sub.add_parser("speed", help="aldpat dtm over FSite5 in LAZ tiles")
    sp.add_argument("--tiles", type=int, default=3, help="N: N x N tiles")
    sp.add_argument("--cell", type=float, default=1.0)
    args = ap.parse_args()
    if args.command == "tiles":
        run_tiles()
    else:
        run_speed(args.tiles, args.cell)


if __name__ == "__main__":
    main()
