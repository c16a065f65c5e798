"""What a task's run function gets (:class:`JobContext`: output names, atomic writers, and
where to record outputs, warnings and results) and what one job gives back (:class:`JobResult`)."""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aldpat.io.registry import output_extension, write_points

if TYPE_CHECKING:
    from aldpat.jobs.registry import Task

log = logging.getLogger(__name__)


class Record(dict):
    """A machine-readable result of a reporting task (``info``, ``evaluate``): its items are what
    ``--json`` prints; :meth:`lines` is the text a person reads. Each task's record subclasses
    this with its own :meth:`lines`."""

    def lines(self) -> list[str]:
        return ["  ".join(f"{k}={_text(v)}" for k, v in self.items())]


def _text(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.3f}"
    if isinstance(v, list):
        return "  ".join(_text(x) for x in v)
    return "-" if v is None else str(v)


@dataclass
class Written:
    path: str
    count: int | None = None  # points (None for non-point outputs)


@dataclass
class JobResult:
    """What one job did; picklable so it can come back from a worker process."""

    inputs: list[str]
    outputs: list[Written] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)  # values the job derived (written to its log)
    records: list[Record] = field(default_factory=list)  # machine-readable results (info, evaluate)
    error: str | None = None
    usage: bool = False  # the error was a usage error (exit status 2)
    detail: str | None = None  # traceback of an unexpected failure (shown with -v)
    seconds: float = 0.0
    log_path: str | None = None

    @property
    def ok(self) -> bool:
        return self.error is None


class JobContext:
    """Output naming, atomic writing and bookkeeping for one job."""

    def __init__(self, task: Task, output: Any, input_opts: Any, result: JobResult):
        self.task = task
        self.output = output  # an OutputParams (PointOutputParams for point outputs), or None
        self.input = input_opts
        self.result = result
        #: inputs a planned job reads besides its own (:attr:`Task.plan`): neighbouring tiles
        self.neighbours: list[Path] = []
        #: processes the job may use for its chunks (``--chunk``)
        self.workers = 1

    # names
    def output_path(self, source: Path, default_suffix: str, ext: str | None = None, *,
                    reader=None, use_suffix_option: bool = True) -> Path:
        """``<odir or source folder>/<stem><suffix><ext>`` (the output place and name of every task)."""
        source = Path(source)
        suffix = default_suffix
        if use_suffix_option and self.output is not None and self.output.suffix is not None:
            suffix = self.output.suffix
        if ext is None:
            ext = output_extension(reader, getattr(self.output, "out_format", None)) \
                if reader is not None else source.suffix
        folder = self.output_dir(source)
        return folder / f"{source.stem}{suffix}{ext}"

    def output_dir(self, source: Path | None = None) -> Path:
        if self.output is not None and self.output.odir:
            return Path(self.output.odir)
        return Path(source).parent if source is not None else Path.cwd()

    @property
    def overwrite(self) -> bool:
        return bool(self.output is not None and self.output.overwrite)

    @property
    def delimiter(self) -> str:
        return getattr(self.output, "delimiter", "space")

    def write_points(self, path: Path, names: tuple[str, ...], *, like=None, **kwargs):
        """An atomic point writer honouring ``--overwrite`` and ``--delimiter``."""
        return write_points(path, names, overwrite=self.overwrite, like=like, delimiter=self.delimiter, **kwargs)

    def open_input(self, path: Path, **kwargs):
        from aldpat.io.registry import open_points

        fmt = self.input.format if self.input is not None else None
        return open_points(path, format=fmt, **kwargs)

    # bookkeeping
    def wrote(self, path: Path, count: int | None = None) -> None:
        self.result.outputs.append(Written(str(path), count))

    def warn(self, message: str) -> None:
        """A warning for the log file and stderr (reported once the job ends, in input order)."""
        self.result.warnings.append(message)

    def note(self, message: str) -> None:
        """A value the job derived from its data (``--auto``), recorded in the job log."""
        self.result.notes.append(message)
        log.info(message)

    def emit(self, record: Record) -> None:
        self.result.records.append(record)
