"""``aldpat separate-returns``: a 9-column strip -> a first-return and a last-return point file.

ALDPAT 1.0 user manual (2007), Task 2 "Separate First and Last Return Measurements from a 9 Column
Strip File", with its parameters UTM Zone, Stop Gap and Fields (see :mod:`aldpat.core.returns`
for the rules). The first-return file gets the suffix ``_1``, the last-return file ``_2``
("second stop files (identified by the suffix '_2')"), which the manual recommends moving "into
the appropriate directory": ``--last-odir`` writes them there directly. Streamed chunk by chunk.
"""

from __future__ import annotations

import contextlib
import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aldpat.core.crs import output_crs
from aldpat.core.returns import stop_gap_mask, strip_zone, zone_prefix
from aldpat.errors import DataError, ParamError
from aldpat.io.las import RETURN_DIMENSIONS
from aldpat.io.table import PointTable
from aldpat.io.text import PulseDecimals
from aldpat.jobs.context import JobContext
from aldpat.jobs.registry import register_task
from aldpat.jobs.task import Planned, Task
from aldpat.options import CrsOption, FieldsOption, OrderOption
from aldpat.params import Checked, param

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SeparateReturnsParams(FieldsOption, OrderOption, CrsOption, Checked):
    utm_zone: str = param("auto", "UTM zone prefixed to x and y: auto (detect by digit count), none, or the "
                          "zone number to strip", manual="UTM Zone", metavar="auto|none|N")
    stop_gap: float = param(5.0, "where first minus last return elevation is below this, the last return is "
                            "replaced by the first", unit="m", manual="Stop Gap")
    last_odir: str | None = param(None, "folder for the last-return (_2) files, which the manual recommends "
                                  "keeping apart (default: with the first-return files)", path=True, metavar="DIR",
                                  level="advanced")

    def check(self) -> None:
        super().check()
        parse_zone(self.utm_zone)


def parse_zone(value: str) -> str | int:
    """``"auto"``, ``"none"`` or a zone number 1..60; anything else is a :class:`ParamError`."""
    text = str(value).strip().lower()
    if text in ("auto", "none"):
        return text
    try:
        zone = int(text)
    except ValueError:
        zone = -1
    if not 1 <= zone <= 60:
        raise ParamError(f"utm_zone: expected auto, none or a zone number 1-60, got {value!r}")
    return zone


class ZoneStripper:
    """Removes a UTM zone prefix from x and y, deciding (auto) on the first chunk and checking the
    rest; a file whose points disagree is refused with the line of the first offender."""

    def __init__(self, setting: str | int, source: Path, first_line: int):
        self.zone = None if setting == "auto" else (0 if setting == "none" else setting)
        self.auto = setting == "auto"
        self.source = source
        self.first_line = first_line

    def __call__(self, x: np.ndarray, y: np.ndarray, row0: int) -> tuple[np.ndarray, np.ndarray]:
        if self.zone == 0 and not self.auto:
            return x, y
        zx, zy = zone_prefix(x, y)
        if self.zone is None:
            self.zone = int(zx[0]) if zx[0] == zy[0] else -1
            if self.zone > 60 or self.zone < 0:
                self._bad(0, f"x {x[0]:.3f}, y {y[0]:.3f} carry no consistent UTM zone prefix "
                          "(use --utm-zone none to keep coordinates as they are)")
            if self.zone:
                log.info("%s: UTM zone %d prefixed to x and y (removed)", self.source, self.zone)
        wrong = np.flatnonzero((zx != self.zone) | (zy != self.zone))
        if len(wrong):
            k = int(wrong[0])
            what = "no zone prefix" if self.zone == 0 else f"zone {self.zone}"
            self._bad(row0 + k, f"x {x[k]:.3f}, y {y[k]:.3f} do not carry {what} like the other points")
        return (x, y) if self.zone == 0 else strip_zone(x, y, int(self.zone))

    def _bad(self, row: int, message: str) -> None:
        raise DataError(message, path=self.source, line=self.first_line + row)


def las_returns(out: Path) -> tuple[str, ...]:
    """The return columns a LAS/LAZ output of a tape carries (a text output keeps the manual's
    x y z [i])."""
    return RETURN_DIMENSIONS if out.suffix.lower() in (".las", ".laz") else ()


def pulse_returns(out: Path, number: int, n: int) -> dict[str, np.ndarray]:
    """Return ``number`` of 2 for ``n`` points of a LAS/LAZ output: an ALTM tape records two
    returns of every pulse, first and last (ALDPAT 1.0 user manual (2007), task 1: "t, x2, y2,
    z2, i2, x1, y1, z1, i1"), so the first is return 1 of 2 and the last 2 of 2, as LAS readers
    (lidR's ``las_check``, LAStools) expect of a file of several returns. A last return replaced
    by the first within the stop gap stays 2 of 2: it is the pulse's last return as the manual
    defines it."""
    if not las_returns(out):
        return {}
    return {"return_number": np.full(n, number, np.uint8), "number_of_returns": np.full(n, 2, np.uint8)}


def separate_returns_outputs(source: Path, params: SeparateReturnsParams, ctx: JobContext) -> list[Planned]:
    """``<stem>_1`` (first returns) and ``<stem>_2`` (last returns, in ``--last-odir`` if given)."""
    suffix = ctx.output.suffix if ctx.output is not None and ctx.output.suffix is not None else "_"
    first_out = ctx.output_path(source, f"{suffix}1", use_suffix_option=False)
    last_out = ctx.output_path(source, f"{suffix}2", use_suffix_option=False)
    if params.last_odir:
        last_out = Path(params.last_odir) / last_out.name
    return [Planned(first_out, source, "first"), Planned(last_out, source, "last")]


def separate_returns_one(source: Path, params: SeparateReturnsParams, ctx: JobContext) -> None:
    reader = ctx.open_input(source, layout="altm9", order=params.order)
    first_out, last_out = (p.path for p in ctx.outputs_for(source))
    names = ("x", "y", "z") + (("intensity",) if params.fields == "xyzi" else ())
    decimals = PulseDecimals(reader.decimals)
    # a stripped zone leaves as many decimals as before
    strip = ZoneStripper(parse_zone(params.utm_zone), source, reader.first_data_line)
    crs = output_crs(params.crs, None, first_out, ctx.warn)  # a tape names no CRS; one line for both files
    replaced = total = 0
    with contextlib.ExitStack() as stack:
        w1 = stack.enter_context(ctx.write_points(first_out, names + las_returns(first_out), decimals=decimals,
                                                  crs=crs))
        w2 = stack.enter_context(ctx.write_points(last_out, names + las_returns(last_out), decimals=decimals,
                                                  crs=crs))
        for chunk in reader.chunks():
            x1, y1 = strip(chunk["x1"], chunk["y1"], total)
            x2, y2 = strip(chunk["x2"], chunk["y2"], total)
            z1, z2 = chunk["z1"], chunk["z2"]
            i1, i2 = chunk["i1"], chunk["i2"]
            swap = stop_gap_mask(z1, z2, params.stop_gap, decimals.get("z"))
            first = {"x": x1, "y": y1, "z": z1, "intensity": i1}
            last = {"x": np.where(swap, x1, x2), "y": np.where(swap, y1, y2), "z": np.where(swap, z1, z2),
                    "intensity": np.where(swap, i1, i2)}
            w1.write(PointTable({n: first[n] for n in names} | pulse_returns(first_out, 1, len(chunk)),
                                meta={"decimals": decimals}))
            w2.write(PointTable({n: last[n] for n in names} | pulse_returns(last_out, 2, len(chunk)),
                                meta={"decimals": decimals}))
            replaced += int(swap.sum())
            total += len(chunk)
    ctx.wrote(first_out, w1.count)
    ctx.wrote(last_out, w2.count)
    log.info("%s: %d of %d last returns replaced by the first (stop gap %g m)", source, replaced, total,
             params.stop_gap)


register_task(Task(
    name="separate-returns",
    summary="Split a 9-column strip into first-return (_1) and last-return (_2) point files, replacing last "
            "returns within the stop gap of the first (manual task 2).",
    params=SeparateReturnsParams,
    run_one=separate_returns_one,
    examples=(
        ("aldpat separate-returns strips/*.txt --odir returns/",
         "first returns (_1) and last returns (_2) of each strip"),
        ("aldpat separate-returns strip01.txt --stop-gap 5 --utm-zone auto",
         "last returns within 5 m of the first replaced, UTM zone prefix found"),
    ),
    outputs=separate_returns_outputs,
))
