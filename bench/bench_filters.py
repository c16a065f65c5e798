"""Ground filters: ISPRS accuracy and speed of every registered filter.

    python bench/bench_filters.py isprs                      # Type I / II / total per sample
    python bench/bench_filters.py isprs --algos pm gapm --params gapm=jobs/params/gapm-isprs-set01.toml
    python bench/bench_filters.py isprs --peers              # plus SMRF, CSF and whitebox-workflows
    python bench/bench_filters.py speed                      # 10 M points end to end, each in a fresh process
    python bench/bench_filters.py speed --algos gapm --params gapm=jobs/params/gapm-isprs-set01.toml --peers

``isprs`` runs every registered filter on all points of the seven ISPRS samples
(``bench/data_paths.py`` says where) with ``jobs/params/<algo>.toml`` when
that file exists (defaults otherwise, or the file given with ``--params algo=FILE``), prints
Type I, Type II, total error and kappa per sample, the mean total, and the filter's points per
second (gridding + filter + classification, in process).

``speed`` builds a large LAS once under ``bench/_work/`` -- ``--source sites``: tiled copies of
the raw ISPRS site FSite5 (0.31 points/m2, so a 1 m grid has three cells per point);
``--source isprs``: tiled copies of ISPRS samp12, urban, about 1 point/m2 -- and times
``aldpat filter ALGO`` end to end (read LAS, grid, filter, classify, write a classified LAS) in a
fresh process per algorithm, reporting points/second and peak resident memory. ``--peers`` adds
SMRF with PDAL's defaults (the pysmrf package; ``isprs`` only), the CSF package
(cloth-simulation-filter) and whitebox-workflows' improved_ground_point_filter, when installed
(benchmark-only extras, never dependencies of aldpat).
"""

from __future__ import annotations

import argparse
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

BENCH = Path(__file__).resolve().parent
REPO = BENCH.parent
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(BENCH))

from _measure import measure, mib
from data_paths import ISPRS_SITES
from isprs import PUBLISHED_GAPM_SET01, SAMPLES, Sample, load_samples, score

WORK = BENCH / "_work"
SITES = ISPRS_SITES


def rate(n: int, seconds: float) -> str:
    """Points per second, readable from thousands to millions."""
    r = n / seconds if seconds > 0 else float("inf")
    return f"{r / 1e6:6.2f} M/s" if r >= 1e5 else f"{r / 1e3:6.1f} k/s"


# ---------------------------------------------------------------------------- parameters


def load_params(algo: str, path: Path | None):
    """The filter's params from a TOML file (filter keys only; task keys such as ``result``
    are ignored), or its defaults when there is no file."""
    from aldpat.filters import FILTERS
    from aldpat.params import resolve, spec_map

    cls = FILTERS[algo].params
    if path is None or not path.exists():
        return cls(), "defaults"
    data = tomllib.loads(path.read_text())
    known = spec_map(cls)
    return resolve(cls, [("params file", {k: v for k, v in data.items() if k in known})]).values, str(path)


def params_for(algos, overrides: dict[str, str], params_dir: Path):
    out = {}
    for a in algos:
        path = Path(overrides[a]) if a in overrides else params_dir / f"{a}.toml"
        out[a] = load_params(a, path)
    return out


def parse_overrides(items) -> dict[str, str]:
    out = {}
    for item in items or []:
        algo, _, path = item.partition("=")
        if not path:
            raise SystemExit(f"--params expects ALGO=FILE, got {item!r}")
        out[algo] = path
    return out


# ---------------------------------------------------------------------------- ISPRS accuracy


def run_isprs(algos, params, samples: list[Sample]) -> dict:
    from aldpat.filters import ground_filter

    table = {}
    for algo in algos:
        p, source = params[algo]
        scores, seconds = {}, 0.0
        for s in samples:
            t0 = time.perf_counter()
            res = ground_filter(s.x, s.y, s.z, algo, p)
            seconds += time.perf_counter() - t0
            scores[s.name] = score(s.ground, res.is_ground)
        table[algo] = {"scores": scores, "seconds": seconds, "source": source}
    return table


def peer_csf(s: Sample) -> np.ndarray:
    """CSF (Zhang et al. 2016) with settings for relief terrain and slope smoothing."""
    import CSF

    c = CSF.CSF()
    c.params.bSloopSmooth = True
    c.params.cloth_resolution = 1.0
    c.params.rigidness = 2
    c.params.class_threshold = 0.5
    c.setPointCloud(np.column_stack([s.x, s.y, s.z]))
    ground, other = CSF.VecInt(), CSF.VecInt()
    c.do_filtering(ground, other, False)
    out = np.zeros(len(s), bool)
    out[np.asarray(ground, dtype=np.int64)] = True
    return out


def _write_las(path: Path, x, y, z) -> None:
    import laspy

    header = laspy.LasHeader(point_format=0, version="1.2")
    header.scales = np.array([0.001, 0.001, 0.001])
    header.offsets = np.floor(np.array([x.min(), y.min(), z.min()]))
    las = laspy.LasData(header)
    las.x, las.y, las.z = x, y, z
    las.write(path)


def peer_whitebox(s: Sample) -> np.ndarray:
    """whitebox-workflows improved_ground_point_filter with its defaults, classify mode."""
    import laspy
    import whitebox_workflows as wbw

    WORK.mkdir(exist_ok=True)
    src, dst = WORK / f"{s.name}_in.las", WORK / f"{s.name}_wbw.las"
    _write_las(src, s.x, s.y, s.z)
    wbw.WbEnvironment().lidar.filtering_classification.improved_ground_point_filter(
        input=str(src), output=str(dst), classify=True)
    las = laspy.read(dst)
    if len(las.points) != len(s) or not np.allclose(np.asarray(las.x), s.x, atol=0.002):
        raise RuntimeError("whitebox reordered or dropped points")
    return np.asarray(las.classification) == 2


def peer_smrf(s: Sample) -> np.ndarray:
    """SMRF (Pingel et al. 2013) as pysmrf implements it, with PDAL ``filters.smrf``'s defaults:
    1 m cells, 18 m window, slope 0.15, elevation threshold 0.5 m, scalar 1.25."""
    import pysmrf

    r = pysmrf.classify(s.x, s.y, s.z, cellsize=1.0, windows=18, slope_threshold=0.15,
                        elevation_threshold=0.5, elevation_scaler=1.25)
    return np.asarray(r.is_ground, dtype=bool)


PEERS = {"smrf-pdal-defaults": peer_smrf, "csf": peer_csf, "wbw-igpf": peer_whitebox}


def run_peers(samples: list[Sample]) -> dict:
    table = {}
    for name, fn in PEERS.items():
        scores, seconds = {}, 0.0
        try:
            for s in samples:
                t0 = time.perf_counter()
                ground = fn(s)
                seconds += time.perf_counter() - t0
                scores[s.name] = score(s.ground, ground)
        except ImportError as exc:
            print(f"# {name}: not installed ({exc.name})")
            continue
        table[name] = {"scores": scores, "seconds": seconds, "source": "peer"}
    return table


def print_isprs(table: dict, samples: list[Sample]) -> None:
    n = sum(len(s) for s in samples)
    names = [s.name for s in samples]
    print(f"{'algorithm':12} {'sample':8} {'type I %':>9} {'type II %':>9} {'total %':>8} {'kappa':>7}")
    for algo, row in table.items():
        for name in names:
            sc = row["scores"][name]
            print(f"{algo:12} {name:8} {sc.type1:9.2f} {sc.type2:9.2f} {sc.total:8.2f} {sc.kappa:7.4f}")
        mean = np.mean([row["scores"][k].total for k in names])
        print(f"{algo:12} {'mean':8} {'':9} {'':9} {mean:8.2f}   (filter {rate(n, row['seconds']).strip()}; "
              f"params: {row['source']})")
    print()
    print("mean total error % (per-sample totals)   " + "  ".join(f"{k:>7}" for k in names))
    for algo, row in table.items():
        mean = np.mean([row["scores"][k].total for k in names])
        print(f"{algo:12} {mean:6.2f}                      " + "  ".join(
            f"{row['scores'][k].total:7.2f}" for k in names))
    pub = [PUBLISHED_GAPM_SET01[k][0] for k in names if k in PUBLISHED_GAPM_SET01]
    if len(pub) == len(names):
        print(f"{'published':12} {np.mean(pub):6.2f}                      " + "  ".join(f"{v:7.2f}" for v in pub)
              + "   (GAPM set 01, dissertation Table 6-9)")


# ---------------------------------------------------------------------------- speed


def build_sites(n_target: int) -> Path:
    """Tiled copies of FSite5 (first + last returns) side by side, ``n_target`` points or more."""
    import laspy

    src = laspy.read(SITES / "FSite5_orig-utm.laz")
    copies = -(-n_target // len(src.points))
    side = int(np.ceil(np.sqrt(copies)))
    path = WORK / f"fsite5_x{copies}.las"
    if path.exists():
        return path
    h = src.header
    width = np.ceil((h.maxs[0] - h.mins[0]) / 10 + 1) * 10
    height = np.ceil((h.maxs[1] - h.mins[1]) / 10 + 1) * 10
    X, Y = np.asarray(src.X), np.asarray(src.Y)
    parts = []
    for k in range(copies):
        a = src.points.array.copy()
        a["X"] = X + round((k % side) * width / h.scales[0])
        a["Y"] = Y + round((k // side) * height / h.scales[1])
        parts.append(a)
    out = laspy.LasData(laspy.LasHeader(point_format=h.point_format, version=h.version))
    out.header.scales, out.header.offsets = h.scales, h.offsets
    out.points = laspy.PackedPointRecord(np.concatenate(parts), h.point_format)
    WORK.mkdir(exist_ok=True)
    out.write(path)
    return path


def build_isprs(n_target: int, name: str = "samp12") -> Path:
    """Tiled copies of one ISPRS sample (samp12: urban, about 1 point/m2), packed edge to edge."""
    (s,) = load_samples([name])
    copies = -(-n_target // len(s))
    side = int(np.ceil(np.sqrt(copies)))
    path = WORK / f"{name}_x{copies}.las"
    if path.exists():
        return path
    width = np.ceil(s.x.max() - s.x.min() + 1.0)
    height = np.ceil(s.y.max() - s.y.min() + 1.0)
    k = np.arange(copies)
    dx = np.repeat((k % side) * width, len(s))
    dy = np.repeat((k // side) * height, len(s))
    WORK.mkdir(exist_ok=True)
    _write_las(path, np.tile(s.x, copies) + dx, np.tile(s.y, copies) + dy, np.tile(s.z, copies))
    return path


def speed_code(algo: str, las: Path, params_file: str | None) -> str:
    kwargs = {}
    if params_file:
        from aldpat.filters import FILTERS
        from aldpat.params import spec_map

        known = spec_map(FILTERS[algo].params)
        kwargs = {k: v for k, v in tomllib.loads(Path(params_file).read_text()).items() if k in known}
    odir = WORK / "out"
    return (
        f"import sys; sys.path.insert(0, {str(REPO)!r})\n"
        "from aldpat.tasks import get_task\n"
        f"rep = get_task('filter', {algo!r})([{str(las)!r}], odir={str(odir)!r}, overwrite=True, "
        f"result='classified', **{kwargs!r})\n"
        "assert rep.exit_code == 0, [r.error for r in rep.results]\n"
        "result = dict(n=sum(w.count for w in rep.outputs))"
    )


def peer_speed_code(name: str, las: Path) -> str:
    if name == "csf":
        return (
            "import laspy, numpy as np, CSF\n"
            f"las = laspy.read({str(las)!r})\n"
            "c = CSF.CSF(); c.params.bSloopSmooth = True; c.params.cloth_resolution = 1.0\n"
            "c.params.rigidness = 2; c.params.class_threshold = 0.5\n"
            "c.setPointCloud(np.column_stack([las.x, las.y, las.z]))\n"
            "g, o = CSF.VecInt(), CSF.VecInt(); c.do_filtering(g, o, False)\n"
            "las.classification[:] = 1; las.classification[np.asarray(g, dtype=np.int64)] = 2\n"
            f"las.write({str(WORK / 'out' / 'csf.las')!r})\n"
            "result = dict(n=len(las.points))"
        )
    return (
        "import whitebox_workflows as wbw\n"
        "wbw.WbEnvironment().lidar.filtering_classification.improved_ground_point_filter(\n"
        f"    input={str(las)!r}, output={str(WORK / 'out' / 'wbw.las')!r}, classify=True)\n"
        f"import laspy; result = dict(n=laspy.open({str(WORK / 'out' / 'wbw.las')!r}).header.point_count)"
    )


def run_speed(algos, overrides, params_dir: Path, source: str, millions: float, peers: bool) -> None:
    n_target = int(millions * 1_000_000)
    las = build_sites(n_target) if source == "sites" else build_isprs(n_target)
    (WORK / "out").mkdir(parents=True, exist_ok=True)
    import laspy

    n = laspy.open(las).header.point_count
    print(f"# {las.name}: {n:,} points; each row is a fresh process (read, grid, filter, classify, write)")
    print(f"{'algorithm':12} {'params':34} {'time':>9} {'rate':>14} {'peak RSS':>10}")
    for algo in algos:
        pf = overrides.get(algo)
        if pf is None and (params_dir / f"{algo}.toml").exists():
            pf = str(params_dir / f"{algo}.toml")
        r = measure(speed_code(algo, las, pf))
        label = Path(pf).name if pf else "defaults"
        print(f"{algo:12} {label:34} {r['seconds']:7.1f} s {rate(n, r['seconds']):>12} {mib(r['peak_bytes']):>10}",
              flush=True)
    if peers:
        for name in ("csf", "wbw-igpf"):
            try:
                r = measure(peer_speed_code(name, las))
            except RuntimeError as exc:
                print(f"{name:12} failed: {str(exc).strip().splitlines()[-1][:100]}")
                continue
            print(f"{name:12} {'peer':34} {r['seconds']:7.1f} s {rate(n, r['seconds']):>12} "
                  f"{mib(r['peak_bytes']):>10}", flush=True)


# ---------------------------------------------------------------------------- main


def main() -> None:
    import aldpat.filters

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("what", choices=("isprs", "speed"))
    ap.add_argument("--algos", nargs="+", default=sorted(aldpat.filters.FILTERS))
    ap.add_argument("--params", nargs="*", metavar="ALGO=FILE", help="parameter file for an algorithm")
    ap.add_argument("--params-dir", type=Path, default=REPO / "jobs" / "params",
                    help="where <algo>.toml files are looked for (default: jobs/params)")
    ap.add_argument("--samples", nargs="+", default=list(SAMPLES))
    ap.add_argument("--peers", action="store_true", help="also run SMRF (PDAL's defaults), CSF and whitebox-workflows")
    ap.add_argument("--source", choices=("sites", "isprs"), default="sites", help="speed: data to tile")
    ap.add_argument("--points", type=float, default=10.0, help="speed: millions of points")
    args = ap.parse_args()
    overrides = parse_overrides(args.params)
    unknown = set(args.algos) - set(aldpat.filters.FILTERS)
    if unknown:
        raise SystemExit(f"unknown algorithms: {', '.join(sorted(unknown))}")
    if args.what == "isprs":
        samples = load_samples(args.samples)
        table = run_isprs(args.algos, params_for(args.algos, overrides, args.params_dir), samples)
        if args.peers:
            table.update(run_peers(samples))
        print_isprs(table, samples)
    else:
        run_speed(args.algos, overrides, args.params_dir, args.source, args.points, args.peers)


if __name__ == "__main__":
    main()
