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

``python bench/bench_dtm.py project [--site FSite5_orig-utm] [--width 500] [--buffer 30] [--cell 1]
[--jobs 2]`` -- the README's project in tiles on a raw ISPRS site (FSite5, or ``--site
CSite1_red2-utm`` / ``FSite8_red2-utm``; ``bench/data_paths.py``): ``aldpat tile`` at ``--width``
with ``--buffer``, ``aldpat dtm`` and ``aldpat grid`` over the tile folder, ``aldpat filter gapm
--result classified`` of the folder and ``aldpat merge`` of the classified tiles. Reported: the
tiles, the nodes two or more tile grids hold and how many of them differ in any bit (values or
blank), the tiles warned to have no node, the wall times, and the merged file's points against the
site's (every point once: the stored records, classes aside, compared as a multiset).

``python bench/bench_dtm.py compare NEW.tif OLD.tif`` -- two DTMs node for node: the largest
|difference|, how many nodes differ at all and by more than 1 mm, and the nodes blank in one
only; "holds" when every node is within 1 mm and the blanks are the same (the check a speed
change must pass; ``bench_pdal.py --against REV`` runs it on the 10 M-point file).

``python bench/bench_dtm.py levels [--auto] [--filter-params FILE] [--keep DIR]`` -- reads the raw
ISPRS sites CSite1, FSite5 and FSite8 (``bench/data_paths.py``) and makes each into a 1 m DTM with
``aldpat dtm`` (gapm's defaults unless told otherwise). It counts the DTM's nodes that stand more
than 3 m above a local lower envelope (building remnants) or more than 3 m below a local upper
envelope (pits), and the connected patches they form. The lower envelope (:func:`envelopes`) is
the DTM with its pits narrower than 20 m filled (a closing with a disk of radius 10 m) and then
every bump narrower than 60 m taken off (an opening with a disk of radius 30 m); the upper one the
same two steps the other way round. Both are taken over the DTM's own nodes 10 m or more inside its
edge (where a TIN slants down to the outermost points) and keep planes and steps as they are, so a
node counts only where it stands out of its neighbourhood, not where the ground is steep or runs
to the DTM's edge. For
CSite1 it also prints the DTM's height at (512959, 5403189), where a stepped building stood.

The envelope also cuts terrain that stands out of its surroundings -- a hilltop, a platform on a
slope -- so the remnant patches are split by what the DTM's own ground points say at their edges
(:func:`patch_edges`): a patch is *stepped* where at least half of the TIN edges between its
ground points and those around it climb more than ``STEP_RISE`` onto it at more than
``STEP_SLOPE`` (a roof piece left standing: its points stand on a wall), *smooth* where fewer do
(terrain rising gently to its top, or an object only a map can tell), and *without points* where
no ground point lies in it (a TIN facet slanting between sparse points).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import measure, mib
from data_paths import FSITE5, ISPRS_SAMPLES, ISPRS_SITES

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
            _dtm(tiles, folder / "buffered", mosaic=str(folder / "buffered" / "m.vrt"))
            _dtm(tiles, folder / "unbuffered", mosaic=str(folder / "unbuffered" / "m.vrt"), buffer=0.0)
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


#: The raw sites ``levels`` makes DTMs of, and a point of each where a remnant was seen (or none).
SITES = {"CSite1_red2-utm": (512959.0, 5403189.0), "FSite5_orig-utm": None, "FSite8_red2-utm": None}
#: A node this far above (below) the lower envelope counts as a remnant (pit), m.
LEVEL = 3.0
#: Radii (m) of the envelope's closing (the widest pit) and opening (the widest remnant), halved.
PIT_RADIUS = 10.0
REMNANT_RADIUS = 30.0
#: Nodes this close (m) to the DTM's edge or to a blank node are left out: a TIN slants down to the
#: outermost points there, which no filter decides.
EDGE = 10.0


def envelopes(z: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """The local lower and upper envelopes of a DTM, over its nodes ``EDGE`` or more inside its
    edge and its blank nodes (NaN elsewhere).

    Lower: pits narrower than ``2 * PIT_RADIUS`` filled (a grey-scale closing with a disk), then
    bumps narrower than ``2 * REMNANT_RADIUS`` taken off (an opening with a disk); a remnant stands
    above it. Upper: the same two steps the other way round; a pit lies below it. Filling the pits
    (taking off the bumps) first keeps them from pulling the envelope down (up) around them. Both
    steps keep planes and steps as they are, so the envelopes follow the terrain's slopes and its
    terraces. Only the DTM's own nodes count: a disk reaching past them is the part of it over
    nodes, so a slope running to the edge is not cut as a bump would be (and a bump cut by the
    edge is not counted).
    """
    from scipy import ndimage

    from aldpat.core import morphology

    pit, remnant = round(PIT_RADIUS / cell), round(REMNANT_RADIUS / cell)
    z = np.asarray(z, np.float64)
    inner = ndimage.binary_erosion(np.isfinite(z), morphology.disk_footprint(round(EDGE / cell)), border_value=0)
    pad = pit + remnant
    zp = np.pad(np.where(inner, z, np.nan), pad, constant_values=np.nan)
    blank = np.isnan(zp)
    big = 1e9  # stands for a node that is not there: never the minimum (maximum) of a disk

    def step(values: np.ndarray, radius: int, op: str) -> np.ndarray:
        """Erosion (``min``) or dilation (``max``) over the nodes of each disk; computed over the
        padded grid, so that disks centred off the DTM take part."""
        fill = big if op == "min" else -big
        fn = morphology.erosion if op == "min" else morphology.dilation
        out = fn(np.where(np.isnan(values), fill, values), radius, window="disk")
        out[np.abs(out) >= big / 2] = np.nan
        return out

    def closing(values: np.ndarray) -> np.ndarray:
        out = step(step(values, pit, "max"), pit, "min")
        out[blank] = np.nan  # it stands for the DTM's own nodes only
        return out

    def opening(values: np.ndarray) -> np.ndarray:
        out = step(step(values, remnant, "min"), remnant, "max")
        out[blank] = np.nan
        return out

    lower, upper = opening(closing(zp)), closing(opening(zp))
    return lower[pad:-pad, pad:-pad], upper[pad:-pad, pad:-pad]


def level_counts(z: np.ndarray, cell: float) -> dict:
    """Nodes (and 8-connected patches of them) more than ``LEVEL`` above the lower envelope
    (remnants) and below the upper one (pits), of the nodes the envelopes cover."""
    from scipy import ndimage

    lower, upper = envelopes(z, cell)
    out = {"nodes": int(np.isfinite(lower).sum())}
    with np.errstate(invalid="ignore"):
        for name, depth in (("remnant", z - lower), ("pit", upper - z)):
            mask = depth > LEVEL
            out[name] = int(mask.sum())
            out[f"{name}_patches"] = int(ndimage.label(mask, structure=np.ones((3, 3)))[1])
            out[f"{name}_worst"] = float(depth[mask].max()) if mask.any() else 0.0
    return out


#: A TIN edge climbing more than this (m) onto a remnant patch, at more than this slope, is a step.
STEP_RISE = 1.5
STEP_SLOPE = 0.5
#: TIN edges longer than this (m) are left out (across data gaps and the hull).
LONGEST_EDGE = 15.0


def patch_edges(labels: np.ndarray, transform, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Per patch of ``labels`` (1..n; the DTM's nodes, placed by ``transform``), what its edges
    are made of, from the ground points ``x, y, z``: 0 without points (no ground point in it),
    1 smooth, 2 stepped (the module's docstring). Index 0 of the result is unused."""
    from scipy.spatial import Delaunay

    n = int(labels.max())
    kind = np.zeros(n + 1, np.int8)
    keep = np.unique(np.round(x, 2) * 1e8 + np.round(y, 2), return_index=True)[1]  # one point per place
    x, y, z = x[keep], y[keep], z[keep]
    col = np.clip(np.floor((x - transform.c) / transform.a).astype(np.int64), 0, labels.shape[1] - 1)
    row = np.clip(np.floor((y - transform.f) / transform.e).astype(np.int64), 0, labels.shape[0] - 1)
    patch = labels[row, col]
    simplices = Delaunay(np.c_[x, y]).simplices
    edges = np.unique(np.sort(np.concatenate([simplices[:, [0, 1]], simplices[:, [1, 2]], simplices[:, [2, 0]]]),
                              axis=1), axis=0)
    a, b = edges[:, 0], edges[:, 1]
    length = np.hypot(x[a] - x[b], y[a] - y[b])
    cross = (length <= LONGEST_EDGE) & ((patch[a] > 0) != (patch[b] > 0))
    inside = np.where(patch[a] > 0, a, b)[cross]
    outside = np.where(patch[a] > 0, b, a)[cross]
    rise = z[inside] - z[outside]
    step = (rise > STEP_RISE) & (rise > STEP_SLOPE * length[cross])
    crossing = np.bincount(patch[inside], minlength=n + 1)
    stepped = np.bincount(patch[inside], weights=step, minlength=n + 1)
    kind[crossing > 0] = 1
    kind[(crossing > 0) & (stepped >= 0.5 * crossing)] = 2
    return kind


def remnant_kinds(z: np.ndarray, cell: float, transform, ground: tuple[np.ndarray, np.ndarray, np.ndarray]
                  ) -> dict[str, tuple[int, int]]:
    """The remnant nodes and patches (:func:`level_counts`) by what their edges are made of
    (:func:`patch_edges`): ``{"stepped": (nodes, patches), "smooth": ..., "without points": ...}``."""
    from scipy import ndimage

    lower, _ = envelopes(z, cell)
    with np.errstate(invalid="ignore"):
        labels, n = ndimage.label(z - lower > LEVEL, structure=np.ones((3, 3)))
    out = {}
    if n == 0:
        return {name: (0, 0) for name in ("stepped", "smooth", "without points")}
    kind = patch_edges(labels, transform, *ground)
    size = np.bincount(labels.ravel(), minlength=n + 1)
    for name, k in (("stepped", 2), ("smooth", 1), ("without points", 0)):
        pick = kind == k
        pick[0] = False
        out[name] = (int(size[pick].sum()), int(pick.sum()))
    return out


def site_ground(path: Path, options: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The points ``aldpat dtm`` with ``options`` takes for ground in the file ``path``."""
    import laspy

    import aldpat.tasks  # noqa: F401  (registers every filter)
    from aldpat.filters.driver import ground_filter
    from aldpat.tasks.dtm import DtmParams

    las = laspy.read(path)
    x, y, z = (np.asarray(v, np.float64) for v in (las.x, las.y, las.z))
    params = DtmParams(**options)
    ground = ground_filter(x, y, z, params.algorithm, params.ground_params()).is_ground
    return x[ground], y[ground], z[ground]


def run_levels(auto: bool, filter_params: str | None, keep: str | None) -> None:
    import rasterio

    options: dict = {"cell": 1.0, "auto": auto}
    if filter_params:
        options["filter_params"] = filter_params
    print(f"aldpat dtm --cell 1{' --auto' if auto else ''}"
          f"{' --filter-params ' + filter_params if filter_params else ''}; envelope: closing r {PIT_RADIUS:g} m, "
          f"opening r {REMNANT_RADIUS:g} m; counted beyond {LEVEL:g} m")
    print("| site | nodes | remnant nodes (patches, highest m) | stepped | smooth | without points "
          "| pit nodes (patches, deepest m) | probe height |")
    print("|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        odir = Path(keep) if keep else Path(tmp)
        for name, probe in SITES.items():
            _dtm([ISPRS_SITES / f"{name}.laz"], odir, **options)
            with rasterio.open(odir / f"{name}_dtm.tif") as ds:
                z = ds.read(1, masked=True).filled(np.nan).astype(np.float64)
                cell, transform = ds.res[0], ds.transform
                at = f"{next(ds.sample([probe]))[0]:.1f} m at {probe[0]:.0f}, {probe[1]:.0f}" if probe else ""
            c = level_counts(z, cell)
            kinds = remnant_kinds(z, cell, transform, site_ground(ISPRS_SITES / f"{name}.laz", options))
            split = " | ".join(f"{nodes:,} ({patches})" for nodes, patches in kinds.values())
            print(f"| {name} | {c['nodes']:,} | {c['remnant']:,} ({c['remnant_patches']}, {c['remnant_worst']:.1f}) | "
                  f"{split} | {c['pit']:,} ({c['pit_patches']}, {c['pit_worst']:.1f}) | {at} |")


def shared_nodes(tifs: list[Path]) -> tuple[int, int]:
    """(nodes held by two rasters or more, of them those whose values differ in any bit)."""
    import rasterio

    keys, bits = [], []
    for path in tifs:
        with rasterio.open(path) as ds:
            band = ds.read(1)
            t = ds.transform  # node (row, col) at x = c + a (col + 1/2), y = f + e (row + 1/2)
            cols = np.round((t.c + t.a * (np.arange(ds.width) + 0.5)) * 1000).astype(np.int64)
            rows = np.round((t.f + t.e * (np.arange(ds.height) + 0.5)) * 1000).astype(np.int64)
            keys.append(np.stack(np.meshgrid(cols, rows), axis=-1).reshape(-1, 2))
            bits.append(band.astype(np.float32).view(np.uint32).ravel())
    key, value = np.concatenate(keys), np.concatenate(bits)
    order = np.lexsort((value, key[:, 1], key[:, 0]))
    key, value = key[order], value[order]
    start = np.r_[True, np.any(key[1:] != key[:-1], axis=1)]
    group = np.cumsum(start) - 1
    size = np.bincount(group)
    differs = np.zeros(len(size), bool)
    np.logical_or.at(differs, group[1:][~start[1:]], value[1:][~start[1:]] != value[:-1][~start[1:]])
    return int((size > 1).sum()), int(differs.sum())


def run_project(site_name: str, width: float, buffer: float, cell: float, jobs: int) -> None:
    import laspy

    from aldpat.tasks import get_task

    def timed(name: str, inputs, **options) -> tuple[float, list[str]]:
        start = time.perf_counter()
        report = get_task(*name.split())(inputs, **options)
        if report.exit_code != 0:
            raise RuntimeError(report.input_errors + [r.error for r in report.results if r.error])
        return time.perf_counter() - start, [w for r in report.results for w in r.warnings]

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        source = ISPRS_SITES / f"{site_name}.laz"
        t_tile, _ = timed("tile", [source], width=width, height=width, buffer=buffer, odir=str(root / "tiles"))
        tiles = sorted((root / "tiles").glob("tile_*.laz"))
        t_dtm, warned = timed("dtm", [root / "tiles"], cell=cell, jobs=jobs, odir=str(root / "dtm"),
                              mosaic=str(root / "dtm.vrt"))
        dtm_shared = shared_nodes(sorted((root / "dtm").glob("*_dtm.tif")))
        no_node = sum("no grid written" in w for w in warned)
        t_grid, _ = timed("grid", [root / "tiles"], cell=cell, jobs=jobs, grid_format="geotiff",
                          odir=str(root / "grid"))
        grid_shared = shared_nodes(sorted((root / "grid").glob("*_linear.tif")))
        t_filter, _ = timed("filter gapm", [root / "tiles"], result="classified", jobs=jobs, odir=str(root / "ground"))
        t_merge, _ = timed("merge", [root / "ground"], output=str(root / "site.laz"))
        site, merged = laspy.read(source), laspy.read(root / "site.laz")
        held = sum(laspy.open(p).header.point_count for p in tiles)

        def records(las) -> np.ndarray:
            return np.sort(np.rec.fromarrays([las.X, las.Y, las.Z, las.intensity, las.return_number]))

        same = np.array_equal(records(site), records(merged))
    print(f"{site_name} ({len(site.points):,} points) in {len(tiles)} tiles of {width:g} m with a {buffer:g} m buffer "
          f"({held:,} points held), cell {cell:g} m, -j {jobs}, load {os.getloadavg()[0]:.1f}")
    print("| step | wall s | result |")
    print("|---|---|---|")
    print(f"| tile | {t_tile:.1f} | {len(tiles)} tiles |")
    print(f"| dtm over the tiles | {t_dtm:.1f} | {dtm_shared[0]:,} shared nodes, {dtm_shared[1]} differ; "
          f"{no_node} tiles without a node |")
    print(f"| grid over the tiles (linear, all points) | {t_grid:.1f} | {grid_shared[0]:,} shared nodes, "
          f"{grid_shared[1]} differ |")
    print(f"| filter gapm of the folder | {t_filter:.1f} | classified tiles |")
    print(f"| merge of the classified tiles | {t_merge:.1f} | {len(merged.points):,} points, "
          f"{'every point of the site once' if same else 'NOT the points of the site'} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="command", required=True)
    sub.add_parser("tiles", help="whole vs buffered vs unbuffered tiles on the seven ISPRS samples")
    sp = sub.add_parser("speed", help="aldpat dtm over FSite5 in LAZ tiles")
    sp.add_argument("--tiles", type=int, default=3, help="N: N x N tiles")
    sp.add_argument("--cell", type=float, default=1.0)
    pj = sub.add_parser("project", help="a raw ISPRS site as a project in tiles: tile, dtm, grid, filter, merge")
    pj.add_argument("--site", default=FSITE5.stem, choices=[FSITE5.stem, "CSite1_red2-utm", "FSite8_red2-utm"])
    pj.add_argument("--width", type=float, default=500.0)
    pj.add_argument("--buffer", type=float, default=30.0)
    pj.add_argument("--cell", type=float, default=1.0)
    pj.add_argument("--jobs", type=int, default=2)
    cp = sub.add_parser("compare", help="two DTM GeoTIFFs node for node (the 1 mm check of a speed change)")
    cp.add_argument("new", type=Path)
    cp.add_argument("old", type=Path)
    lv = sub.add_parser("levels", help="remnants and pits in the DTMs of the raw sites CSite1, FSite5, FSite8")
    lv.add_argument("--auto", action="store_true", help="aldpat dtm --auto")
    lv.add_argument("--filter-params", help="aldpat dtm --filter-params FILE")
    lv.add_argument("--keep", help="write the DTMs into this folder (kept) instead of a temporary one")
    args = ap.parse_args()
    if args.command == "tiles":
        run_tiles()
    elif args.command == "levels":
        run_levels(args.auto, args.filter_params, args.keep)
    elif args.command == "project":
        run_project(args.site, args.width, args.buffer, args.cell, args.jobs)
    elif args.command == "compare":
        from bench_pdal import compare_dtms

        print(compare_dtms(args.new, args.old))
    else:
        run_speed(args.tiles, args.cell)


if __name__ == "__main__":
    main()
