"""Kill ``aldpat run`` with SIGKILL at random instants, resume it, and compare with a clean run.

    python bench/kill_resume.py --points 3000000 --instants 20 [--jobs 2] [--seed 1]

A multi-job worksheet (convert text -> LAZ, a ground filter, thinning, a TIN grid and tiling,
over four synthetic terrain files of ``--points`` points in all) is run once uninterrupted.
Then, for each instant, a fresh copy is started, killed with SIGKILL after a random share of
the clean run's wall time, and resumed with ``aldpat run --resume`` until it finishes. Each
resumed project must end with every output byte-identical to the clean run's (logs and the
resume state excepted: they hold times), no temporary file left, and every job that the state
file recorded as finished before the kill skipped, not redone; and no process of the killed run
may be alive 10 s after the kill (a worker outliving its parent: ``psutil``, the ``bench`` extra).

Prints one line per instant and a summary; exits 1 if any instant disagrees. Needs no data
outside the repository. The test suite runs a small version of it (``tests/cli/test_interrupt.py``).
"""

from __future__ import annotations

import argparse
import contextlib
import filecmp
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import psutil

WORKSHEET = """\
[settings]
jobs = {jobs}

[[job]]
task = "convert"
inputs = ["raw/*.txt"]
odir = "laz"
out_format = "laz"

[[job]]
task = "filter"
algorithm = "pm"
inputs = ["laz/*.laz"]
odir = "ground"
cell = 1.0
result = "classified"

[[job]]
task = "thin"
inputs = ["raw/*.txt"]
odir = "thin"
cell = 2.0

[[job]]
task = "grid"
inputs = ["thin/*_thin.txt"]
odir = "grids"
cell = 1.0

[[job]]
task = "tile"
inputs = ["thin/*_thin.txt"]
odir = "tiles"
width = 200.0
height = 200.0
buffer = 10.0
"""


def aldpat_command() -> list[str]:
    script = Path(sys.executable).with_name("aldpat")
    return [str(script)] if script.exists() else [sys.executable, "-m", "aldpat"]


def make_project(folder: Path, points: int, jobs: int, seed: int = 0) -> Path:
    """Four terrain files (a sloped, rolling surface with boxes on it) and the worksheet."""
    raw = folder / "raw"
    raw.mkdir(parents=True)
    rng = np.random.default_rng(seed)
    per = points // 4
    for k in range(4):
        x = 1000.0 * (k % 2) + rng.uniform(0, 1000, per)
        y = 1000.0 * (k // 2) + rng.uniform(0, 1000, per)
        z = 50 + 0.02 * x + 3 * np.sin(y / 90) + rng.normal(0, 0.05, per)
        box = ((x % 100) < 25) & ((y % 120) < 30)
        z = np.where(box, z + 8, z)
        with open(raw / f"part{k}.txt", "w") as fh:  # chunked: savetxt on millions of rows is slow
            for a in range(0, per, 200_000):
                b = min(per, a + 200_000)
                block = np.c_[x[a:b], y[a:b], z[a:b]]
                fh.write(("%.2f %.2f %.2f\n" * (b - a)) % tuple(block.ravel()))
    ws = folder / "project.toml"
    ws.write_text(WORKSHEET.format(jobs=jobs))
    return ws


def outputs(folder: Path) -> dict[str, Path]:
    """Every file the run wrote, by relative path (logs, the earlier runs' logs and the resume
    state left out)."""
    return {str(p.relative_to(folder)): p for p in sorted(folder.rglob("*"))
            if p.is_file() and p.suffix != ".log" and ".log." not in p.name and not p.name.endswith(".state.json")
            and p.relative_to(folder).parts[0] != "raw" and p.name != "project.toml"}


def run(ws: Path, *extra: str) -> subprocess.CompletedProcess:
    return subprocess.run(aldpat_command() + ["run", str(ws), *extra], capture_output=True, text=True,
                          check=False, stdin=subprocess.DEVNULL)


@dataclass
class Instant:
    delay: float
    mid_run: bool  # the run was still going when it was killed
    running_at_kill: int | None  # the worksheet job the state file recorded as running
    done_before_kill: list[int]
    skipped_on_resume: list[int]
    identical: bool
    leftovers: list[str]
    problem: str = ""
    orphans: list[str] = field(default_factory=list)  # processes of the killed run alive 10 s after it

    @property
    def ok(self) -> bool:
        return self.identical and not self.leftovers and set(self.done_before_kill) <= set(self.skipped_on_resume) \
            and not self.problem and not self.orphans


def same_bytes(a: Path, a_root: Path, b: Path, b_root: Path) -> bool:
    """Byte-identical, except that tile_parameter.txt names its tiles by absolute path (the
    manual's Fig. 8), which differs between the two project folders by their roots only."""
    if filecmp.cmp(a, b, shallow=False):
        return True
    if a.name != "tile_parameter.txt":
        return False
    return a.read_text().replace(str(a_root.resolve()), "ROOT") == b.read_text().replace(str(b_root.resolve()), "ROOT")


def describe(p: psutil.Process) -> str:
    """``pid status: command`` of a process, for a report of those left behind."""
    try:
        return f"{p.pid} {p.status()}: {' '.join(p.cmdline())[-120:]}"
    except psutil.Error:
        return str(p.pid)


def kill_and_resume(template: Path, reference: dict[str, Path], workdir: Path, delay: float) -> Instant:
    """Copy the project, start it, SIGKILL it after ``delay`` s, resume it, compare."""
    if workdir.exists():
        shutil.rmtree(workdir)
    shutil.copytree(template, workdir, ignore=shutil.ignore_patterns("laz", "ground", "thin", "grids", "tiles",
                                                                      "*.log", "*.state.json"))
    ws = workdir / "project.toml"
    proc = subprocess.Popen(aldpat_command() + ["run", str(ws)], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL)
    time.sleep(delay)
    mid_run = proc.poll() is None
    try:
        family = psutil.Process(proc.pid).children(recursive=True)
    except psutil.NoSuchProcess:
        family = []
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    # workers notice their parent's death (SIGTERM from the kernel, or their watchdog) and clean up
    _, alive = psutil.wait_procs(family, timeout=10)
    orphans = [describe(p) for p in alive if p.is_running() and p.status() != psutil.STATUS_ZOMBIE]
    for p in alive:
        with contextlib.suppress(psutil.Error):
            p.kill()
    state_file = workdir / "project.state.json"
    state = json.loads(state_file.read_text()) if state_file.exists() else {}
    done = sorted(int(k) for k, v in state.items() if v.get("status") == "Done")
    running = next((int(k) for k, v in state.items() if v.get("status") == "Running"), None)
    resumed = run(ws, "--resume")
    problem = "" if resumed.returncode == 0 else f"resume exited {resumed.returncode}: {resumed.stderr[-300:]}"
    skipped = sorted(int(line.split()[1]) for line in resumed.stderr.splitlines()
                     if line.startswith("job ") and ": Skipped" in line)
    got = outputs(workdir)
    identical = set(got) == set(reference) and all(
        same_bytes(got[name], workdir, reference[name], template) for name in reference)
    left = sorted(str(p) for p in workdir.rglob("*.aldpat-tmp*"))
    return Instant(delay, mid_run, running, done, skipped, identical, left, problem, orphans)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", type=int, default=3_000_000)
    ap.add_argument("--instants", type=int, default=20)
    ap.add_argument("--jobs", type=int, default=2, help="worker processes of each worksheet job")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--workdir", type=Path, default=None)
    args = ap.parse_args(argv)
    base = args.workdir or Path(os.environ.get("TMPDIR", "/tmp")) / "aldpat-kill-resume"
    if base.exists():
        shutil.rmtree(base)
    clean = base / "clean"
    ws = make_project(clean, args.points, args.jobs)
    start = time.perf_counter()
    first = run(ws)
    wall = time.perf_counter() - start
    if first.returncode != 0:
        print(first.stderr, file=sys.stderr)
        return 1
    reference = outputs(clean)
    print(f"clean run: {args.points:,} points, {len(reference)} outputs, {wall:.1f} s, jobs per worksheet job "
          f"{args.jobs}")
    rng = random.Random(args.seed)
    results = []
    for k in range(args.instants):
        delay = rng.uniform(0.05, 0.9) * wall
        r = kill_and_resume(clean, reference, base / "killed", delay)
        results.append(r)
        print(f"instant {k + 1:2d}: killed at {delay:6.2f} s{'' if r.mid_run else ' (after the run ended)'}, "
              f"job running {r.running_at_kill}, finished before the kill {r.done_before_kill}, "
              f"skipped on resume {r.skipped_on_resume}, identical {r.identical}, leftovers {len(r.leftovers)}, "
              f"orphaned workers {len(r.orphans)}"
              + (f", {r.problem}" if r.problem else ""))
    good = sum(r.ok for r in results)
    landed = sum(r.mid_run for r in results)
    print(f"{landed} of {len(results)} kills landed while the run was going; {good} of {len(results)} instants "
          "ended byte-identical to the clean run, without leftovers and without redoing finished jobs")
    return 0 if good == len(results) else 1


if __name__ == "__main__":
    sys.exit(main())
