"""``aldpat ortho-height``: ellipsoidal -> orthometric heights, optionally re-projecting x, y.

ALDPAT 1.0 user manual (2007), task 3 "Convert ellipsoid to orthometric heights" (Corpscon's job):
``H = h - N`` with a geoid grid, ``--reverse`` for ``h = H + N``, and x, y converted between
datums, UTM zones or State Plane (``--to-crs``). Streams chunk by chunk in bounded memory; a
point outside the geoid grid stops that file with a message naming it (no silent 0 or NaN).
Conversion: :mod:`aldpat.core.heights`.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aldpat.core.crs import parse_crs
from aldpat.core.heights import Z_UNITS, HeightConverter, geoid_transformer
from aldpat.errors import AldpatError, ParamError, UsageError
from aldpat.jobs.context import JobContext, Planned
from aldpat.jobs.registry import Task, register_task
from aldpat.options import CrsOption
from aldpat.params import param


@dataclass(frozen=True)
class OrthoHeightParams(CrsOption):
    geoid: str | None = param(None, "geoid grid: a GTX or GeoTIFF file (such as egm96_15.gtx) or a grid name "
                              "PROJ knows", path=True, metavar="GRID", required=True)
    to_crs: str | None = param(None, "re-project x, y to this CRS (datum, UTM zone, State Plane...)")
    reverse: bool = param(False, "orthometric -> ellipsoidal heights (h = H + N)", level="advanced")
    z_unit: str = param("m", "unit of the input and output heights (the geoid is in metres)",
                        choices=tuple(Z_UNITS), level="advanced")

    def check(self) -> None:
        super().check()
        if self.geoid is None:
            return  # required: resolve() says so
        try:
            geoid_transformer(self.geoid)  # the grid opens, or the job stops before reading inputs
        except AldpatError as exc:
            raise ParamError(f"geoid: {exc}") from None
        if self.to_crs is not None:
            parse_crs(self.to_crs, key="to_crs")


def ortho_height_outputs(source: Path, params: OrthoHeightParams, ctx: JobContext) -> list[Planned]:
    return [Planned(ctx.output_path(source, "_Ortho"), source)]


def ortho_height_one(source: Path, params: OrthoHeightParams, ctx: JobContext) -> None:
    reader = ctx.open_input(source)
    crs = params.crs or reader.crs
    if crs is None:
        raise UsageError("--crs is required: the input does not say which CRS its x, y are in", path=source)
    assert params.geoid is not None  # required
    convert = HeightConverter(crs, params.geoid, to_crs=params.to_crs, reverse=params.reverse,
                              z_unit=params.z_unit)
    out = ctx.outputs_for(source)[0].path
    like, decimals = reader, None
    if convert.to_crs is not None:
        dec = dict(getattr(reader, "decimals", None) or {})
        if convert.to_crs.is_geographic:
            dec.update(x=9, y=9)  # degrees need more decimals than metres
        decimals = dec or None
        if reader.format == "las":
            like = _reprojected_template(reader, convert)
    with ctx.write_points(out, reader.names, like=like, decimals=decimals, crs=convert.to_crs or convert.crs) \
            as writer:
        done = 0
        for chunk in reader.chunks():
            x, y, z = convert(chunk.x, chunk.y, chunk.z, first=done, path=source)
            writer.write(chunk.with_columns(x=x, y=y, z=z))
            done += len(chunk)
    ctx.wrote(out, writer.count)


@dataclass(frozen=True)
class _LasTemplate:
    """A LAS header to write re-projected points with (a :class:`~aldpat.io.registry.PointSource`)."""

    header: Any
    crs: Any
    format: str = "las"
    decimals: dict[str, int] | None = None


def _reprojected_template(reader, convert: HeightConverter) -> _LasTemplate:
    """The LAS source's header (point format, VLRs, every attribute kept) with the target CRS
    and an x, y scale and offset that suit the new coordinates (1e-7 for degrees)."""
    header = copy.deepcopy(reader.header)
    assert convert.to_crs is not None  # called only when re-projecting
    x0, y0 = (float(v[0]) for v in convert.horizontal([header.mins[0]], [header.mins[1]], path=reader.path))
    if convert.to_crs.is_geographic:
        header.scales = np.array([1e-7, 1e-7, header.scales[2]])
        header.offsets = np.array([np.floor(x0), np.floor(y0), header.offsets[2]])
    else:
        header.offsets = np.array([np.floor(x0 / 1000.0) * 1000.0, np.floor(y0 / 1000.0) * 1000.0,
                                   header.offsets[2]])
    header.add_crs(convert.to_crs)
    return _LasTemplate(header, convert.to_crs)


register_task(Task(
    name="ortho-height",
    summary="Ellipsoidal -> orthometric heights with a geoid grid (H = h - N), optionally re-projecting x, y "
            "(manual task 3, Corpscon's job).",
    params=OrthoHeightParams,
    run_one=ortho_height_one,
    examples=(
        ("aldpat ortho-height strips/*.txt --geoid egm96_15.gtx --crs EPSG:4979",
         "orthometric heights, H = h - N, from an EGM96 grid"),
        ("aldpat ortho-height site.laz --geoid egm96_15.gtx --to-crs EPSG:32617",
         "and x, y re-projected to UTM 17N"),
    ),
    outputs=ortho_height_outputs,
))
