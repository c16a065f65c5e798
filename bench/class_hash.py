"""Hashes of the classes every ground filter gives real data: a restructuring must leave them alone.

    python bench/class_hash.py                # one line per filter x sample
    python bench/class_hash.py --save         # store them as the reference (bench/class_hash.ref)
    python bench/class_hash.py --check        # compare with the reference; exit 1 on any difference
    python bench/class_hash.py --algos gapm pm --check

Reads (``bench/data_paths.py`` says where; ``$ALDPAT_DATA``) the seven ISPRS reference samples
and the raw ISPRS site FSite5 (``FSite5_orig-utm.laz``, the strip the filter and PDAL benchmarks
tile), and runs every registered filter with its default parameters on all points of each, twice
for FSite5:

* ``ground_filter`` in process on the points as arrays (``aldpat.ground`` and the chunk path take
  this road): a hash of every point's mark (0 ground, else the window that removed it, the low
  outliers' and the raised segments' marks) and one of the ground flags;
* ``fsite5-cli``: ``aldpat filter ALGO FSite5 --result classified`` as a user runs it, in this
  process through the task (the LAS path: the file streamed in two passes for the grid filters),
  hashing the LAS classes written.

Each line: filter, sample, points, ground points, class hash and mark hash (the first 12 hex
digits of SHA-1; ``-`` where the path gives no marks). Results do not depend on thread counts or
input order, so the hashes are the same on every machine with the same numpy/scipy/numba.
Running every filter on every sample takes about three minutes on two busy cores; run it with
``nice -n 10`` on a shared machine.
"""

from __future__ import annotations

import argparse
import hashlib
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

BENCH = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH))

from data_paths import FSITE5
from isprs import SAMPLES, load_sample

REFERENCE = BENCH / "class_hash.ref"


def digest(a: np.ndarray) -> str:
    return hashlib.sha1(np.ascontiguousarray(a).tobytes()).hexdigest()[:12]


def fsite5_points() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    import laspy

    las = laspy.read(FSITE5)
    return np.asarray(las.x, np.float64), np.asarray(las.y, np.float64), np.asarray(las.z, np.float64)


def in_process(algo: str, x, y, z) -> tuple[int, str, str]:
    """(ground count, class hash, mark hash) of ``ground_filter`` with the filter's defaults."""
    from aldpat.filters import ground_filter

    res = ground_filter(x, y, z, algo)
    return int(res.is_ground.sum()), digest(res.is_ground.astype(np.uint8)), digest(res.point_marks.astype(np.int32))


def through_cli(algo: str, odir: Path) -> tuple[int, int, str]:
    """(points, ground count, class hash) of ``aldpat filter ALGO FSite5 --result classified``."""
    import laspy

    from aldpat.tasks import get_task

    rep = get_task("filter", algo)([str(FSITE5)], odir=str(odir), overwrite=True, result="classified")
    if rep.exit_code != 0:
        raise SystemExit(f"{algo}: aldpat filter failed: {[r.error for r in rep.results]}")
    (out,) = [w.path for w in rep.outputs]
    cls = np.asarray(laspy.read(out).classification, np.uint8)
    return len(cls), int((cls == 2).sum()), digest(cls)


def sample_points(name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    if name == "fsite5":
        return fsite5_points()
    s = load_sample(name)
    return s.x, s.y, s.z


def lines(algos: list[str], samples: list[str], cli: bool):
    """Yield (key, line, seconds) for every filter x sample, as computed."""
    loaded: dict[str, tuple] = {}
    with tempfile.TemporaryDirectory(prefix="class_hash_") as tmp:
        for algo in algos:
            for name in [*samples, "fsite5"]:
                if name not in loaded:
                    loaded[name] = sample_points(name)
                x, y, z = loaded[name]
                t0 = time.perf_counter()
                ground, ch, mh = in_process(algo, x, y, z)
                yield (algo, name), f"{len(z):>9} {ground:>9} {ch} {mh}", time.perf_counter() - t0
            if cli:
                t0 = time.perf_counter()
                n, ground, ch = through_cli(algo, Path(tmp))
                yield (algo, "fsite5-cli"), f"{n:>9} {ground:>9} {ch} {'-':12}", time.perf_counter() - t0


def read_reference(path: Path) -> dict[tuple[str, str], str]:
    ref = {}
    for ln in path.read_text().splitlines():
        if ln.strip() and not ln.startswith("#"):
            algo, sample, rest = ln.split(maxsplit=2)
            ref[(algo, sample)] = " ".join(rest.split())
    return ref


def main() -> int:
    import aldpat.filters

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--algos", nargs="+", default=sorted(aldpat.filters.FILTERS))
    ap.add_argument("--samples", nargs="+", default=list(SAMPLES), help="ISPRS samples (FSite5 always runs)")
    ap.add_argument("--no-cli", action="store_true", help="leave out the fsite5-cli rows")
    ap.add_argument("--reference", type=Path, default=REFERENCE)
    what = ap.add_mutually_exclusive_group()
    what.add_argument("--save", action="store_true", help="write the lines as the reference file")
    what.add_argument("--check", action="store_true", help="exit 1 when a line differs from the reference")
    args = ap.parse_args()
    unknown = set(args.algos) - set(aldpat.filters.FILTERS)
    if unknown:
        raise SystemExit(f"unknown algorithms: {', '.join(sorted(unknown))}")
    ref = read_reference(args.reference) if args.check else {}
    out, differ, t_all = [], 0, time.perf_counter()
    print(f"{'filter':11} {'sample':11} {'points':>9} {'ground':>9} {'class hash':12} {'mark hash':12}")
    for (algo, sample), line, seconds in lines(args.algos, args.samples, not args.no_cli):
        row = f"{algo:11} {sample:11} {line}"
        out.append(row)
        verdict = ""
        if args.check:
            want = ref.get((algo, sample))
            if want is None:
                verdict, differ = "  NO REFERENCE", differ + 1
            elif want != " ".join(line.split()):
                verdict, differ = f"  DIFFERS (reference: {want})", differ + 1
            else:
                verdict = "  same"
        print(f"{row}  {seconds:6.1f} s{verdict}", flush=True)
    print(f"# {len(out)} rows in {time.perf_counter() - t_all:.0f} s")
    if args.save:
        args.reference.write_text(
            "# bench/class_hash.py --save: filter, sample, points, ground points, class hash, mark hash\n"
            + "\n".join(out) + "\n")
        print(f"# reference written: {args.reference}")
    if args.check:
        print(f"# {differ} of {len(out)} rows differ from {args.reference}" if differ
              else f"# all {len(out)} rows as in {args.reference}")
        return 1 if differ else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
