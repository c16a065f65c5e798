"""aldpat against PDAL as users run them: the same file, the same 1 m cells, in one run.

    python bench/bench_pdal.py                         # every row: aldpat's three, PDAL's two, ratios
    python bench/bench_pdal.py --rows gapm-defaults gapm-set01 pdal-smrf
    python bench/bench_pdal.py --rows multipass outlier --against REV   # the filters PDAL lacks
    python bench/bench_pdal.py --against main          # also the aldpat rows with the code of main:
                                                       # classes and DTM nodes compared point for point
    python bench/bench_pdal.py --las14 --rows gapm-defaults dtm --against REV   # the same points as a
                                                       # LAS 1.4 LAZ (point format 6, GPS times)

Reads ``bench/data_paths.FSITE5`` (the ISPRS site FSite5, outside the repository) and builds once,
under ``bench/_work/``, one LAS of 16 tiled copies of it: 10,053,120 points (the file
``bench_cells.py`` and ``bench_filters.py speed --source sites`` use). Each row is the command a
user types, run in a fresh process, timed wall clock, with the peak resident memory of the
process tree (``ru_maxrss`` of the waited-for children):

* ``gapm-defaults``: ``aldpat filter gapm FILE --cell 1 --result classified`` (gapm's built-in
  defaults on 1 m cells);
* ``gapm-set01``: the same with ``--params jobs/params/gapm-isprs-set01.toml`` (Table 6-8);
* ``dtm``: ``aldpat dtm FILE --cell 1`` (gapm's defaults, TIN, Cloud Optimized GeoTIFF);
* ``pdal-smrf``: ``pdal pipeline``: ``readers.las`` -> ``filters.smrf`` (its defaults: 1 m
  cells) -> ``writers.las``;
* ``pdal-dtm``: PDAL's usual DTM pipeline: ``filters.smrf`` -> ``filters.range``
  ``Classification[2:2]`` -> ``writers.gdal`` (``idw``, 1 m);
* ``multipass`` and ``outlier`` (only when named in ``--rows``: PDAL has neither):
  ``aldpat filter multipass FILE --cell 1 --result classified`` and the same for ``outlier``,
  their own defaults otherwise;
* ``grid-linear`` (only when named): ``aldpat grid FILE --method linear --cell 1``, the TIN of
  every point (Surfer 7 grid, the default format); with ``gapm-defaults`` in the same run the
  bench prints its time over the filter's.

Ratios: PDAL's time over aldpat's (gapm rows against ``pdal-smrf``, ``dtm`` against
``pdal-dtm``) and aldpat's peak memory over PDAL's. The load average is printed before and after
every row: on a shared machine a figure means little without it.

PDAL is found from ``$ALDPAT_PDAL`` (a command line, e.g. ``env LD_LIBRARY_PATH=/opt/pdal/lib
/opt/pdal/bin/pdal``), else ``pdal`` on ``PATH``. When it is absent or does not run, the bench
says so loudly and quotes the stored figure (:data:`STORED`) for the ratios instead. To get one:
``conda install -c conda-forge pdal``, or build PDAL 2.8 from source (cmake with GDAL, PROJ,
GeoTIFF; ``make install``). A copy whose library symlinks were flattened into text files fails
with "libpdalcpp.so.18: file too short": make a folder of real symlinks to
``lib/libpdalcpp.so.18.x.y`` and put it on ``LD_LIBRARY_PATH``.

``--against REV`` extracts the ``aldpat`` package of git revision REV (``git archive``) under
``bench/_work/`` and runs each aldpat row with it as well, on the same file: the classes written
must be identical point for point, and the DTM's nodes must agree within 1 mm with the same
blank nodes -- the check that a speed change changed no result. Each aldpat tree runs its row
once on ``tests/data/fsite5_strip.laz`` first, untimed, so that numba's compiling is not timed. Without it each row still prints
a hash of its classes (and of its DTM's nodes rounded to the millimetre) to compare across runs.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shlex
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

BENCH = Path(__file__).resolve().parent
REPO = BENCH.parent
sys.path.insert(0, str(BENCH))

from _measure import mib

WORK = BENCH / "_work"
OUT = WORK / "out_pdal"
POINTS = 10_053_120
CELL = 1.0
SET01 = REPO / "jobs" / "params" / "gapm-isprs-set01.toml"
ALDPAT_ROWS = ("gapm-defaults", "gapm-set01", "dtm", "multipass", "outlier", "grid-linear")
#: rows of filters PDAL has no counterpart of, measured alone (not run unless asked: ``--rows``)
OWN_ROWS = ("multipass", "outlier", "grid-linear")
PDAL_ROWS = ("pdal-smrf", "pdal-dtm")
#: each aldpat row and the PDAL row it is compared with
PEER_OF = {"gapm-defaults": "pdal-smrf", "gapm-set01": "pdal-smrf", "dtm": "pdal-dtm", "multipass": None,
           "outlier": None, "grid-linear": None}

#: PDAL 2.8.4 on this file when no PDAL runs here: (seconds, peak bytes, when and how measured),
#: from this script's own runs on a quiet machine (bench/README.md, "aldpat against PDAL").
STORED = {
    "pdal-smrf": (192.5, 6780 * 2**20, "bench_pdal.py 2026-11-28 02:34 UTC, 2 cores, load 1.3 -> 1.0"),
    "pdal-dtm": (195.3, 6782 * 2**20, "bench_pdal.py 2026-11-28 02:37 UTC, 2 cores, load 1.0 -> 1.0"),
}


def source_file() -> Path:
    from bench_filters import build_sites  # the tiled FSite5 file the other filter benchmarks use

    return build_sites(POINTS)


def las14_file(source: Path) -> Path:
    """``source`` as today's surveys deliver it, built once beside it: LAS 1.4, point format 6
    (layered LAZ), every field of the source kept and a GPS time added in file order (the pulses
    about 10 us apart, jittered: the source holds none, and a constant step would compress to
    nothing)."""
    import laspy

    out = source.with_name(f"{source.stem}_14.laz")
    if not out.exists():
        las = laspy.convert(laspy.read(source), point_format_id=6, file_version="1.4")
        steps = np.random.default_rng(14).uniform(5e-6, 15e-6, len(las.points))
        las.gps_time = 3.2e8 + np.cumsum(steps)
        las.write(out.with_suffix(".tmp.laz"))
        out.with_suffix(".tmp.laz").rename(out)
    return out


def load() -> str:
    one, five, _ = os.getloadavg()
    return f"{one:.1f}/{five:.1f}"


# ---------------------------------------------------------------------------- commands


def pdal_command() -> tuple[list[str] | None, str]:
    """PDAL's command line and its version, or ``None`` and why it cannot run."""
    given = os.environ.get("ALDPAT_PDAL")
    cmd = shlex.split(given) if given else ([found] if (found := shutil.which("pdal")) else None)
    if cmd is None:
        return None, "no pdal on PATH and $ALDPAT_PDAL not set"
    try:
        proc = subprocess.run([*cmd, "--version"], check=False, capture_output=True, text=True, timeout=60)
    except OSError as exc:
        return None, f"{' '.join(cmd)}: {exc}"
    if proc.returncode != 0:
        lines = (proc.stderr or proc.stdout).strip().splitlines()
        return None, f"{' '.join(cmd)} fails: {lines[-1] if lines else proc.returncode}"
    version = next((ln.strip() for ln in proc.stdout.splitlines() if ln.startswith("pdal ")), "pdal")
    return cmd, version


def pdal_pipeline(row: str, las: Path) -> list[dict]:
    stages: list[dict] = [{"type": "readers.las", "filename": str(las)}, {"type": "filters.smrf"}]
    if row == "pdal-smrf":
        return [*stages, {"type": "writers.las", "filename": str(OUT / "pdal_smrf.las")}]
    return [*stages, {"type": "filters.range", "limits": "Classification[2:2]"},
            {"type": "writers.gdal", "filename": str(OUT / "pdal_dtm.tif"), "resolution": CELL,
             "output_type": "idw", "gdaldriver": "GTiff"}]


def aldpat_command(row: str, las: Path, odir: Path) -> list[str]:
    cmd = [sys.executable, "-m", "aldpat"]
    if row == "grid-linear":
        return [*cmd, "grid", str(las), "--method", "linear", "--cell", f"{CELL:g}", "--odir", str(odir),
                "--overwrite", "-q"]
    if row == "dtm":
        return [*cmd, "dtm", str(las), "--cell", f"{CELL:g}", "--odir", str(odir), "--overwrite", "-q"]
    algorithm = row if row in OWN_ROWS else "gapm"
    cmd += ["filter", algorithm, str(las), "--cell", f"{CELL:g}", "--result", "classified", "--odir", str(odir),
            "--overwrite", "-q"]
    return [*cmd, "--params", str(SET01)] if row == "gapm-set01" else cmd


def aldpat_env(tree: Path) -> dict:
    """The environment of an aldpat row: the package of ``tree`` first on the path, and Python
    free to write its bytecode, as ``pip install`` compiles it for users: under
    ``PYTHONDONTWRITEBYTECODE`` (set on some machines) every run compiled the package's modules
    from source again, some 0.2 s of start-up no user pays, and a tree that had bytecode from
    another run did not."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def warm(row: str, env: dict) -> None:
    """Run ``row``'s command once on a small file, untimed: a package tree's first run compiles its
    numba loops and holds the compiler's memory (some 100 MB) and time, which the timed run would
    otherwise count -- a freshly extracted ``--against`` tree and a just-edited module alike."""
    small = REPO / "tests" / "data" / "fsite5_strip.laz"
    if small.exists():
        subprocess.run(aldpat_command(row, small, OUT / "warm"), env=env, capture_output=True, cwd=WORK, check=False)


def timed(cmd: list[str], env: dict | None = None, stdin: str | None = None) -> dict:
    """Wall time and peak memory of ``cmd`` in a fresh process tree (a new interpreter measures it,
    so that the peak is this command's alone)."""
    probe = (
        "import json, resource, subprocess, sys, time\n"
        "cmd, stdin = json.loads(sys.argv[1])\n"
        "t0 = time.perf_counter()\n"
        "p = subprocess.run(cmd, input=stdin, text=True, capture_output=True)\n"
        "dt = time.perf_counter() - t0\n"
        "peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024\n"
        "print(json.dumps(dict(rc=p.returncode, seconds=dt, peak_bytes=peak, err=p.stderr[-2000:])))\n"
    )
    before = load()
    # run from bench/_work: from the repository root, the current folder's ``aldpat`` would be
    # imported whatever PYTHONPATH says (``--against`` would time and compare the same code)
    proc = subprocess.run([sys.executable, "-c", probe, json.dumps([cmd, stdin])], capture_output=True,
                          text=True, env=env, check=True, cwd=WORK)
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    out["load"] = f"{before} -> {load()}"
    if out["rc"] != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{out['err']}")
    return out


# ---------------------------------------------------------------------------- results


def output_of(row: str, las: Path, odir: Path) -> Path:
    if row == "grid-linear":
        return next(p for p in sorted(odir.iterdir()) if p.name.startswith(las.stem))
    if row == "dtm":
        return odir / f"{las.stem}_dtm.tif"
    return odir / f"{las.stem}_{row if row in OWN_ROWS else 'gapm'}{las.suffix}"


def classes_of(path: Path) -> np.ndarray:
    import laspy

    with laspy.open(path) as reader:
        return np.concatenate([np.asarray(c.classification) for c in reader.chunk_iterator(2_000_000)])


def nodes_of(path: Path) -> tuple[np.ndarray, tuple]:
    import rasterio

    with rasterio.open(path) as ds:
        return ds.read(1, masked=True).astype(np.float64).filled(np.nan), tuple(ds.transform)


def fingerprint(row: str, path: Path) -> str:
    """A short hash of what the row produced: the classes, or the DTM's nodes to the millimetre."""
    if row == "grid-linear":
        return f"{path.name}, {path.stat().st_size:,} bytes"
    if row == "dtm":
        z, transform = nodes_of(path)
        mm = np.where(np.isnan(z), -(2**62), np.round(z * 1000)).astype(np.int64)
        blank = int(np.isnan(z).sum())
        return f"nodes {z.shape[1]} x {z.shape[0]}, {blank:,} blank, mm-hash " \
               f"{hashlib.sha1(mm.tobytes() + repr(transform).encode()).hexdigest()[:10]}"
    cls = classes_of(path)
    return f"{int((cls == 2).sum()):,} ground, class-hash {hashlib.sha1(cls.tobytes()).hexdigest()[:10]}"


def compare(row: str, new: Path, old: Path) -> str:
    """Whether the row's result equals that of the other revision (classes) or lies within 1 mm of
    it on the same nodes (DTM)."""
    if row == "dtm":
        return compare_dtms(new, old)
    if row == "grid-linear":
        return "same bytes" if new.read_bytes() == old.read_bytes() else "bytes differ (not compared node by node)"
    a, b = classes_of(new), classes_of(old)
    if a.shape != b.shape:
        return f"{len(a):,} points against {len(b):,}: FAILS"
    differ = int((a != b).sum())
    return f"classes: {differ} of {len(a):,} points differ: {'identical' if differ == 0 else 'FAILS'}"


def compare_dtms(new: Path, old: Path) -> str:
    """Two DTMs node for node: the same nodes, the same blank nodes, every other node within 1 mm
    (the largest difference, and how many nodes differ at all and by more than 1 mm)."""
    a, ta = nodes_of(new)
    b, tb = nodes_of(old)
    if a.shape != b.shape or ta != tb:
        return f"DTM on other nodes ({a.shape} against {b.shape}): FAILS"
    blank_a, blank_b = np.isnan(a), np.isnan(b)
    differ = int((blank_a != blank_b).sum())
    both = ~blank_a & ~blank_b
    gap = np.abs(a[both] - b[both])
    worst = float(gap.max()) if gap.size else 0.0
    ok = differ == 0 and worst <= 0.001
    return (f"max |node difference| {worst * 1000:.3f} mm over {int(both.sum()):,} nodes "
            f"({int((gap > 0).sum()):,} differ, {int((gap > 0.001).sum()):,} by more than 1 mm), "
            f"{differ} nodes blank in one only: {'holds' if ok else 'FAILS'} (1 mm)")


def revision_tree(rev: str) -> tuple[Path, str]:
    """The ``aldpat`` package of git revision ``rev``, extracted once under ``bench/_work/``."""
    sha = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--verify", f"{rev}^{{commit}}"], check=True,
                         capture_output=True, text=True).stdout.strip()
    root = WORK / f"rev-{sha[:12]}"
    if not (root / "aldpat").is_dir():
        tmp = WORK / f"rev-{sha[:12]}.part"
        shutil.rmtree(tmp, ignore_errors=True)
        tmp.mkdir(parents=True)
        archive = subprocess.run(["git", "-C", str(REPO), "archive", "--format=tar", sha, "aldpat"], check=True,
                                 capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(tmp)], input=archive, check=True)
        tmp.rename(root)
    return root, sha[:12]


# ---------------------------------------------------------------------------- the table


def row_line(row: str, points: int, m: dict, note: str, peer: dict | None, peer_stored: bool) -> str:
    ratio = ""
    if peer is not None:
        star = " (stored PDAL figure)" if peer_stored else ""
        ratio = (f"x{peer['seconds'] / m['seconds']:.1f} faster, "
                 f"1/{peer['peak_bytes'] / m['peak_bytes']:.1f} memory{star}")
    rate = points / m["seconds"] / 1e6
    return (f"| {row} | {m['seconds']:.1f} s | {rate:.2f} M/s | {mib(m['peak_bytes'])} | {m['load']} | "
            f"{ratio} | {note} |")


def run(rows: list[str], against: str | None, repeat: int, file: Path | None, las14: bool = False) -> None:
    import laspy

    las = file.resolve() if file else las14_file(source_file()) if las14 else source_file()
    with laspy.open(las) as reader:
        points = reader.header.point_count
    OUT.mkdir(parents=True, exist_ok=True)
    pdal, why = pdal_command()
    commit = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], check=False,
                            capture_output=True, text=True).stdout.strip()
    print(f"# {las.name}: {points:,} points, {CELL:g} m cells, {os.cpu_count()} cores; commit {commit}; "
          f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    if pdal is None:
        bar = "!" * 100
        print(f"{bar}\n!! PDAL NOT RUN: {why}.\n!! The PDAL rows and ratios below QUOTE A STORED FIGURE, "
              "not a measurement of this run:")
        for row, (sec, peak, when) in STORED.items():
            print(f"!!   {row}: {sec:.1f} s, {mib(peak)} ({when})")
        print("!! To run PDAL: set ALDPAT_PDAL to its command line or put pdal on PATH (conda install -c "
              "conda-forge pdal, or build PDAL 2.8 from source);\n!! a copy failing with 'libpdalcpp.so.18: "
              "file too short' needs a folder of real symlinks to its lib/libpdalcpp.so.18.x.y on "
              f"LD_LIBRARY_PATH.\n{bar}")
    else:
        print(f"# PDAL: {' '.join(pdal)} ({why})")
    print("\n| row | wall | points/s | peak RSS | load (1/5 min) before -> after | against PDAL | result |")
    print("|---|---|---|---|---|---|---|")
    measured: dict[str, dict] = {}
    stored: set[str] = set()
    for row in [r for r in rows if r in PDAL_ROWS]:  # PDAL first: each aldpat row then prints its ratio
        if pdal is None:
            sec, peak, when = STORED[row]
            measured[row] = {"seconds": sec, "peak_bytes": peak, "load": f"stored: {when}"}
            stored.add(row)
            print(f"| {row} | {sec:.1f} s | {points / sec / 1e6:.2f} M/s | {mib(peak)} | STORED FIGURE, "
                  f"not measured now ({when}) | | |", flush=True)
            continue
        m = timed([*pdal, "pipeline", "--stdin"], stdin=json.dumps(pdal_pipeline(row, las)))
        measured[row] = m
        print(row_line(row, points, m, "", None, False), flush=True)
    old = revision_tree(against) if against else None
    for row in [r for r in rows if r in ALDPAT_ROWS]:
        odir = OUT / row
        env = aldpat_env(REPO)
        warm(row, env)
        runs = [timed(aldpat_command(row, las, odir), env=env) for _ in range(repeat)]
        m = min(runs, key=lambda r: r["seconds"])
        m["peak_bytes"] = max(r["peak_bytes"] for r in runs)
        measured[row] = m
        note = fingerprint(row, output_of(row, las, odir))
        if old is not None:
            old_dir = OUT / f"{row}-{old[1]}"
            old_env = aldpat_env(old[0])
            warm(row, old_env)
            om = timed(aldpat_command(row, las, old_dir), env=old_env)
            note += (f"; at {old[1]}: {om['seconds']:.1f} s, {mib(om['peak_bytes'])}; "
                     + compare(row, output_of(row, las, odir), output_of(row, las, old_dir)))
        peer = PEER_OF[row]
        print(row_line(row, points, m, note, measured.get(peer) if peer else None, peer in stored), flush=True)
    if "grid-linear" in measured and "gapm-defaults" in measured:
        ratio = measured["grid-linear"]["seconds"] / measured["gapm-defaults"]["seconds"]
        print(f"\ngrid --method linear took {ratio:.2f} x the time of gapm's defaults (the filter's own time) "
              f"in this run")
    print(f"\nbest of {repeat} for the aldpat rows (largest peak); PDAL once. Ratios: PDAL's wall time over "
          "aldpat's, aldpat's peak over PDAL's.")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rows", nargs="+", default=[*PDAL_ROWS, *(r for r in ALDPAT_ROWS if r not in OWN_ROWS)],
                    choices=(*PDAL_ROWS, *ALDPAT_ROWS))
    ap.add_argument("--against", metavar="REV", help="also run the aldpat rows with git revision REV and compare")
    ap.add_argument("--repeat", type=int, default=1, help="runs per aldpat row (best time, largest peak)")
    ap.add_argument("--file", type=Path, help="another LAS/LAZ file instead of the tiled FSite5")
    ap.add_argument("--las14", action="store_true",
                    help="the tiled FSite5 as a LAS 1.4 LAZ of point format 6 with GPS times (built once)")
    args = ap.parse_args()
    run(args.rows, args.against, max(1, args.repeat), args.file, args.las14)


if __name__ == "__main__":
    main()
