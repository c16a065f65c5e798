"""``aldpat info``: what a point file holds (like ``lasinfo``), streamed in chunks."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aldpat.options import JsonOption
from aldpat.tasks.base import JobContext, Task, register_task


@dataclass(frozen=True)
class InfoParams(JsonOption):
    """Only the shared ``json``."""


def crs_text(crs) -> str | None:
    if crs is None:
        return None
    epsg = crs.to_epsg()
    return f"EPSG:{epsg}" if epsg else crs.name


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
    ctx.emit({
        "path": str(source),
        "count": count,
        "bounds": [float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])],
        "z_range": [float(lo[2]), float(hi[2])],
        "density": count / area if area > 0 else None,
        "fields": list(reader.names),
        "format": reader.format if reader.format != "las" else source.suffix.lower().lstrip("."),
        "delimiter": {" ": "space", ",": "comma", "\t": "tab"}.get(getattr(reader, "delimiter", "")),
        "crs": crs_text(reader.crs),
    })


register_task(Task(
    name="info",
    summary="Count, bounds, z range, density, fields, format and CRS of point files (like lasinfo).",
    params=InfoParams,
    run_one=info_one,
    writes_outputs=False,
))
