"""``aldpat info``: what a point file holds (like ``lasinfo``), streamed in chunks.

A technician's first look: count, bounds, density, fields and CRS; for a LAS its version, point
format, generating software, class and return histograms and withheld points; and a warning when
z values lie far outside the bulk of the file (:func:`far_heights`) -- noise a grid or a filter
would otherwise take for terrain -- and when x or y do (:func:`far_places`): a stray point that
stretches every grid of the file."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aldpat.jobs.context import JobContext, Record
from aldpat.jobs.registry import register_task
from aldpat.jobs.task import Task
from aldpat.options import JsonOption


@dataclass(frozen=True)
class InfoParams(JsonOption):
    """Only the shared ``json``."""


def crs_text(crs) -> str | None:
    if crs is None:
        return None
    epsg = crs.to_epsg()
    return f"EPSG:{epsg}" if epsg else crs.name


class InfoRecord(Record):
    """What ``aldpat info`` reports of one file."""

    def lines(self) -> list[str]:
        b = self["bounds"]
        delimited = f" ({self['delimiter']}-delimited)" if self.get("delimiter") else ""
        rows = [
            ("format", self["format"] + delimited),
            ("points", f"{self['count']:,}"),
            ("fields", " ".join(self["fields"])),
            ("x range", "-" if b is None else f"{b[0]:.3f} .. {b[2]:.3f}  ({b[2] - b[0]:.3f})"),
            ("y range", "-" if b is None else f"{b[1]:.3f} .. {b[3]:.3f}  ({b[3] - b[1]:.3f})"),
            ("z range", "-" if b is None else f"{self['z_range'][0]:.3f} .. {self['z_range'][1]:.3f}"),
            ("density", "-" if self["density"] is None else f"{self['density']:.3f} points per unit² (bounding box)"),
            ("crs", self["crs"] or "unknown"),
        ]
        if self.get("las_version"):
            rows += [
                ("las", f"version {self['las_version']}, point format {self['point_format']}"),
                ("software", self["software"] or "-"),
                ("classes", histogram_text(self["classes"])),
                ("returns", histogram_text(self["returns"])),
                ("withheld", f"{self['withheld']:,}"),
            ]
        return [self["path"]] + [f"  {k:8} {v}" for k, v in rows]


def histogram_text(counts: dict[str, int]) -> str:
    return ", ".join(f"{k}: {v:,}" for k, v in counts.items()) or "-"


#: Points sampled to find the bulk of a file's x, y and z values: a uniform sample of the whole
#: file (:class:`Sample`), so memory is bounded whatever its size.
SAMPLE = 200_000
#: The bulk of the heights: between these percentiles.
BULK = (0.1, 99.9)


class Sample:
    """A uniform random sample of at most :data:`SAMPLE` rows of a stream of chunks: each row
    gets a random key and the rows of the smallest keys are kept (bottom-k sampling)."""

    def __init__(self, seed: int = 0) -> None:
        self._rng = np.random.default_rng(seed)
        self._keys = np.zeros(0)
        self._rows = np.zeros((0, 3))
        self._bound = 1.0  # keys at or above this can no longer be kept

    def add(self, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> None:
        if len(x) > SAMPLE // 4:  # a chunk's share, drawn at once (the chunks of a file are alike in size)
            pick = self._rng.integers(0, len(x), SAMPLE // 4)
            x, y, z = x[pick], y[pick], z[pick]
        keys = self._rng.random(len(x))
        take = np.flatnonzero(keys < self._bound)
        self._keys = np.concatenate([self._keys, keys[take]])
        self._rows = np.concatenate([self._rows, np.column_stack([x[take], y[take], z[take]])])
        if len(self._keys) > 2 * SAMPLE:
            keep = np.argpartition(self._keys, SAMPLE)[:SAMPLE]
            self._keys, self._rows = self._keys[keep], self._rows[keep]
            self._bound = float(self._keys.max())

    @property
    def rows(self) -> np.ndarray:
        """The sampled (x, y, z) rows."""
        return self._rows


def far_heights(sample: np.ndarray, zmin: float, zmax: float) -> str | None:
    """A warning when the lowest or highest z lies far outside the bulk of the heights (the
    ``BULK`` percentiles of ``sample``): more than half the bulk's range beyond it, and 20 m at
    least -- FSite5's 899 m over a bulk of 251-389 m, not a hillside's summit."""
    if len(sample) < 100:
        return None
    lo, hi = (float(v) for v in np.percentile(sample, BULK))
    margin = max(0.5 * (hi - lo), 20.0)
    far = []
    if zmax > hi + margin:
        far.append(f"up to {zmax:.2f} (high noise?)")
    if zmin < lo - margin:
        far.append(f"down to {zmin:.2f} (low noise?)")
    if not far:
        return None
    return (f"z values lie far outside the bulk of the file: {BULK[1] - BULK[0]:g} % of the points lie within "
            f"{lo:.2f} .. {hi:.2f}, yet z goes {' and '.join(far)}")


def far_places(sample: np.ndarray, name: str, vmin: float, vmax: float) -> str | None:
    """A warning when the extent of x (or y) comes from points far outside the bulk of the file
    (the ``BULK`` percentiles of ``sample``): beyond it by more than its width, and 1 km at least
    -- a wrong coordinate that makes every grid of the file span the gap."""
    if len(sample) < 100:
        return None
    lo, hi = (float(v) for v in np.percentile(sample, BULK))
    margin = max(hi - lo, 1000.0)
    if vmax <= hi + margin and vmin >= lo - margin:
        return None
    return (f"{name} values lie far outside the bulk of the file: {BULK[1] - BULK[0]:g} % of the points lie "
            f"within {lo:.2f} .. {hi:.2f}, yet {name} spans {vmin:.6g} .. {vmax:.6g} (a stray point? a grid "
            "of the file spans it all)")


def info_one(source: Path, params: InfoParams, ctx: JobContext) -> None:
    reader = ctx.open_input(source)
    count = 0
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    classes = np.zeros(256, np.int64)
    returns = np.zeros(256, np.int64)
    withheld = 0
    sample = Sample()
    # a LAS file of no points is a valid file (an empty edge tile of a delivery): its header is
    # reported, with a warning, where reading its points would refuse it
    empty = reader.format == "las" and reader.count == 0
    if empty:
        ctx.warn(f"{source.name}: holds no points")
    for chunk in () if empty else reader.chunks():
        if len(chunk) == 0:
            continue
        count += len(chunk)
        for k, name in enumerate("xyz"):
            col = chunk[name]
            lo[k] = min(lo[k], float(col.min()))
            hi[k] = max(hi[k], float(col.max()))
        sample.add(np.asarray(chunk.x), np.asarray(chunk.y), np.asarray(chunk.z))
        if reader.format == "las":
            classes += np.bincount(np.asarray(chunk["classification"]).astype(np.int64), minlength=256)[:256]
            if "return_number" in chunk:
                returns += np.bincount(np.asarray(chunk["return_number"]).astype(np.int64), minlength=256)[:256]
            if chunk.record is not None and "withheld" in chunk.record.point_format.dimension_names:
                withheld += int(np.count_nonzero(chunk.record["withheld"]))
    area = float((hi[0] - lo[0]) * (hi[1] - lo[1]))
    if count:
        rows = sample.rows
        for k, name in enumerate("xy"):
            if (far := far_places(rows[:, k], name, float(lo[k]), float(hi[k]))) is not None:
                ctx.warn(f"{source.name}: {far}")
        if (far := far_heights(rows[:, 2], float(lo[2]), float(hi[2]))) is not None:
            ctx.warn(f"{source.name}: {far}")
    las = {}
    if reader.format == "las":
        header = reader.header
        las = {
            "las_version": f"{header.version.major}.{header.version.minor}",
            "point_format": int(header.point_format.id),
            "software": str(header.generating_software).strip("\x00 ") or None,
            "classes": {str(c): int(n) for c, n in enumerate(classes) if n},
            "returns": {str(r): int(n) for r, n in enumerate(returns) if n},
            "withheld": withheld,
        }
    ctx.emit(InfoRecord({
        "path": str(source),
        "count": count,
        "bounds": [float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])] if count else None,
        "z_range": [float(lo[2]), float(hi[2])] if count else None,
        "density": count / area if count and area > 0 else None,
        "fields": list(reader.names),
        "format": reader.format if reader.format != "las" else source.suffix.lower().lstrip("."),
        "delimiter": {" ": "space", ",": "comma", "\t": "tab"}.get(getattr(reader, "delimiter", "")),
        "crs": crs_text(reader.crs),
        **las,
    }))


register_task(Task(
    name="info",
    summary="Count, bounds, z range, density, fields, format and CRS of point files; LAS version, software, "
            "class and return histograms; a warning for far heights (like lasinfo).",
    params=InfoParams,
    run_one=info_one,
    writes_outputs=False,
    examples=(
        ("aldpat info tiles/*.laz",
         "count, bounds, z range, density, fields and CRS of each file"),
        ("aldpat info site.txt --json",
         "one JSON object per input, for scripts"),
    ),
))
