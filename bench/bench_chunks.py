"""``aldpat filter --chunk``: agreement with whole-file runs, and memory on a big file.

``python bench/bench_chunks.py agree [--chunk 100]`` -- reads the seven ISPRS samples and the
raw ISPRS site FSite5 (``bench/data_paths.py``). Every filter runs on each file whole and in
chunks of ``--chunk`` m with the automatic buffer (point filters, which have none: 40 m); the
share of points whose class agrees is reported per filter (the lowest over the files, and over
all points).

``python bench/bench_chunks.py memory --points 20 [--chunk 500]`` -- tiled copies of FSite5 as one
LAS of about N million points (built once under ``bench/_work/``), filtered with ``gapm`` whole
and with ``--chunk`` (-j 1 and -j 2), each in a fresh process: wall time, points per second and
peak memory (with -j 2, the parent's; each chunk process holds one chunk with its buffer).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import measure, mib
from bench_filters import build_sites
from data_paths import FSITE5, ISPRS_SAMPLES

SAMPLES = ("samp12", "samp21", "samp24", "samp42", "samp51", "samp53", "samp61")


def _classes(algorithm: str, source: Path, odir: Path, **options) -> np.ndarray:
    import laspy

    from aldpat.tasks import get_task

    report = get_task("filter", algorithm)([source], odir=str(odir), result="classified", out_format="las",
                                           overwrite=True, **options)
    if report.exit_code != 0:
        raise RuntimeError([r.error for r in report.results])
    return np.asarray(laspy.read(odir / f"{source.stem}_{algorithm}.las").classification)


def run_agree(chunk: float) -> None:
    from aldpat.filters import FILTERS

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        files = []
        for name in SAMPLES:
            rows = np.loadtxt(ISPRS_SAMPLES / f"{name}.txt")
            np.savetxt(root / f"{name}.txt", rows[:, :3], fmt="%.2f")
            files.append(root / f"{name}.txt")
        files.append(FSITE5)
        print(f"| filter | buffer | lowest agreement (file) | all points | chunks {chunk:g} m |")
        print("|---|---|---|---|---|")
        for algorithm in sorted(FILTERS):
            buffer = "auto" if FILTERS[algorithm].reach is not None else "40"
            same = total = 0
            worst = (1.0, "")
            for source in files:
                whole = _classes(algorithm, source, root / "whole")
                parts = _classes(algorithm, source, root / "chunks", chunk=chunk, chunk_buffer=buffer, jobs=2)
                agree = float((whole == parts).mean())
                same += int((whole == parts).sum())
                total += len(whole)
                worst = min(worst, (agree, source.stem))
            print(f"| {algorithm} | {buffer} | {worst[0]:.4%} ({worst[1]}) | {same / total:.4%} | |")


def run_memory(millions: float, chunk: float) -> None:
    las = build_sites(int(millions * 1e6))
    import laspy

    n = laspy.open(las).header.point_count
    print(f"{las.name}: {n:,} points; aldpat filter gapm --result classified")
    for label, options in (("whole", {}), (f"--chunk {chunk:g} -j 1", {"chunk": chunk, "jobs": 1}),
                           (f"--chunk {chunk:g} -j 2", {"chunk": chunk, "jobs": 2})):
        with tempfile.TemporaryDirectory(dir=las.parent) as out:
            code = ("from aldpat.tasks import get_task\n"
                    f"r = get_task('filter', 'gapm')([{str(las)!r}], odir={out!r}, result='classified', **{options!r})\n"
                    "assert r.exit_code == 0, [x.error for x in r.results]\n"
                    "result = {}\n")
            m = measure(code)
        print(f"  {label}: {m['seconds']:.1f} s, {n / m['seconds'] / 1e6:.2f} M points/s, peak {mib(m['peak_bytes'])}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="command", required=True)
    a = sub.add_parser("agree", help="chunked vs whole classes on the ISPRS samples and FSite5")
    a.add_argument("--chunk", type=float, default=100.0)
    m = sub.add_parser("memory", help="gapm on a big LAS, whole and in chunks")
    m.add_argument("--points", type=float, default=20.0, help="millions of points")
    m.add_argument("--chunk", type=float, default=500.0)
    args = ap.parse_args()
    if args.command == "agree":
        run_agree(args.chunk)
    else:
        run_memory(args.points, args.chunk)


if __name__ == "__main__":
    main()
