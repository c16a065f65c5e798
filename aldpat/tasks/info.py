"""``aldpat info``: what a point file holds (like ``lasinfo``), streamed in chunks."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aldpat.jobs.context import JobContext, Record
from aldpat.jobs.registry import Task, register_task
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
            ("x range", f"{b[0]:.3f} .. {b[2]:.3f}  ({b[2] - b[0]:.3f})"),
            ("y range", f"{b[1]:.3f} .. {b[3]:.3f}  ({b[3] - b[1]:.3f})"),
            ("z range", f"{self['z_range'][0]:.3f} .. {self['z_range'][1]:.3f}"),
            ("density", "-" if self["density"] is None else f"{self['density']:.3f} points per unit² (bounding box)"),
            ("crs", self["crs"] or "unknown"),
        ]
        return [self["path"]] + [f"  {k:8} {v}" for k, v in rows]


def info_one(source: Path, params: InfoParams, ctx: JobContext) -> None:
    reader = ctx.open_input(source)
    count = 0
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for chunk in reader.chunks():
        if len(chunk) == 0:
            continue
        count += len(chunk)
        for k, name in enumerate("xyz"):
            col = chunk[name]
            lo[k] = min(lo[k], float(col.min()))
            hi[k] = max(hi[k], float(col.max()))
    area = float((hi[0] - lo[0]) * (hi[1] - lo[1]))
    ctx.emit(InfoRecord({
        "path": str(source),
        "count": count,
        "bounds": [float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])],
        "z_range": [float(lo[2]), float(hi[2])],
        "density": count / area if area > 0 else None,
        "fields": list(reader.names),
        "format": reader.format if reader.format != "las" else source.suffix.lower().lstrip("."),
        "delimiter": {" ": "space", ",": "comma", "\t": "tab"}.get(getattr(reader, "delimiter", "")),
        "crs": crs_text(reader.crs),
    }))


register_task(Task(
    name="info",
    summary="Count, bounds, z range, density, fields, format and CRS of point files (like lasinfo).",
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
