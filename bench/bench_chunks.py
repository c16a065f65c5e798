"""``aldpat filter --chunk``: agreement with whole-file runs, and memory on a big file.

``python bench/bench_chunks.py agree [--chunk 100] [--point-buffer M] [--filters ...] [--sites]`` --
reads the seven ISPRS samples (``bench/data_paths.py``) and the FSite5 strip in ``tests/data/``
(with ``--sites``: the ISPRS sites FSite5 and CSite1 whole, 1.6 x 1.3 km and 1.1 x 1.0 km). Every
filter (or those named) runs on each file whole and in chunks of ``--chunk`` m with the automatic
buffer (``--point-buffer``: the point filters' buffer in metres instead); the share of points
whose class agrees is reported per filter (the lowest over the files, and over all points).

``python bench/bench_chunks.py memory --points 100 --chunk 2000 [--whole]`` -- tiled copies of
FSite5 as one LAZ of about N million points (built once under ``bench/_work/``), filtered with
``gapm --chunk`` with ``-j 1``, ``-j 2`` and ``--scheduler local:2`` (and whole with ``--whole``),
each in a fresh process: wall time, points per second, peak memory of the process (with -j 2
and the cluster, the parent's; each chunk process holds one chunk with its buffer), and the sum
of the chunks' own filtering times from the log.

``python bench/bench_chunks.py dense --points 100 [--layers 10] [--las14] [--chunked 2000] [--compare]``
-- a dense file of about N million points: the tiled FSite5 copies (4 x 4 for 100 M) laid ``--layers``
times over one another, each layer shifted by under a metre (as overlapping flight lines lie), so
about 3.5 points/m2 over 33 km2; one LAZ (with ``--las14`` LAS 1.4, point format 6, GPS times
added), built once under ``bench/_work/``. ``aldpat filter gapm`` with its defaults, LAZ in and
LAZ out, in a fresh process (the two-pass streamed path): wall time, points per second, peak
memory. ``--chunked C`` also runs ``--chunk C -j 2`` on the same file (equal work: the same
points and classes written) and gives the ratio of the rates. ``--compare`` runs ``ground_filter``
on all the points held in memory in another fresh process (about 10 GB at 100 M) and counts the
points whose class differs from the streamed run's.

``python bench/bench_chunks.py tiles --tiles 16`` -- 16 LAS tiles of about 1 M points (copies of
ISPRS samp12, urban, 1 point/m2, side by side) through a worksheet (gapm, then a 1 m TIN grid)
with ``-j 1``, ``-j 2`` and ``--scheduler local:2``: wall time of each run.
"""

from __future__ import annotations

import argparse
import re
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import measure, mib
from bench_filters import build_isprs, build_sites
from data_paths import ISPRS_SAMPLES, ISPRS_SITES

SAMPLES = ("samp12", "samp21", "samp24", "samp42", "samp51", "samp53", "samp61")


def _classes(algorithm: str, source: Path, odir: Path, **options) -> np.ndarray:
    import laspy

    from aldpat.tasks import get_task

    report = get_task("filter", algorithm)([source], odir=str(odir), result="classified", out_format="las",
                                           overwrite=True, **options)
    if report.exit_code != 0:
        raise RuntimeError([r.error for r in report.results])
    return np.asarray(laspy.read(odir / f"{source.stem}_{algorithm}.las").classification)


def _chunk_for(algorithm: str, chunk: float, buffer: str) -> float:
    """``chunk``, or the least chunk the filter's default buffer allows when ``chunk`` is refused
    for copying each point into too many chunks (gapm's automatic buffer reaches ~500 m at its
    defaults, so 100 m chunks are refused as a user's would be)."""
    import math

    from aldpat.errors import ParamError
    from aldpat.filters import FILTERS
    from aldpat.filters.chunked import chunk_plan
    from aldpat.io.chunks import MOST_COPIES

    spec = FILTERS[algorithm]
    try:
        chunk_plan(algorithm, spec.params(chunk=chunk, chunk_buffer=buffer))
        return chunk
    except ParamError:  # the copies bound: the least chunk for the buffer the plan would use
        lattice = chunk_plan(algorithm, spec.params(chunk=1e6, chunk_buffer=buffer)).lattice
        return float(math.ceil(2 * lattice.buffer / (math.sqrt(MOST_COPIES) - 1)))


def run_agree(chunk: float, point_buffer: float | None, names: list[str] | None, sites: bool) -> None:
    from aldpat.filters import FILTERS

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        files = []
        if sites:  # whole ISPRS sites, the size of a tile people chunk
            files = [ISPRS_SITES / "FSite5_orig-utm.laz", ISPRS_SITES / "CSite1_red2-utm.laz"]
        else:
            for name in SAMPLES:
                rows = np.loadtxt(ISPRS_SAMPLES / f"{name}.txt")
                np.savetxt(root / f"{name}.txt", rows[:, :3], fmt="%.2f")
                files.append(root / f"{name}.txt")
            files.append(Path(__file__).resolve().parents[1] / "tests" / "data" / "fsite5_strip.laz")
        print("| filter | buffer | lowest agreement (file) | all points | chunks |")
        print("|---|---|---|---|---|")
        for algorithm in sorted(names or FILTERS):
            spec = FILTERS[algorithm]
            buffer = "auto" if point_buffer is None or spec.reach is not None else f"{point_buffer:g}"
            shown = buffer
            if buffer == "auto" and spec.reach is None and spec.buffer is not None:
                shown = f"auto ({spec.buffer(spec.params()):g} m)"
            size = _chunk_for(algorithm, chunk, buffer)
            same = total = 0
            worst: tuple[float, str] = (1.0, "")
            for source in files:
                whole = _classes(algorithm, source, root / "whole")
                parts = _classes(algorithm, source, root / "chunks", chunk=size, chunk_buffer=buffer, jobs=2)
                agree = float((whole == parts).mean())
                same += int((whole == parts).sum())
                total += len(whole)
                worst = min(worst, (agree, source.stem))
            lowest = f"{worst[0]:.4%} ({worst[1]})" if worst[1] else "100% (every file)"
            used = f"{size:g} m" if size == chunk else f"{size:g} m (the least its buffer allows)"
            print(f"| {algorithm} | {shown} | {lowest} | {same / total:.4%} | {used} |", flush=True)


def build_laz(millions: float) -> Path:
    """FSite5 copies as one LAZ of about ``millions`` M points (made once from the LAS copies)."""
    import laspy

    las = build_sites(int(millions * 1e6))
    laz = las.with_suffix(".laz")
    if not laz.exists():
        tmp = laz.with_suffix(".part.laz")
        with laspy.open(las) as src, laspy.open(tmp, mode="w", header=src.header, do_compress=True) as dst:
            for points in src.chunk_iterator(2_000_000):
                dst.write_points(points)
        tmp.rename(laz)
    return laz


def run_memory(millions: float, chunk: float, whole: bool) -> None:
    import laspy

    laz = build_laz(millions)
    n = laspy.open(laz).header.point_count
    print(f"{laz.name}: {n:,} points; aldpat filter gapm --result classified, LAZ out")
    runs = [(f"--chunk {chunk:g} -j 1", {"chunk": chunk, "jobs": 1}),
            (f"--chunk {chunk:g} -j 2", {"chunk": chunk, "jobs": 2}),
            (f"--chunk {chunk:g} --scheduler local:2", {"chunk": chunk, "scheduler": "local:2"})]
    if whole:
        runs.insert(0, ("whole", {}))
    for label, options in runs:
        with tempfile.TemporaryDirectory(dir=laz.parent) as out:
            code = ("import re, time\n"
                    "from aldpat.tasks import get_task\n"
                    f"r = get_task('filter', 'gapm')([{str(laz)!r}], odir={out!r}, result='classified', **{options!r})\n"
                    "assert r.exit_code == 0, [x.error for x in r.results]\n"
                    "result = {'notes': r.results[0].notes}\n")
            m = measure(code)
        print(f"  {label}: {m['seconds']:.1f} s, {n / m['seconds'] / 1e6:.2f} M points/s, peak {mib(m['peak_bytes'])}"
              + (f"  [{m['notes'][0]}]" if m["notes"] else ""))


def build_dense(millions: float, layers: int, las14: bool) -> Path:
    """The tiled FSite5 copies of ``millions / layers`` M points laid ``layers`` times over one
    another, layer ``k`` shifted by the fractional parts of ``k`` times two irrational steps (under a
    metre each way), written layer by layer as one LAZ (made once)."""
    import laspy

    base = build_sites(int(millions * 1e6 / layers))
    out = base.with_name(f"{base.stem}_dense{layers}{'_14' if las14 else ''}.laz")
    if out.exists():
        return out
    las = laspy.read(base)
    if las14:
        las = laspy.convert(las, point_format_id=6, file_version="1.4")
    header = las.header
    X, Y = np.asarray(las.points.array["X"]).copy(), np.asarray(las.points.array["Y"]).copy()
    tmp = out.with_suffix(".part.laz")
    rng = np.random.default_rng(14)
    with laspy.open(tmp, mode="w", header=header, do_compress=True) as dst:
        for k in range(layers):
            dx, dy = (k * 0.6180339887) % 1.0, (k * 0.4142135624) % 1.0
            las.points.array["X"] = X + round(dx / header.scales[0])
            las.points.array["Y"] = Y + round(dy / header.scales[1])
            if las14:  # each layer a later flight; pulses about 10 us apart, jittered
                las.gps_time = 3.2e8 + k * 1e4 + np.cumsum(rng.uniform(5e-6, 15e-6, len(X)))
            dst.write_points(las.points)
            print(f"  layer {k + 1} of {layers} written", flush=True)
    tmp.rename(out)
    return out


def _filter_code(laz: Path, out: str, options: dict) -> str:
    """A fresh process's run of gapm's defaults on ``laz``, noting whether the streamed path
    gave way to reading the file whole."""
    return ("import logging\n"
            "from aldpat.tasks import get_task\n"
            "class Seen(logging.Handler):\n"
            "    whole = False\n"
            "    def emit(self, record):\n"
            "        Seen.whole |= 'reading the file whole' in record.getMessage()\n"
            "logging.getLogger('aldpat').addHandler(Seen())\n"
            "logging.getLogger('aldpat').setLevel(logging.INFO)\n"
            f"r = get_task('filter', 'gapm')([{str(laz)!r}], odir={out!r}, result='classified', **{options!r})\n"
            "assert r.exit_code == 0, [x.error for x in r.results]\n"
            "result = {'whole': Seen.whole, 'notes': r.results[0].notes}\n")


def _classes_of(path: Path) -> np.ndarray:
    import laspy

    with laspy.open(path) as reader:
        return np.concatenate([np.asarray(c.classification) for c in reader.chunk_iterator(5_000_000)])


def run_dense(millions: float, layers: int, las14: bool, chunked: float | None, compare: bool) -> None:
    import laspy

    laz = build_dense(millions, layers, las14)
    n = laspy.open(laz).header.point_count
    print(f"{laz.name}: {n:,} points in {layers} layers; aldpat filter gapm (defaults) --result classified, "
          "LAZ out", flush=True)
    runs = [("streamed", {})]
    if chunked:
        runs.append((f"--chunk {chunked:g} -j 2", {"chunk": chunked, "jobs": 2}))
    rates = {}
    with tempfile.TemporaryDirectory(dir=laz.parent) as keep:
        streamed_out = Path(keep) / f"{laz.stem}_gapm.laz"
        for label, options in runs:
            with tempfile.TemporaryDirectory(dir=laz.parent) as out:
                m = measure(_filter_code(laz, out, options))
                written = Path(out) / f"{laz.stem}_gapm.laz"
                if label == "streamed":
                    written.rename(streamed_out)
                else:
                    differ = int((_classes_of(written) != _classes_of(streamed_out)).sum())
            rates[label] = n / m["seconds"]
            how = " (the streamed path gave way: read whole)" if m["whole"] else ""
            print(f"  {label}: {m['seconds']:.1f} s, {rates[label] / 1e6:.2f} M points/s, "
                  f"peak {mib(m['peak_bytes'])}{how}" + ("" if label == "streamed" else
                                                        f", {differ:,} points' classes differ from the streamed run"),
                  flush=True)
            for note in m["notes"]:
                print(f"    [{note}]", flush=True)
        if chunked:
            print(f"  streamed rate / chunked rate: {rates['streamed'] / rates[runs[1][0]]:.2f}")
            found = re.search(r"\((\d+) filtered with the buffers' copies\)", " ".join(m["notes"]))
            if found:  # the same rate over the points the chunks filtered, their buffers' copies counted
                work = int(found.group(1)) / n
                print(f"  the chunks filtered {work:.2f} times the file's points (buffers); per point filtered, "
                      f"streamed rate / chunked rate: {rates['streamed'] / (rates[runs[1][0]] * work):.2f}")
        if compare:
            code = ("import laspy, numpy as np\n"
                    "from aldpat.filters import FILTERS, ground_filter\n"
                    "from aldpat.filters.survey import taking_part\n"
                    "from aldpat.io.las import las_table\n"
                    f"las = laspy.read({str(laz)!r})\n"
                    "params = FILTERS['gapm'].params()\n"
                    "part = taking_part(las_table(las), params)\n"
                    "part = np.ones(len(las.points), bool) if part is None else part\n"
                    "x, y, z = (np.asarray(v, dtype=np.float64)[part] for v in (las.x, las.y, las.z))\n"
                    "del las\n"
                    "ground = ground_filter(x, y, z, 'gapm', params).is_ground\n"
                    f"np.save({str(Path(keep) / 'ground.npy')!r}, ground)\n"
                    f"np.save({str(Path(keep) / 'part.npy')!r}, part)\n"
                    "result = {}\n")
            m = measure(code)
            ground, part = np.load(Path(keep) / "ground.npy"), np.load(Path(keep) / "part.npy")
            written = _classes_of(streamed_out)[part] == 2
            print(f"  whole file in memory (ground_filter): {m['seconds']:.1f} s, peak {mib(m['peak_bytes'])}; "
                  f"{int((written != ground).sum()):,} of {len(ground):,} points' ground calls differ from "
                  "the streamed run", flush=True)


def run_tiles(count: int) -> None:
    import laspy

    one = build_isprs(1_000_000, "samp12")
    folder = one.parent / f"samp12_tiles_{count}"
    if not folder.exists():
        tmp = folder.with_suffix(".part")
        tmp.mkdir(parents=True, exist_ok=True)
        header = laspy.open(one).header
        width = float(np.ceil(header.maxs[0] - header.mins[0] + 1.0))
        for k in range(count):
            part = laspy.read(one)
            part.x = np.asarray(part.x) + k * width
            part.write(tmp / f"tile_{k:02d}.las")
        tmp.rename(folder)
    n = sum(laspy.open(p).header.point_count for p in folder.glob("*.las"))
    print(f"{count} tiles, {n:,} points: worksheet of gapm then a 1 m TIN grid")
    for label, setting in (("-j 1", "jobs = 1"), ("-j 2", "jobs = 2"), ("--scheduler local:2", 'scheduler = "local:2"')):
        with tempfile.TemporaryDirectory(dir=folder.parent) as out:
            sheet = Path(out) / "tiles.toml"
            sheet.write_text(f"[settings]\n{setting}\n\n[[job]]\ntask = \"filter\"\nalgorithm = \"gapm\"\n"
                             f"inputs = [\"{folder}/*.las\"]\nodir = \"ground\"\n\n[[job]]\ntask = \"grid\"\n"
                             f"inputs = [\"ground/*.las\"]\nodir = \"grids\"\ncell = 1.0\n")
            code = ("import subprocess, sys\n"
                    f"p = subprocess.run([sys.executable, '-m', 'aldpat', 'run', {str(sheet)!r}, '-q'], capture_output=True, text=True)\n"
                    "assert p.returncode == 0, p.stderr\n"
                    "result = {}\n")
            m = measure(code)
        print(f"  {label}: {m['seconds']:.1f} s, {n / m['seconds'] / 1e6:.2f} M points/s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="command", required=True)
    a = sub.add_parser("agree", help="chunked vs whole classes on the ISPRS samples and FSite5")
    a.add_argument("--chunk", type=float, default=100.0)
    a.add_argument("--point-buffer", type=float, help="buffer of the point filters (m; default: auto)")
    a.add_argument("--sites", action="store_true", help="the ISPRS sites FSite5 and CSite1 instead of the samples")
    a.add_argument("--filters", nargs="+", help="only these filters")
    m = sub.add_parser("memory", help="gapm on a big LAZ in chunks")
    m.add_argument("--points", type=float, default=100.0, help="millions of points")
    m.add_argument("--chunk", type=float, default=2000.0)
    m.add_argument("--whole", action="store_true", help="also the whole file at once (memory grows with it)")
    d = sub.add_parser("dense", help="gapm's defaults streamed over a dense LAZ of N M points")
    d.add_argument("--points", type=float, default=100.0, help="millions of points")
    d.add_argument("--layers", type=int, default=10, help="copies of the tiled site laid over one another")
    d.add_argument("--las14", action="store_true", help="LAS 1.4, point format 6 (as surveys are delivered)")
    d.add_argument("--chunked", type=float, metavar="C", help="also --chunk C -j 2 on the same file")
    d.add_argument("--compare", action="store_true", help="also every point in memory: classes identical?")
    t = sub.add_parser("tiles", help="a worksheet over tiles with -j 1, -j 2 and a local Dask cluster")
    t.add_argument("--tiles", type=int, default=16)
    args = ap.parse_args()
    if args.command == "agree":
        run_agree(args.chunk, args.point_buffer, args.filters, args.sites)
    elif args.command == "memory":
        run_memory(args.points, args.chunk, args.whole)
    elif args.command == "dense":
        run_dense(args.points, args.layers, args.las14, args.chunked, args.compare)
    else:
        run_tiles(args.tiles)


if __name__ == "__main__":
    main()
