"""Grid filters at the cell sizes people use: 1 m cells over 10 M real points, against SMRF.

    python bench/bench_cells.py                    # every grid filter + the peers, 1 m cells
    python bench/bench_cells.py --algos gapm gapm-defaults --check
    python bench/bench_cells.py --threads 1 2 --algos gapm --no-peers
    python bench/bench_cells.py stages             # the share of each step of gapm's two runs

Reads ``bench/data_paths.FSITE5`` (the ISPRS site FSite5, outside the repository) and builds once,
under ``bench/_work/``, a LAS of 16 tiled copies of it: 10,053,120 points on about 32 M cells of
1 m. Each row is ``aldpat filter ALGO FILE --cell 1 --result classified`` in a fresh process
(read, grid, filter, classify, write a classified LAS), with its wall time, points per second and
peak resident memory (``VmHWM``). ``gapm`` uses the dissertation's parameter set 01
(``jobs/params/gapm-isprs-set01.toml``), ``gapm-defaults`` gapm's built-in defaults (set 01
followed by the raised-segment and surface tests), every other filter its shipped parameter
file; all on 1 m cells.

Peers in the same run, on the same file and cell size: PDAL's ``filters.smrf`` with its defaults
when a ``pdal`` binary is on PATH (its time only: the peak printed is this script's wrapper's;
``bench/bench_pdal.py`` measures PDAL's own, finds it from ``$ALDPAT_PDAL`` too and sets the ratios
users see); otherwise (and besides) the SMRF of ``pysmrf`` with PDAL's
defaults (1 m cells, 18 m window, slope 0.15, threshold 0.5 m, scalar 1.25), whitebox-workflows'
``improved_ground_point_filter`` and CSF -- each if installed (``pip install ".[peers]"``),
otherwise reported as missing.

``--check`` also filters the points held in memory (``aldpat.filters.ground_filter``) and
compares every point's class with the file the command wrote: the two-pass run must not change
a single class. ``--threads N ...`` repeats each aldpat row with ``ALDPAT_THREADS=N``.

``stages`` runs gapm (set 01 and defaults) in this process with a timer around each step; the second
pass classifies a chunk while a thread writes the one before, so its two parts are shown under it
and overlap.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(HERE))

from _measure import measure, mib

PARAMS = REPO / "jobs" / "params"
WORK = HERE / "_work"
OUT = WORK / "out_cells"
POINTS = 10_053_120
CELL = 1.0
ALGOS = ("gapm", "gapm-defaults", "pm", "pm2d", "pmcircle", "etew", "cluster-pm", "multipass", "outlier")
PEERS = ("pdal-smrf", "pysmrf", "wbw-igpf", "csf")
NOISE = (7, 18)  # ASPRS low and high noise


def source_file() -> Path:
    from bench_filters import build_sites  # the tiled FSite5 file the other filter benchmarks use

    return build_sites(POINTS)


def filter_and_params(row: str) -> tuple[str, dict]:
    """The registered filter of a row and its parameters (1 m cells)."""
    if row == "gapm-defaults":
        return "gapm", {"cell": CELL}
    path = PARAMS / ("gapm-isprs-set01.toml" if row == "gapm" else f"{row}.toml")
    values = tomllib.loads(path.read_text())
    values["cell"] = CELL
    return row, values


def aldpat_code(row: str, las: Path) -> str:
    algo, values = filter_and_params(row)
    return (
        f"import sys; sys.path.insert(0, {str(REPO)!r})\n"
        "from aldpat.tasks import get_task\n"
        f"rep = get_task('filter', {algo!r})([{str(las)!r}], odir={str(OUT / row)!r}, overwrite=True, "
        f"result='classified', **{values!r})\n"
        "assert rep.exit_code == 0, [r.error for r in rep.results]\n"
        "result = dict(n=sum(w.count for w in rep.outputs))"
    )


def peer_code(name: str, las: Path) -> str | None:
    """Python code running peer ``name`` on ``las`` (``None`` when it is not installed here)."""
    out = OUT / f"{name}.las"
    if name == "pdal-smrf":
        if not shutil.which("pdal"):
            return None
        pipeline = (f'[{{"type": "readers.las", "filename": "{las}"}}, {{"type": "filters.smrf"}}, '
                    f'{{"type": "writers.las", "filename": "{out}"}}]')
        return ("import subprocess\n"
                f"subprocess.run(['pdal', 'pipeline', '--stdin'], input={pipeline!r}, text=True, check=True)\n"
                "result = dict(n=0)")
    module = {"pysmrf": "pysmrf", "wbw-igpf": "whitebox_workflows", "csf": "CSF"}[name]
    try:
        __import__(module)
    except ImportError:
        return None
    if name == "pysmrf":
        # PDAL's filters.smrf defaults: 1 m cells, 18 m window, slope 0.15, threshold 0.5 m, scalar 1.25
        return (
            "import laspy, numpy as np, pysmrf\n"
            f"las = laspy.read({str(las)!r})\n"
            "r = pysmrf.classify(np.asarray(las.x), np.asarray(las.y), np.asarray(las.z), cellsize=1.0,\n"
            "                    windows=18, slope_threshold=0.15, elevation_threshold=0.5, elevation_scaler=1.25)\n"
            "las.classification[:] = np.where(r.is_ground, 2, 1)\n"
            f"las.write({str(out)!r})\n"
            "result = dict(n=len(las.points))"
        )
    if name == "wbw-igpf":
        return (
            "import whitebox_workflows as wbw\n"
            "wbw.WbEnvironment().lidar.filtering_classification.improved_ground_point_filter(\n"
            f"    input={str(las)!r}, output={str(out)!r}, classify=True)\n"
            "result = dict(n=0)"
        )
    return (
        "import laspy, numpy as np, CSF\n"
        f"las = laspy.read({str(las)!r})\n"
        "c = CSF.CSF(); c.params.bSloopSmooth = True; c.params.cloth_resolution = 1.0\n"
        "c.params.rigidness = 2; c.params.class_threshold = 0.5\n"
        "c.setPointCloud(np.column_stack([las.x, las.y, las.z]))\n"
        "g, o = CSF.VecInt(), CSF.VecInt(); c.do_filtering(g, o, False)\n"
        "las.classification[:] = 1; las.classification[np.asarray(g, dtype=np.int64)] = 2\n"
        f"las.write({str(out)!r})\n"
        "result = dict(n=len(las.points))"
    )


def check_classes(row: str, las: Path) -> str:
    """Whether the classes the command wrote equal those of the points filtered in memory: the
    ground class for a ground filter; for a noise filter (``outlier``, whose classified output
    writes only low and high noise, 7 and 18, and keeps every other class) the noise classes."""
    import laspy

    from aldpat.filters import FILTERS, ground_filter
    from aldpat.params import resolve
    from aldpat.tasks.filter import point_classes

    algo, values = filter_and_params(row)
    points = laspy.read(las)
    params = resolve(FILTERS[algo].params, [("bench", values)]).values
    z = np.asarray(points.z)
    result = ground_filter(np.asarray(points.x), np.asarray(points.y), z, algo, params)
    written = np.asarray(laspy.read(OUT / row / f"{las.stem}_{algo}.las").classification)
    if FILTERS[algo].noise is None:
        differ = int(((written == 2) != result.is_ground).sum())
    else:  # 18 is written as 7 in point formats 0-5: compare noise or not
        expected = point_classes(result, z, params, algo)
        differ = int((np.isin(written, NOISE) != np.isin(expected, NOISE)).sum())
    return "identical" if differ == 0 else f"{differ} points differ"


def run_table(algos: list[str], threads: list[int | None], peers: bool, check: bool, repeat: int) -> None:
    las = source_file()
    OUT.mkdir(parents=True, exist_ok=True)
    print(f"# {las.name}: {POINTS:,} points, {CELL:g} m cells; each row a fresh process "
          f"(read, grid, filter, classify, write); best of {repeat}")
    print(f"{'filter':14} {'threads':>7} {'time':>9} {'points/s':>11} {'peak RSS':>10}  classes")
    budget = os.environ.get("ALDPAT_THREADS")
    for row in algos:
        for n in threads:
            if n is None:
                os.environ.pop("ALDPAT_THREADS", None)
            else:
                os.environ["ALDPAT_THREADS"] = str(n)
            runs = [measure(aldpat_code(row, las)) for _ in range(repeat)]
            best = min(runs, key=lambda r: r["seconds"])
            peak = max(r["peak_bytes"] for r in runs)
            verdict = check_classes(row, las) if check else ""
            print(f"{row:14} {n or 'all':>7} {best['seconds']:7.1f} s {POINTS / best['seconds'] / 1e6:7.2f} M/s "
                  f"{mib(peak):>10}  {verdict}", flush=True)
    if budget is None:
        os.environ.pop("ALDPAT_THREADS", None)
    else:
        os.environ["ALDPAT_THREADS"] = budget
    if not peers:
        return
    for name in PEERS:
        code = peer_code(name, las)
        if code is None:
            print(f"{name:14} {'':>7} not installed here")
            continue
        try:
            r = measure(code)
        except RuntimeError as exc:
            print(f"{name:14} failed: {str(exc).strip().splitlines()[-1][:100]}")
            continue
        print(f"{name:14} {'':>7} {r['seconds']:7.1f} s {POINTS / r['seconds'] / 1e6:7.2f} M/s "
              f"{mib(r['peak_bytes']):>10}  peer", flush=True)


# ---------------------------------------------------------------------------- stages

#: the label of a step timed inside another (its share is of the whole run, not added to the rest)
PART = "- of which: "


def run_stages(repeat: int) -> None:
    """gapm's two runs with a timer around each step, in this process (after a first run that
    loads every library): wall seconds and CPU seconds of the process (all its threads) in each
    step. On a machine shared with other work the wall time stretches with the load; the CPU
    time much less, so it is the figure to compare between two versions of a step there."""
    from aldpat.core import segments, spans, surface_check
    from aldpat.filters import classify, gapm, grid_stage, streamed
    from aldpat.io import las as las_io
    from aldpat.tasks import filter as filter_task
    from aldpat.tasks import get_task

    las = source_file()
    spent: dict[str, tuple[float, float]] = {}

    def timed(owner, name: str, label: str):
        fn = getattr(owner, name)

        def wrapper(*args, **kwargs):
            start, cpu = time.perf_counter(), time.process_time()
            try:
                return fn(*args, **kwargs)
            finally:
                wall_before, cpu_before = spent.get(label, (0.0, 0.0))
                spent[label] = (wall_before + time.perf_counter() - start, cpu_before + time.process_time() - cpu)

        setattr(owner, name, wrapper)

    timed(streamed, "lowest_codes", "pass 1: read and grid the lowest points")
    timed(grid_stage, "find_low_outliers", "low-outlier test")
    timed(grid_stage, "fill_nearest", "fill the empty cells (nearest neighbour)")
    timed(segments, "raised_segments", "raised-segment test")
    timed(spans, "raised_spans", "raised spans")
    timed(gapm, "adaptive_sequential", "gapm's row and column passes")
    timed(surface_check.SurfaceTest, "build", "provisional surface and slope")
    timed(filter_task, "_write_from_classes", "pass 2: read, classify and write every point")
    # the second pass writes a chunk on a thread while it classifies the next: its two parts overlap
    timed(classify.CellClasses, "classify", PART + "classify (the pass's own thread)")
    timed(las_io.LasWriter, "write", PART + "write the classified LAS (a thread beside it)")
    for row in ("gapm", "gapm-defaults"):
        algo, values = filter_and_params(row)
        get_task("filter", algo)([str(las)], odir=str(OUT / row), overwrite=True, result="classified", **values)
        best: dict[str, tuple[float, float]] = {}
        total, total_cpu = float("inf"), 0.0
        for _ in range(repeat):
            spent.clear()
            start, cpu = time.perf_counter(), time.process_time()
            get_task("filter", algo)([str(las)], odir=str(OUT / row), overwrite=True, result="classified", **values)
            wall = time.perf_counter() - start
            if wall < total:
                total, total_cpu, best = wall, time.process_time() - cpu, dict(spent)
        print(f"\n### {row}: {total:.1f} s in all, {total_cpu:.1f} CPU s (best of {repeat}, in-process: no "
              f"start-up; load average {os.getloadavg()[0]:.1f})\n")
        print("| step | seconds | share | CPU seconds |\n|---|---|---|---|")
        whole = {label: spent for label, spent in best.items() if not label.startswith(PART)}
        parts = {label: spent for label, spent in best.items() if label.startswith(PART)}
        for label, (seconds, cpu_seconds) in whole.items():
            print(f"| {label} | {seconds:.2f} | {100 * seconds / total:.0f} % | {cpu_seconds:.2f} |")
            if label.startswith("pass 2"):  # its two overlapping parts under it
                for part, (part_seconds, part_cpu) in parts.items():
                    print(f"| {part} | {part_seconds:.2f} | {100 * part_seconds / total:.0f} % | {part_cpu:.2f} |")
        rest = total - sum(w for w, _ in whole.values())
        rest_cpu = total_cpu - sum(c for _, c in whole.values())
        print(f"| the rest (the marks, files) | {rest:.2f} | {100 * rest / total:.0f} % | {rest_cpu:.2f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("what", nargs="?", default="table", choices=("table", "stages"))
    ap.add_argument("--algos", nargs="+", default=list(ALGOS), choices=ALGOS)
    ap.add_argument("--threads", nargs="+", type=int, default=None, help="ALDPAT_THREADS for each aldpat row")
    ap.add_argument("--no-peers", action="store_true", help="leave out PDAL / pysmrf / whitebox / CSF")
    ap.add_argument("--check", action="store_true", help="compare the classes with the in-memory filter")
    ap.add_argument("--repeat", type=int, default=1, help="runs per aldpat row (best time, largest memory)")
    args = ap.parse_args()
    if args.what == "stages":
        run_stages(max(1, args.repeat))
        return
    run_table(args.algos, args.threads or [None], not args.no_peers, args.check, max(1, args.repeat))


if __name__ == "__main__":
    main()
