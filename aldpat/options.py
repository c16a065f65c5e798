"""Options shared by several tasks and filters, each declared once.

A params class takes a shared option by plain inheritance (``class ThinParams(OriginOption)``).
Shared options are listed after the class's own parameters in ``--help`` and logs
(:class:`SharedOption`). The ALDPAT 1.0 user manual (2007, "4. Description of Tasks") names
several of these choices in more than one task: "Fields" (XYZI or XYZ, tasks 2 and 7) and the
column order of the 9-column tapes (task 1: "t, x2, y2, z2, i2, x1, y1, z1, i1" by default,
"t, x1, y1, z1, i1, x2, y2, z2, i2" when REALM exported it the other way).
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from typing import TYPE_CHECKING

from aldpat.core.crs import parse_crs
from aldpat.core.workers import MOST_WORKERS
from aldpat.errors import ParamError, one_line
from aldpat.params import Checked, SharedOption, param

if TYPE_CHECKING:  # for annotations only: the readers are io's, which these options do not need to run
    from aldpat.io.registry import PointReader


@dataclass(frozen=True)
class FieldsOption(SharedOption):
    fields: str = param("xyzi", "columns written to text outputs: x y z and intensity, or x y z only",
                        choices=("xyzi", "xyz"), manual="Fields")


@dataclass(frozen=True)
class OrderOption(SharedOption):
    order: str = param("last-first", "column order of 9-column tapes: t x2 y2 z2 i2 x1 y1 z1 i1 (last return "
                       "first, the manual's) or t x1 y1 z1 i1 x2 y2 z2 i2", choices=("last-first", "first-last"))


@dataclass(frozen=True)
class OriginOption(SharedOption):
    origin: tuple[float, float] | None = param(
        None, "grid origin X Y (default: cells aligned to whole multiples of the cell size)", unit="m",
        metavar="X Y", level="advanced",
    )


@dataclass(frozen=True)
class CrsOption(SharedOption, Checked):
    crs: str | None = param(
        None, "CRS of the x, y coordinates: an EPSG code (EPSG:32617 or 32617), a UTM zone such as 17N, or "
        "WKT; written into LAS/LAZ headers, GeoTIFFs and .prj files (default: a LAS input's own CRS; given, it "
        "replaces a LAS input's, with a warning, without re-projecting)")

    def check(self) -> None:
        super().check()
        if self.crs is not None:
            parse_crs(self.crs)


@dataclass(frozen=True)
class CellHeightOption(SharedOption):
    """Rectangular cells: ``cell`` (declared by the class taking this option) is the width."""

    if TYPE_CHECKING:
        cell: float  # declared, with its default and help, by each class taking this option

    cell_height: float | None = param(None, "cell height (none: square cells of cell)", unit="m", gt=0,
                                      manual="Height", renamed_from=("height",), level="advanced")

    def cell_shape(self) -> tuple[float, float]:
        """Width and height of the cells."""
        width = float(self.cell)
        return width, self.cell_height if self.cell_height is not None else width


@dataclass(frozen=True)
class ElevationLimitsOption(SharedOption, Checked):
    max_z: float | None = param(None, "highest elevation allowed for ground (none: no limit)", unit="m",
                                manual="Max Z", level="advanced")
    min_z: float | None = param(None, "lowest elevation allowed for ground (none: no limit)", unit="m",
                                manual="Min Z", level="advanced")

    def check(self) -> None:
        super().check()
        if self.min_z is not None and self.max_z is not None and self.min_z > self.max_z:
            raise ParamError(f"min_z: {self.min_z:g} is above max_z {self.max_z:g}")


@dataclass(frozen=True)
class JsonOption(SharedOption):
    json: bool = param(False, "print JSON (one object per input) instead of a table")


def point_names(reader: PointReader, fields: str) -> tuple[str, ...]:
    """Columns a point output carries: x y z, plus intensity when asked for and present."""
    names: tuple[str, ...] = ("x", "y", "z")
    if fields == "xyzi" and "intensity" in reader.names:
        names += ("intensity",)
    return names


def kept_names(reader: PointReader, out: str | os.PathLike[str]) -> tuple[str, ...]:
    """Columns a task that keeps whole points writes: every column, except that LAS/LAZ going to
    text keeps x y z and intensity (as ``convert`` does), not the LAS flags."""
    if reader.format == "las" and str(out).lower().endswith((".las", ".laz")):
        return reader.names
    if reader.format == "las":
        return point_names(reader, "xyzi")
    return reader.names


# ---------------------------------------------------------------------------- every command


@dataclass(frozen=True)
class ChunkOption(SharedOption, Checked):
    """Processing one input in square chunks with buffers (lidR's chunk size and chunk buffer):
    memory bounded by a chunk, chunks in parallel with ``-j``."""

    chunk: float | None = param(None, "process each input in square chunks of this size (rounded to whole cells), "
                                "each with a buffer, in bounded memory and in parallel with -j; none: whole",
                                unit="m", gt=0, level="advanced")
    chunk_buffer: str = param("auto", "buffer around each chunk in metres, or auto: what the filter needs "
                              "(twice its windows' reach; a point filter's own buffer)", metavar="M|auto",
                              level="advanced")
    tmpdir: str | None = param(None, "folder for the chunks' temporary files (default: the output folder)",
                               path=True, metavar="DIR", level="advanced")
    catalog: bool = param(False, "with --chunk: take all inputs as one catalog (tiles without buffers of their "
                          "own), so each chunk's buffer reaches into the neighbouring files; one output per input",
                          level="advanced")

    def check(self) -> None:
        super().check()
        if self.catalog and self.chunk is None:
            raise ParamError("catalog: takes the inputs together in chunks; give --chunk SIZE too")
        self.buffer_metres()

    def chunk_cells(self, cell: float) -> int:
        """The side of a ``--chunk`` in whole cells of ``cell`` m (at least one)."""
        assert self.chunk is not None
        return max(1, round(self.chunk / cell))

    def buffer_metres(self) -> float | None:
        """``chunk_buffer`` in metres, or None for ``auto`` (what the filter or the grid needs):
        the one place it is read, so a bad value is refused when the parameters are made."""
        if self.chunk_buffer == "auto":
            return None
        try:
            value = float(self.chunk_buffer)
        except ValueError:
            raise ParamError(f"chunk_buffer: expected metres or auto, got {self.chunk_buffer!r}") from None
        if not (math.isfinite(value) and value >= 0):
            raise ParamError(f"chunk_buffer: must be at least 0, got {self.chunk_buffer}")
        return value


@dataclass(frozen=True)
class OverwriteOption(SharedOption):
    """Whether existing outputs are replaced: every file-writing task's (:class:`OutputParams`),
    and a reporting task's that writes a picture on request (``evaluate --map``)."""

    overwrite: bool = param(False, "replace existing outputs")


@dataclass(frozen=True)
class OutputParams(OverwriteOption, Checked):
    """Options every file-writing task shares."""

    odir: str | None = param(None, "output folder, created if missing (default: beside each input)", path=True,
                             metavar="DIR")
    suffix: str | None = param(None, "output name suffix, replacing the task's default", level="advanced")

    def check(self) -> None:
        super().check()
        if self.suffix is not None:
            check_name_part("suffix", self.suffix)


@dataclass(frozen=True)
class PointOutputParams(OutputParams):
    """Options of a task whose outputs are point files (not grids, pictures or shapefiles)."""

    delimiter: str = param("space", "delimiter of text outputs", choices=("space", "comma"), manual="Preference",
                           level="advanced")
    out_format: str = param("same", "output format", choices=("same", "text", "csv", "las", "laz"))


def check_name_part(key: str, text: str) -> None:
    """Refuse a part of a file name (``--suffix``) that could leave the output folder or break a
    line: a path separator, ``..`` or a control character."""
    separators = {"/", "\\", os.sep, os.altsep or "/"}
    if any(sep in text for sep in separators) or ".." in text:
        raise ParamError(f"{key}: {text!r} holds a path separator or '..'; it is a part of a file name "
                         "(use --odir for another folder)")
    if one_line(text) != text:
        raise ParamError(f"{key}: {one_line(text)!r} holds a control character")


@dataclass(frozen=True)
class InputParams:
    """How inputs are read."""

    format: str = param("auto", "input format (auto: by extension)", choices=("auto", "text", "las"),
                        level="advanced")


@dataclass(frozen=True)
class RunParams(Checked):
    """How the jobs are run (not recorded as task parameters)."""

    jobs: int = param(1, "worker processes (0 = all cores; at most four per core, and as many as the memory "
                         "holds); results identical to -j 1", ge=0, le=1024)
    scheduler: str | None = param(None, "run the jobs on a Dask cluster: its scheduler's address (tcp://host:8786, "
                                  "tls://host:8786 with Dask's TLS settings), or local:N for N worker processes "
                                  "here; default: $ALDPAT_SCHEDULER, else none (needs aldpat[dask]; inputs and "
                                  "outputs on a file system the workers share; a worksheet or parameter file may "
                                  "name an address only if the command line or $ALDPAT_SCHEDULER gives the same)",
                                  metavar="ADDRESS", level="advanced")

    def check(self) -> None:
        super().check()
        if self.scheduler is not None:
            check_scheduler(self.scheduler)


#: scheduler values that mean "no cluster" (to override ``$ALDPAT_SCHEDULER``)
NO_SCHEDULER = ("none", "off", "")
#: ``local`` or ``local:N`` (a Dask cluster of N workers here), or a Dask scheduler's address
LOCAL_SCHEDULER = re.compile(r"^local(?::(\d+))?$")
SCHEDULER_ADDRESS = re.compile(r"^(tcp|tls|ucx|inproc|ws|wss)://\S+$")


def check_scheduler(text: str) -> None:
    """Refuse, before anything runs, a scheduler that is none of ``none``, ``local[:N]`` and an
    address (the option, a worksheet's setting and ``$ALDPAT_SCHEDULER`` alike)."""
    if text.lower() in NO_SCHEDULER:
        return
    m = LOCAL_SCHEDULER.match(text)
    if m:
        if m.group(1) is not None and not 1 <= int(m.group(1)) <= MOST_WORKERS:
            raise ParamError(f"scheduler: {text!r}: local:N needs N from 1 to {MOST_WORKERS} "
                             f"({os.cpu_count() or 1} cores here)")
        return
    if not SCHEDULER_ADDRESS.match(text):
        raise ParamError(f"scheduler: {text!r}: expected a Dask scheduler address such as tcp://host:8786, "
                         "or local:N for N worker processes on this machine")

