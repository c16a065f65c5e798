"""The TIN grid against the TIN of every point: how far ``grid --method linear`` and every ``dtm``
are from one Delaunay triangulation of all their points (qhull's, through scipy).

    python bench/bench_tin.py                      # the three raw ISPRS sites and a scene with holes
    python bench/bench_tin.py --against 906b037    # the same with another revision's code beside it

Each case grids its points at 1 m with :func:`aldpat.core.interpolate.linear` and with
``scipy.interpolate.LinearNDInterpolator`` (qhull's Delaunay TIN of the same points, duplicates
merged as aldpat merges them, in a local frame: qhull loses digits at UTM coordinates), and counts
the nodes both give that differ by more than 1 mm, the largest difference, and the nodes qhull's
TIN covers that aldpat leaves blank. Cases:

* ``CSite1``, ``FSite5``, ``FSite8`` (``bench/data_paths.ISPRS_SITES``, outside the repository):
  every point (``grid``), and the ground points of gapm's defaults (``dtm``'s TIN: the ground
  under buildings and trees removed, holes the TIN bridges);
* ``holes``: a curved terrain of 200,000 points over 600 m with 60 rectangular holes of 20-70 m
  (building footprints): ``ground_with_building_holes`` of ``tests/filters/terrain_scenes.py``.

Differences left where aldpat's blocks reach the limit of the points they take (a sliver
bridging a bay of the data's outline) or where equally valid triangulations tie (points on one
circle) are expected; differences of metres inside the data are not. ``--against REV`` runs the
same cases with the code of revision REV (a git worktree under ``bench/_work/``) in its own
process, the times beside each other (in-process, ``linear`` alone, load printed).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

BENCH = Path(__file__).resolve().parent
REPO = BENCH.parent
WORK = BENCH / "_work"
sys.path.insert(0, str(BENCH))

from data_paths import ISPRS_SITES

SITES = ("CSite1_red2-utm", "FSite5_orig-utm", "FSite8_red2-utm")

CASE_CODE = r"""
import json, sys, time
import numpy as np
sys.path.insert(0, sys.argv[1])
from scipy.interpolate import LinearNDInterpolator
from aldpat.core.grid_extent import from_bounds
from aldpat.core.interpolate import linear, merge_duplicates

def compare(x, y, z):
    spec = from_bounds(x.min(), y.min(), x.max(), y.max(), 1.0)
    t = time.perf_counter()
    ours = linear(x, y, z, spec)
    seconds = time.perf_counter() - t
    gx, gy = np.meshgrid(spec.xmin + np.arange(spec.nx) * spec.dx, spec.ymin + np.arange(spec.ny) * spec.dy)
    ox, oy = float(x.mean()), float(y.mean())
    xy, zz = merge_duplicates(np.column_stack([x - ox, y - oy]), z)
    exact = LinearNDInterpolator(xy, zz)(gx - ox, gy - oy)
    d = np.abs(ours - exact)
    both = np.isfinite(d)
    return {"points": int(len(x)), "nodes": int(both.sum()), "off": int((d[both] > 1e-3).sum()),
            "max": float(np.nanmax(d)) if both.any() else 0.0,
            "blank": int((np.isnan(ours) & np.isfinite(exact)).sum()), "seconds": seconds}

case, source = sys.argv[2], sys.argv[3]
if case == "holes":
    x, y, z = np.load(source)
else:
    import laspy
    las = laspy.read(source)
    x, y, z = (np.asarray(v, np.float64) for v in (las.x, las.y, las.z))
    if case.endswith("ground"):
        keep = np.load(sys.argv[4])
        x, y, z = x[keep], y[keep], z[keep]
print(json.dumps(compare(x, y, z)))
"""


def holes_scene() -> Path:
    """The made scene's points (x, y, z rows), written once from this checkout's
    ``tests/filters/terrain_scenes.py`` (one scene for every revision compared)."""
    import numpy as np

    path = WORK / "tin_holes.npy"
    if not path.exists():
        sys.path.insert(0, str(REPO / "tests" / "filters"))
        from terrain_scenes import ground_with_building_holes

        WORK.mkdir(parents=True, exist_ok=True)
        np.save(path, np.stack(ground_with_building_holes(200_000, 600.0, 60)))
    return path


def ground_mask(site: str) -> Path:
    """gapm's defaults' ground points of a site, found once with this checkout (one set of ground
    points for every revision compared)."""
    import numpy as np

    path = WORK / f"tin_ground_{site}.npy"
    if not path.exists():
        sys.path.insert(0, str(REPO))
        import aldpat

        WORK.mkdir(parents=True, exist_ok=True)
        np.save(path, aldpat.ground(str(ISPRS_SITES / f"{site}.laz")))
    return path


def checkout(rev: str) -> Path:
    """A worktree of ``rev`` under bench/_work/ (made once)."""
    sha = subprocess.run(["git", "-C", str(REPO), "rev-parse", rev], check=True, capture_output=True,
                         text=True).stdout.strip()
    where = WORK / f"rev-{sha[:12]}"
    if not (where / "aldpat").is_dir():
        subprocess.run(["git", "-C", str(REPO), "worktree", "add", "-f", "--detach", str(where), sha], check=True,
                       capture_output=True)
    return where


def run_case(code_root: Path, case: str, source: str, mask: str = "") -> dict:
    out = subprocess.run([sys.executable, "-c", CASE_CODE, str(code_root), case, source, mask], check=True,
                         capture_output=True, text=True, cwd="/tmp")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--against", metavar="REV", help="also run the cases with git revision REV's code")
    args = ap.parse_args()
    roots = [("this checkout", REPO)]
    if args.against:
        roots.append((args.against, checkout(args.against)))
    cases = [("holes", "holes", str(holes_scene()), "")]
    for site in SITES:
        source = str(ISPRS_SITES / f"{site}.laz")
        if not Path(source).exists():
            print(f"# {source} not found: set ALDPAT_DATA", file=sys.stderr)
            continue
        cases.append((f"{site.split('_')[0]} all points", "all", source, ""))
        cases.append((f"{site.split('_')[0]} ground (gapm)", "ground", source, str(ground_mask(site))))
    print(f"# load average {os.getloadavg()[0]:.1f}; nodes at 1 m; 'off': nodes more than 1 mm from qhull's TIN")
    print("| case | code | points | nodes | off | max m | blank, qhull not | linear s |")
    print("|---|---|---|---|---|---|---|---|")
    for name, case, source, mask in cases:
        for label, root in roots:
            r = run_case(root, case, source, mask)
            print(f"| {name} | {label} | {r['points']:,} | {r['nodes']:,} | {r['off']:,} | {r['max']:.3f} | "
                  f"{r['blank']:,} | {r['seconds']:.2f} |", flush=True)
    print(f"# load average {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
