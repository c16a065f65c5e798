"""Re-measure every speed and memory figure of README.md and bench/README.md in one sitting.

    python bench/remeasure_speed.py --list                 # the steps, their commands, the expected time
    python bench/remeasure_speed.py                        # every step, most important first, into one log
    python bench/remeasure_speed.py --first 3              # only the first three steps
    python bench/remeasure_speed.py --only pdal cells      # named steps (or groups: core, long, peers)
    python bench/remeasure_speed.py --smoke                # every step at a tiny size: do the commands run?

Each step is the bench command whose figures the READMEs quote, at the sizes they quote, run from
the repository root in series. The log (``bench/_work/remeasure-<UTC time>.log`` unless
``--log``) holds, for every command: the command line, ``uptime`` before, everything it printed,
``uptime`` after, its wall time and exit status; a summary table closes it. A figure copied from
it into a README must say the date and the load printed beside it; on a machine shared with
other work the figures are not a quiet machine's, and the log says so by its load.

Run it alone on the machine (here: ``flock /tmp/aldpat-heavy.lock python bench/remeasure_speed.py``)
with the data and PDAL the benches read::

    ALDPAT_DATA=/path/to/data ALDPAT_PDAL="env LD_LIBRARY_PATH=/path/pdal-lib /path/pdal" \\
        python bench/remeasure_speed.py

Without PDAL the first step still runs but quotes PDAL's stored figures (it says so loudly): the
ratios against PDAL then are not measured. The ``peers`` steps need ``pip install ".[peers]"``
(CSF, whitebox-workflows, pysmrf; pysmrf takes about 20 GB on 10 M points) and, for PDAL's row of
``bench_cells.py``, ``pdal`` on PATH. A step that fails is logged and the next one runs.

The expected minutes are the recorded figures' wall times on a quiet 2-core machine (or, where
only loaded runs were recorded, those scaled down by their load), plus building the input files
the first time; they say how long to set aside, not what the run will show.
"""

from __future__ import annotations

import argparse
import os
import shlex
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

BENCH = Path(__file__).resolve().parent
REPO = BENCH.parent
WORK = BENCH / "_work"
sys.path.insert(0, str(BENCH))

from data_paths import ISPRS_SITES

PY = "python"  # replaced by this interpreter when run

#: parameter files some steps need beside the shipped ones (written under bench/_work/)
AUTO_PARAMS = WORK / "gapm-auto.toml"
NO_LOW_OUTLIERS = WORK / "gapm-low-outliers-none.toml"


@dataclass(frozen=True)
class Step:
    """One bench command (or a few) whose output holds figures of the READMEs."""

    name: str
    group: str  # "core": short, most of the figures; "long": long runs; "peers": other tools
    minutes: float  # expected wall time at full size on a quiet 2-core machine
    figures: str  # where its figures go
    commands: tuple[str, ...]
    smoke: tuple[str, ...] = field(default=())  # the same commands at tiny sizes
    needs: str = ""


PDAL_ROWS = "pdal-smrf gapm-defaults gapm-set01 pdal-dtm dtm grid-linear multipass outlier"
#: a real site small enough for a smoke run (21,714 points; the strip of tests/data has no returns for PDAL)
FSITE8 = shlex.quote(str(ISPRS_SITES / "FSite8_red2-utm.laz"))
SET01 = "jobs/params/gapm-isprs-set01.toml"
CSITE1 = shlex.quote(str(ISPRS_SITES / "CSite1_red2-utm.laz"))


def cells(args: str) -> str:
    """bench_cells.py has no --file: its smoke runs on FSite5 once (628,320 points, not 10 M)."""
    argv = ["bench_cells.py", *shlex.split(args)]
    return (f"{PY} -c " + shlex.quote(f"import sys; sys.path.insert(0, 'bench'); sys.argv = {argv!r}; "
                                      "import bench_cells as b; b.POINTS = 600_000; b.main()"))


STEPS: tuple[Step, ...] = (
    Step("pdal", "core", 10.0,
         "bench/README 'aldpat against PDAL' (a new same-run table; every ratio) and README.md "
         "'Big files' (gapm, set 01 and dtm against PDAL's smrf and DTM pipeline, their times and peaks); "
         "'dtm after its filter' (dtm, pdal-dtm, grid-linear over gapm); 'multipass and outlier'",
         (f"{PY} bench/bench_pdal.py --rows {PDAL_ROWS}",),
         (f"{PY} bench/bench_pdal.py --file {FSITE8} --rows {PDAL_ROWS}",), needs="ALDPAT_PDAL"),
    Step("cells", "core", 7.0,
         "bench/README 'Grid filters at 1 m cells' first table (9 filters: time, points/s, peak, "
         "classes identical); bench_auto's speed paragraph (gapm-defaults at 1 m on FSite5)",
         (f"{PY} bench/bench_cells.py --no-peers --check",),
         (cells("--algos gapm gapm-defaults multipass outlier --no-peers --check"),)),
    Step("cells-stages", "core", 2.0,
         "bench/README 'Grid filters at 1 m cells' stages table (wall and CPU s per step, set 01 and defaults)",
         (f"{PY} bench/bench_cells.py stages --repeat 2",),
         (cells("stages --repeat 1"),)),
    Step("cells-threads", "core", 4.0,
         "bench/README 'Grid filters at 1 m cells' threads paragraph (1 and 2 threads, best of 3)",
         (f"{PY} bench/bench_cells.py --threads 1 2 --algos gapm gapm-defaults --repeat 3 --no-peers",),
         (cells("--threads 1 2 --algos gapm --no-peers"),)),
    Step("filters-isprs", "core", 6.0,
         "bench/README 'Ground filters: speed' table (12 filters on samp12 tiled, 10 M points) and "
         "'Point filters: speed' table (its slope, ipf, poly2, atin rows)",
         (f"{PY} bench/bench_filters.py speed --source isprs --points 10 --params gapm={SET01}",),
         (f"{PY} bench/bench_filters.py speed --source isprs --points 0.1 --params gapm={SET01}",)),
    Step("gapm-isprs", "core", 1.5,
         "bench/README gapm accuracy section's speed paragraph: gapm's defaults and --auto on samp12 "
         "tiled (10 M), and the low-outlier test's cost (jobs/params/gapm.toml with and without it)",
         (f"{PY} bench/bench_filters.py speed --source isprs --points 10 --algos gapm",
          f"{PY} bench/bench_filters.py speed --source isprs --points 10 --algos gapm --params gapm={AUTO_PARAMS.relative_to(REPO)}",
          f"{PY} bench/bench_filters.py speed --source isprs --points 10 --algos gapm --params gapm={NO_LOW_OUTLIERS.relative_to(REPO)}"),
         (f"{PY} bench/bench_filters.py speed --source isprs --points 0.1 --algos gapm",
          f"{PY} bench/bench_filters.py speed --source isprs --points 0.1 --algos gapm --params gapm={AUTO_PARAMS.relative_to(REPO)}",
          f"{PY} bench/bench_filters.py speed --source isprs --points 0.1 --algos gapm --params gapm={NO_LOW_OUTLIERS.relative_to(REPO)}")),
    Step("gapm-2m", "core", 1.0,
         "bench/README 'Ground filters: speed' first bullet (FSite5 tiled, set 01 on 2 m cells; three runs)",
         (f"{PY} bench/bench_gapm.py speed --points 10 --cell 2.0 --algos gapm",) * 3,
         (f"{PY} bench/bench_gapm.py speed --points 0.5 --cell 2.0 --algos gapm",)),
    Step("grid", "core", 3.5,
         "bench/README 'Terrain grids' table (nearest, linear, idw, min/max/mean, kriging at 10 M points)",
         (f"{PY} bench/bench_grid.py",),
         (f"{PY} bench/bench_grid.py --points 0.05",)),
    Step("dtm-speed", "core", 0.5,
         "bench/README 'One-command DTMs' speed paragraph (FSite5 in 3 x 3 LAZ tiles, -j 1 and -j 2)",
         (f"{PY} bench/bench_dtm.py speed --tiles 3 --cell 1",),
         (f"{PY} bench/bench_dtm.py speed --tiles 2 --cell 4",)),
    Step("dtm-project", "core", 1.5,
         "bench/README 'A project in tiles' table (tile, dtm, grid, filter, merge seconds; FSite5 and CSite1)",
         (f"{PY} bench/bench_dtm.py project", f"{PY} bench/bench_dtm.py project --site CSite1_red2-utm"),
         (f"{PY} bench/bench_dtm.py project --site FSite8_red2-utm",)),
    Step("chunks-tiles", "core", 4.0,
         "bench/README 'A 100 M-point file in chunks, and tiles on a cluster': the tiles table "
         "(16 tiles, -j 1, -j 2, local:2)",
         (f"{PY} bench/bench_chunks.py tiles --tiles 16",),
         (f"{PY} bench/bench_chunks.py tiles --tiles 1",)),
    Step("heights", "core", 1.5,
         "bench/README 'Geoid heights' (arrays at 10 M, the task on 1, 4 and 8 M lines)",
         (f"{PY} bench/bench_heights.py --points 10 --file-points 1 4 8",),
         (f"{PY} bench/bench_heights.py --points 0.1 --file-points 0.1 0.2",)),
    Step("startup", "core", 1.5,
         "bench/README 'Start-up and exit of every command' (four commands on the strip of tests/data)",
         (f"{PY} bench/bench_startup.py",),
         (f"{PY} bench/bench_startup.py --runs 1 --rows version info",)),
    Step("readme-lines", "core", 0.2,
         "README.md 'Use': the two example summary lines (CSite1 filtered with gapm, samp24's DTM)",
         (f"{PY} -m aldpat filter gapm {CSITE1} --odir bench/_work/readme-lines --overwrite",
          f"{PY} -m aldpat dtm jobs/data/samp24.txt --cell 2 --odir bench/_work/readme-lines --overwrite"),
         (f"{PY} -m aldpat dtm jobs/data/samp24.txt --cell 2 --odir bench/_work/readme-lines --overwrite",)),
    # 2026-11-23: 482 + 345 + 597 s; since then gapm's defaults do about twice the work and its
    # automatic buffer grew from 378.75 to 501.75 m (about 1.2 x the points per chunk)
    Step("dense", "core", 4.0,
         "bench/README 'A dense 100 M-point LAZ': the streamed rows and the points held in memory "
         "(100,531,200 points of LAS 1.4 LAZ, built once: 432 MB)",
         (f"{PY} bench/bench_chunks.py dense --points 100 --las14 --compare",),
         (f"{PY} bench/bench_chunks.py dense --points 2 --layers 4 --las14 --compare",)),
    Step("dense-chunked", "long", 5.0,
         "bench/README 'A dense 100 M-point LAZ': the --chunk 2000 -j 2 rows and the ratio to the streamed run",
         (f"{PY} bench/bench_chunks.py dense --points 100 --las14 --chunked 2000",),
         (f"{PY} bench/bench_chunks.py dense --points 2 --layers 4 --las14 --chunked 800",)),
    Step("chunks-memory", "long", 50.0,
         "bench/README 'A 100 M-point file in chunks': the memory table (-j 1, -j 2, local:2 on "
         "100,531,200 points of LAZ); builds a 100 M-point LAS and LAZ once (about 5 GB)",
         (f"{PY} bench/bench_chunks.py memory --points 100 --chunk 2000",),
         (f"{PY} bench/bench_chunks.py memory --points 1 --chunk 2000",)),
    Step("io", "long", 7.0,
         "bench/README 'Point I/O' table (1, 10, 50 M lines; writes a 1.6 GB text file once)",
         (f"{PY} bench/bench_io.py --sizes 1 10 50 --loadtxt",),
         (f"{PY} bench/bench_io.py --sizes 1 --loadtxt",)),
    Step("prep", "long", 15.0,
         "bench/README 'Data preparation' and bench_prep.py's docstring table (1, 10, 50 M points; "
         "about 15 GB of temporary files)",
         (f"{PY} bench/bench_prep.py --sizes 1 10 50",),
         (f"{PY} bench/bench_prep.py --sizes 1",)),
    Step("kill-resume", "long", 7.0,
         "bench/README 'Reliability: killed and resumed' (the clean run's time; 24 kills)",
         (f"{PY} bench/kill_resume.py --points 3000000 --instants 24 --jobs 2",),
         (f"{PY} bench/kill_resume.py --points 200000 --instants 2 --jobs 2",)),
    Step("peers-1m", "peers", 5.0,
         "bench/README 'Ground filters: speed' peers bullet (every filter and CSF, whitebox-workflows at 1 M points)",
         (f"{PY} bench/bench_filters.py speed --points 1 --peers",),
         (f"{PY} bench/bench_filters.py speed --points 0.6 --algos pm --peers",), needs="peers"),
    Step("peers-cells", "peers", 55.0,
         "bench/README 'Grid filters at 1 m cells' peers table (pysmrf, whitebox-workflows, CSF on 10 M "
         "points; pysmrf about 20 GB) and the ratio to pysmrf",
         (f"{PY} bench/bench_cells.py --algos gapm gapm-defaults",),
         (cells("--algos gapm"),), needs="peers"),
)

GROUPS = ("core", "long", "peers")

#: run once before the first step (not with --smoke): the compiled loops' first run in a fresh
#: checkout compiles them (numba, cached on disk), tens of seconds that no later run pays
WARMUP = (f"{PY} bench/bench_pdal.py --file {FSITE8} --rows gapm-defaults gapm-set01 dtm grid-linear multipass outlier",
          f"{PY} bench/bench_filters.py speed --source isprs --points 0.1")
WARMUP_MINUTES = 2.0


def write_params() -> None:
    """The two parameter files of the gapm-isprs step: --auto, and gapm.toml without the low-outlier test."""
    WORK.mkdir(parents=True, exist_ok=True)
    AUTO_PARAMS.write_text("# gapm's defaults with --auto (bench/remeasure_speed.py)\nauto = true\n")
    shipped = (REPO / "jobs" / "params" / "gapm.toml").read_text()
    lines = [ln for ln in shipped.splitlines() if not ln.startswith("low_outliers")]
    title = "# jobs/params/gapm.toml without the low-outlier test (bench/remeasure_speed.py)"
    NO_LOW_OUTLIERS.write_text("\n".join([title, *lines, 'low_outliers = "none"', ""]))


def select(first: int | None, only: list[str] | None, skip: list[str]) -> list[Step]:
    names = {s.name for s in STEPS}
    for word in [*(only or []), *skip]:
        if word not in names and word not in GROUPS:
            raise SystemExit(f"remeasure_speed: no step or group {word!r} (steps: {', '.join(sorted(names))}; "
                             f"groups: {', '.join(GROUPS)})")
    chosen = [s for s in STEPS if only is None or s.name in only or s.group in only]
    chosen = [s for s in chosen if s.name not in skip and s.group not in skip]
    return chosen[:first] if first is not None else chosen


def uptime() -> str:
    try:
        return subprocess.run(["uptime"], check=False, capture_output=True, text=True).stdout.strip()
    except OSError:
        one, five, fifteen = os.getloadavg()
        return f"load average: {one:.2f}, {five:.2f}, {fifteen:.2f}"


def command_line(cmd: str) -> str:
    return cmd.replace(f"{PY} ", f"{shlex.quote(sys.executable)} ", 1) if cmd.startswith(f"{PY} ") else cmd


def list_steps(steps: list[Step], smoke: bool, warmup: bool) -> None:
    total = WARMUP_MINUTES if warmup else 0.0
    print(f"{'#':>2} {'step':14} {'group':6} {'minutes':>7}  commands (from the repository root)")
    if warmup:
        print(f"{'0':>2} {'warm-up':14} {'':6} {WARMUP_MINUTES:7.1f}  {WARMUP[0]}")
        for c in WARMUP[1:]:
            print(f"{'':32}{c}")
        print(f"{'':32}-> no figures: the compiled loops' first run compiles and caches them (--no-warmup)")
    for i, s in enumerate(steps, 1):
        total += s.minutes
        cmds = s.smoke if smoke else s.commands
        need = f"  [needs {s.needs}]" if s.needs else ""
        print(f"{i:>2} {s.name:14} {s.group:6} {s.minutes:7.1f}  {cmds[0]}{need}")
        for c in cmds[1:]:
            print(f"{'':32}{c}")
        print(f"{'':32}-> {s.figures}")
    print(f"\n{len(steps)} steps, about {total:.0f} minutes ({total / 60:.1f} h) at full size on a quiet "
          "2-core machine" + (" (--smoke: tiny sizes, some minutes)" if smoke else ""))
    for group in GROUPS:
        chosen = [s for s in steps if s.group == group]
        if chosen:
            print(f"  {group:6} {sum(s.minutes for s in chosen):5.0f} min: {' '.join(s.name for s in chosen)}")


def run_one(say: Callable[[str], None], label: str, figures: str, cmd: str) -> tuple[str, float, str, str, str]:
    """Run one command from the repository root, its output into the log between two uptimes."""
    say(f"\n{'=' * 100}\n=== {label}: {cmd}")
    say(f"=== figures: {figures}")
    before = uptime()
    say(f"=== uptime before: {before}")
    start = time.perf_counter()
    proc = subprocess.Popen(command_line(cmd), shell=True, cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, bufsize=1)
    assert proc.stdout is not None
    for line in proc.stdout:
        say(line.rstrip("\n"))
    status = proc.wait()
    wall = time.perf_counter() - start
    after = uptime()
    say(f"=== uptime after: {after}")
    say(f"=== {label}: {wall:.1f} s wall, exit status {status}")
    return (label, wall, "ok" if status == 0 else f"FAILED ({status})",
            before.split("load average:")[-1].strip(), after.split("load average:")[-1].strip())


def run_steps(steps: list[Step], smoke: bool, warmup: bool, log_path: Path) -> int:
    write_params()
    log_path.parent.mkdir(parents=True, exist_ok=True)
    commit = subprocess.run(["git", "-C", str(REPO), "describe", "--always", "--dirty"], check=False,
                            capture_output=True, text=True).stdout.strip()
    pdal = os.environ.get("ALDPAT_PDAL")
    total = sum(s.minutes for s in steps) + (WARMUP_MINUTES if warmup else 0.0)
    summary: list[tuple[str, float, str, str, str]] = []
    with open(log_path, "a", encoding="utf-8") as log:

        def say(text: str) -> None:
            print(text, flush=True)
            log.write(text + "\n")
            log.flush()

        say(f"# bench/remeasure_speed.py{' --smoke (tiny sizes: NOT figures)' if smoke else ''}: "
            f"{len(steps)} steps ({', '.join(s.name for s in steps)}), expected about {total:.0f} minutes"
            f"{' at full size' if smoke else ''}")
        say(f"# {time.strftime('%Y-%m-%d %H:%M:%S UTC', time.gmtime())}; commit {commit}; {os.cpu_count()} cores; "
            f"ALDPAT_DATA={os.environ.get('ALDPAT_DATA', '(unset: bench/data_paths.py default)')}")
        if pdal:
            say(f"# ALDPAT_PDAL={pdal}")
        else:
            say("# !! ALDPAT_PDAL is not set: bench_pdal.py will look for pdal on PATH, or QUOTE STORED PDAL "
                "FIGURES (no ratio against PDAL measured)")
        say(f"# {uptime()}")
        if warmup:
            for j, cmd in enumerate(WARMUP, 1):
                summary.append(run_one(say, f"[warm-up {j}/{len(WARMUP)}]",
                                       "none (compiles the compiled loops once; not figures)", cmd))
        for i, step in enumerate(steps, 1):
            cmds = step.smoke if smoke else step.commands
            for j, cmd in enumerate(cmds, 1):
                part = f" ({j}/{len(cmds)})" if len(cmds) > 1 else ""
                summary.append(run_one(say, f"[{i}/{len(steps)}] {step.name}{part}", step.figures, cmd))
        say(f"\n{'=' * 100}\n# summary ({time.strftime('%Y-%m-%d %H:%M:%S UTC', time.gmtime())}; "
            f"load average 1/5/15 min before -> after each command)\n")
        say("| command | wall | status | load before | load after |\n|---|---|---|---|---|")
        for label, wall, status, before, after in summary:
            say(f"| {label} | {wall:.1f} s | {status} | {before} | {after} |")
        failed = sum(1 for row in summary if row[2] != "ok")
        say(f"\n# {len(summary)} commands, {failed} failed; log: {log_path}")
    return 1 if failed else 0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--list", action="store_true", help="print the steps, their commands and expected minutes; run nothing")
    ap.add_argument("--first", type=int, metavar="N", help="only the first N steps (of those --only/--skip leave)")
    ap.add_argument("--only", nargs="+", metavar="STEP", help="only these steps or groups (core, long, peers)")
    ap.add_argument("--skip", nargs="+", metavar="STEP", default=[], help="leave out these steps or groups")
    ap.add_argument("--smoke", action="store_true",
                    help="run each command at a tiny size: checks that the commands run; its figures mean nothing")
    ap.add_argument("--no-warmup", action="store_true", help="skip the warm-up run that compiles the compiled loops")
    ap.add_argument("--log", type=Path, help="log file (default bench/_work/remeasure-<UTC time>.log; appended to)")
    args = ap.parse_args()
    steps = select(args.first, args.only, args.skip)
    if args.list:
        list_steps(steps, args.smoke, not (args.smoke or args.no_warmup))
        return
    stamp = time.strftime("%Y%m%d-%H%M", time.gmtime())
    log = args.log or WORK / f"remeasure-{stamp}{'-smoke' if args.smoke else ''}.log"
    sys.exit(run_steps(steps, args.smoke, not (args.smoke or args.no_warmup), log))


if __name__ == "__main__":
    main()
