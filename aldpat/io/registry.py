"""Point format registry: extension -> format, one chunked interface for every reader.

``open_points`` returns a :class:`PointReader`; ``write_points`` opens an atomic writer that
takes chunks and renames the finished file into place, shaped like a :class:`PointSource`.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any, Protocol, TypeVar

from aldpat.errors import DataError, InputFormatError, InputMissingError, UsageError
from aldpat.io.atomic import atomic_output
from aldpat.io.las import LasReader, LasWriter
from aldpat.io.table import PointTable
from aldpat.io.text import TextReader, TextWriter


class PointSource(Protocol):
    """What a writer copies from its source (``like=``): a LAS output takes the source's header
    (point format, scale, offset, VLRs) and CRS, a text output its decimals."""

    @property
    def format(self) -> str: ...  # "text" or "las"

    @property
    def crs(self) -> Any: ...  # a pyproj CRS, or None when unknown

    @property
    def decimals(self) -> dict[str, int] | None: ...


class PointReader(PointSource, Protocol):
    """The contract of every point reader (:class:`~aldpat.io.text.TextReader`,
    :class:`~aldpat.io.las.LasReader`)."""

    @property
    def path(self) -> Path: ...

    @property
    def names(self) -> tuple[str, ...]: ...

    @property
    def count(self) -> int | None: ...  # None when unknown before reading (text)

    def chunks(self, size: int = ...) -> Iterator[PointTable]: ...

    def read(self) -> PointTable: ...


#: extension -> format name
EXTENSIONS = {".txt": "text", ".xyz": "text", ".csv": "text", ".pts": "text", ".las": "las", ".laz": "las"}
#: format name -> reader (mypy checks that each meets the PointReader contract)
FORMATS: dict[str, Callable[..., PointReader]] = {"text": TextReader, "las": LasReader}
#: a reader of either format (what :func:`holding_points` keeps it gives back)
R = TypeVar("R", bound=PointReader)
#: output format name -> default extension (``--out-format``)
OUT_EXTENSIONS = {"text": ".txt", "csv": ".csv", "las": ".las", "laz": ".laz"}


def detect_format(path: Path, override: str | None = None) -> str:
    if override and override != "auto":
        if override in ("las", "laz"):
            return "las"
        if override in ("text", "txt", "csv", "xyz", "pts", "ascii"):
            return "text"
        raise UsageError(f"unknown format {override!r} (use text, las or laz)")
    fmt = EXTENSIONS.get(Path(path).suffix.lower())
    if fmt is None:
        raise InputFormatError(
            f"unknown extension {Path(path).suffix!r} (point files are .txt .xyz .csv .pts .las .laz; "
            "use --format to say which)", path=path)
    return fmt


def open_points(path: str | Path, *, format: str | None = None, layout: str = "points",
                order: str = "last-first") -> PointReader:
    """A chunked reader for a point file (``layout="altm9"`` for 9-column tapes)."""
    path = Path(path)
    if not path.exists():
        raise InputMissingError("no such file", path=path)
    if path.is_dir():
        raise InputFormatError("is a folder, not a point file", path=path)
    fmt = detect_format(path, format)
    if fmt == "las" and layout == "altm9":
        raise UsageError("ALTM 9-column tapes are text files", path=path)
    return FORMATS[fmt](path, layout=layout, order=order)


def holding_points(readers: list[R], warn: Callable[[str], None], what: str) -> list[R]:
    """The readers of ``merge``'s inputs whose files hold points. A LAS tile whose header says it
    holds none (emptied by a filter, a delivery's placeholder) adds nothing, as lasmerge and PDAL
    take it: it is named in a warning and left out -- with its point format, extra bytes and CRS,
    which it does not bring either -- instead of failing the merge of every other tile. When none
    holds a point, the first is returned, whose reading says so. (``tile`` refuses an empty strip
    among its inputs, as any input it cannot use: a strip of no points is a delivery's fault.)"""
    full = [r for r in readers if r.count != 0]
    for reader in readers:
        if reader.count == 0:
            warn(f"{reader.path.name}: holds no points: nothing of it is {what}")
    return full or readers[:1]


def one_crs(readers: list[PointReader], task: str) -> Any:
    """The CRS the inputs of a task combining them into one product (``merge``, ``tile``) share, or
    None when none names one; an input naming another than the first that does is a
    :class:`DataError`: its coordinates are of another system, and written beside the others'
    under one CRS they would lie where they are not (``--crs`` relabels, it does not re-project)."""
    known = [r for r in readers if getattr(r, "crs", None) is not None]
    for reader in known[1:]:
        if reader.crs != known[0].crs:
            raise DataError(f"its CRS differs from {known[0].path.name}'s: {task} inputs of one CRS (re-project "
                            "with 'aldpat ortho-height --to-crs')", path=reader.path)
    return known[0].crs if known else None


def output_extension(source: Path | None, out_format: str | None) -> str:
    """The extension an output of the input ``source`` gets: the input's unless ``--out-format``
    says otherwise."""
    if out_format and out_format != "same":
        return OUT_EXTENSIONS[out_format]
    return Path(source).suffix.lower() if source is not None else ".txt"


@contextlib.contextmanager
def write_points(path: str | Path, names: tuple[str, ...], *, overwrite: bool = False,
                 like: PointSource | None = None,
                 delimiter: str = "space", decimals: Mapping[str, int] | None = None, crs: Any = None, template: Any = None
                 ) -> Iterator[LasWriter | TextWriter]:
    """Open an atomic point writer; the file appears under ``path`` only when the block succeeds.

    ``like`` is the source reader: a LAS output keeps its header (format, scale, offset, VLRs),
    or ``template``'s when given, a text output its decimals. ``decimals``: those to write (a
    text output) or keep (the scales of a LAS output made for text points) instead of the
    chunks' own; a live mapping where they may widen as the input is read.
    """
    path = Path(path)
    fmt = detect_format(path)
    writer: LasWriter | TextWriter
    with atomic_output(path, overwrite=overwrite) as tmp:
        if fmt == "las":
            if template is None and getattr(like, "format", None) == "las":
                template = getattr(like, "header", None)
            writer = LasWriter(tmp, names, template=template, crs=crs if crs is not None else getattr(like, "crs", None),
                               compress=path.suffix.lower() == ".laz", decimals=decimals)
        else:
            if decimals is None and like is not None:
                decimals = getattr(like, "decimals", None)
            writer = TextWriter(tmp, names, delimiter="comma" if path.suffix.lower() == ".csv" and delimiter == "space"
                                else delimiter, decimals=decimals)
        try:
            yield writer
        finally:
            writer.close()
