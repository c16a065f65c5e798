"""``aldpat ortho-height``: ellipsoidal -> orthometric heights, optionally re-projecting x, y.

ALDPAT 1.0 user manual (2007), task 3 "Convert ellipsoid to orthometric heights" (Corpscon's job):
``H = h - N`` with a geoid grid, ``--reverse`` for ``h = H + N``, and x, y converted between
datums, UTM zones or State Plane (``--to-crs``). Streams chunk by chunk in bounded memory; a
point outside the geoid grid stops that file with a message naming it (no silent 0 or NaN).
Conversion: :mod:`aldpat.core.heights`.

The output says its vertical datum (:func:`~aldpat.core.heights.recorded_crs`): orthometric heights
as a compound CRS, horizontal + EGM96 height (EPSG:5773) or the vertical CRS of a compound
``--to-crs`` (``EPSG:32632+5783``); ``--reverse`` output as the horizontal CRS alone. A compound
CRS is OGC WKT in a LAS 1.4 header, so a LAS 1.2 input (formats 0-5) is written as LAS 1.4 in
the format of the same attributes (0, 1 -> 6; 2, 3 -> 7; 4 -> 9; 5 -> 10), every attribute kept;
an output whose CRS GeoTIFF keys hold (``--reverse`` to an EPSG-coded CRS) keeps the input's
version and format. Why upgrade rather than keep 1.2 with the horizontal CRS: most delivered
LAS is 1.2 and laspy's GeoTIFF keys hold no vertical datum, so keeping 1.2 would leave most
outputs without the one thing this command changes. The LAS 1.4 specification (R15, section
2.5) makes OGC WKT the CRS of formats 6-10; PDAL's writers.las writes a compound ``a_srs`` as
WKT with ``minor_version=4``, and LAStools converts with ``las2las -set_version 1.4
-set_point_type 6``. Text outputs carry no CRS, as no text point file aldpat writes does (no
``.prj`` beside point files).
"""

from __future__ import annotations

from collections import ChainMap
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aldpat.core.crs import parse_crs
from aldpat.core.heights import Z_UNITS, HeightConverter, check_to_crs, geoid_transformer
from aldpat.errors import AldpatError, ParamError, UsageError
from aldpat.io.las import holding_crs
from aldpat.jobs.context import JobContext
from aldpat.jobs.registry import register_task
from aldpat.jobs.task import Planned, Task
from aldpat.options import CrsOption
from aldpat.params import param


@dataclass(frozen=True)
class OrthoHeightParams(CrsOption):
    geoid: str | None = param(None, "geoid grid: a GTX or GeoTIFF file (such as egm96_15.gtx) or a grid name "
                              "PROJ knows", path=True, metavar="GRID", required=True)
    to_crs: str | None = param(None, "re-project x, y to this CRS (datum, UTM zone, State Plane...); a "
                               "compound CRS (EPSG:32632+5783) also names the output's height datum "
                               "(default: EGM96 height, EPSG:5773)")
    reverse: bool = param(False, "orthometric -> ellipsoidal heights (h = H + N); the output records the "
                          "horizontal CRS alone", level="advanced")
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
            check_to_crs(self.to_crs, reverse=self.reverse, z_unit=self.z_unit)


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
        # the reader's own decimals, which it widens as it reads (a live view, not a copy); degrees
        # need more decimals than metres
        decimals = ChainMap({"x": 9, "y": 9} if convert.to_crs.is_geographic else {},
                            getattr(reader, "decimals", None) or {})
    if reader.format == "las":
        like = _las_template(reader, convert)
    if out.suffix.lower() in (".las", ".laz"):
        ctx.note(f"{out.name}: CRS recorded: {convert.recorded_crs.name}")
    with ctx.write_points(out, reader.names, like=like, decimals=decimals, crs=convert.recorded_crs) as writer:
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


def _las_template(reader, convert: HeightConverter) -> _LasTemplate:
    """The LAS source's header, as LAS 1.4 when the output's CRS needs WKT
    (:func:`~aldpat.io.las.as_las14`: VLRs and every attribute kept), with the output's CRS as WKT and, when re-projecting, an x, y scale and offset
    that suit the new coordinates (1e-7 for degrees, a millimetre for metres or feet)."""
    header = holding_crs(reader.header, convert.recorded_crs)
    if convert.to_crs is not None:
        x0, y0 = (float(v[0]) for v in convert.horizontal([header.mins[0]], [header.mins[1]], path=reader.path))
        if convert.to_crs.is_geographic:
            header.scales = np.array([1e-7, 1e-7, header.scales[2]])
            header.offsets = np.array([np.floor(x0), np.floor(y0), header.offsets[2]])
        else:
            # a millimetre, or the source's finer step -- not its step in degrees (1e-7 of a metre
            # holds only 214 m of UTM coordinates: the way back from degrees failed)
            step = [float(v) if 1e-4 <= float(v) < 1e-3 else 1e-3 for v in header.scales[:2]]
            header.scales = np.array([step[0], step[1], header.scales[2]])
            header.offsets = np.array([np.floor(x0 / 1000.0) * 1000.0, np.floor(y0 / 1000.0) * 1000.0,
                                       header.offsets[2]])
    return _LasTemplate(header, convert.recorded_crs)


register_task(Task(
    name="ortho-height",
    summary="Ellipsoidal -> orthometric heights with a geoid grid (H = h - N), optionally re-projecting x, y "
            "(manual task 3, Corpscon's job).",
    epilog="A LAS/LAZ output records its height datum: horizontal CRS + EGM96 height (EPSG:5773), or the "
           "vertical CRS of a compound --to-crs, as WKT in LAS 1.4 (a LAS 1.2 input is written as LAS 1.4, "
           "every attribute kept); --reverse records the horizontal CRS alone. Text outputs carry no CRS.",
    params=OrthoHeightParams,
    run_one=ortho_height_one,
    examples=(
        ("aldpat ortho-height strips/*.txt --geoid egm96_15.gtx --crs EPSG:4979",
         "orthometric heights, H = h - N, from an EGM96 grid"),
        ("aldpat ortho-height site.laz --geoid egm96_15.gtx --to-crs EPSG:32617",
         "and x, y re-projected to UTM 17N; the output (LAS 1.4) records UTM 17N + EGM96 height"),
        ("aldpat ortho-height site.laz --geoid gcg2016.tif --to-crs EPSG:25832+7837",
         "heights above a national geoid, recorded as ETRS89 / UTM 32N + DHHN2016 height"),
    ),
    outputs=ortho_height_outputs,
))
