"""What a task's run function gets (:class:`JobContext`: output names, atomic writers, and
where to record outputs, warnings and results) and what one job gives back (:class:`JobResult`).

Every output a job writes is :class:`Planned` before anything runs, by the task's one
``outputs`` hook (:attr:`aldpat.jobs.task.Task.outputs`): the run refuses outputs that would
replace an input or each other before any job starts (:mod:`aldpat.jobs.outputs`), and a task
takes the names it writes from the same hook (:meth:`JobContext.outputs_for`), so what was
checked is what is written; :meth:`JobContext.wrote` holds every output to the plan.
"""

from __future__ import annotations

import logging
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from aldpat.errors import one_line
from aldpat.io.registry import PointReader, PointSource, open_points, output_extension, write_points
from aldpat.jobs.task import Planned, Task

log = logging.getLogger(__name__)


class Record(dict):
    """A machine-readable result of a reporting task (``info``, ``evaluate``): its items are what
    ``--json`` prints; :meth:`lines` is the text a person reads. Each task's record subclasses
    this with its own :meth:`lines`."""

    def lines(self) -> list[str]:
        return ["  ".join(f"{k}={_text(v)}" for k, v in self.items())]


def points_said(n: int) -> str:
    """``1 point``, ``12,379 points``."""
    return f"{n:,} point{'' if n == 1 else 's'}"


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
    #: what the job counted (:meth:`JobContext.tally`): points read, ground points, grid nodes
    counts: dict[str, int] = field(default_factory=dict)
    error: str | None = None
    usage: bool = False  # the error was a usage error (exit status 2)
    existed: bool = False  # the error was an output that exists (made before, no --overwrite)
    detail: str | None = None  # traceback of an unexpected failure (shown with -v)
    seconds: float = 0.0
    log_path: str | None = None

    @property
    def ok(self) -> bool:
        return self.error is None

    @property
    def ground_share(self) -> float | None:
        """Ground points as a share of the points read (None when the job did not count them)."""
        points, ground = self.counts.get("points"), self.counts.get("ground")
        return ground / points if points and ground is not None else None

    def summary(self, one_input: bool = True) -> str:
        """One line saying what the job did: its input, points read, ground share or grid nodes,
        time, and its output -- ``site.laz: 131,622 points, 48.2 % ground, 3.1 s -> site_gapm.laz``.
        ``one_input``: the job is its first input's (the others, a tile's neighbours, are read
        for it), not a job of all its inputs together."""
        n = len(self.inputs)
        name = Path(self.inputs[0]).name if one_input and n else f"{n} input{'' if n == 1 else 's'}"
        parts = []
        if "points" in self.counts:
            parts.append(points_said(self.counts["points"]))
        if self.ground_share is not None:
            parts.append(f"{100 * self.ground_share:.1f} % ground")
        if self.counts.get("points") and "noise" in self.counts:
            parts.append(f"{100 * self.counts['noise'] / self.counts['points']:.1f} % noise")
        did = ", ".join(parts)
        if "nodes" in self.counts:
            nodes, blank = self.counts["nodes"], self.counts.get("blank", 0)
            grid = f"{nodes:,} nodes" + (f" ({100 * blank / nodes:.1f} % blank)" if blank and nodes else "")
            did = f"{did} -> {grid}" if did else grid
        did = f"{did}, {self.seconds:.1f} s" if did else f"{self.seconds:.1f} s"
        if self.outputs:
            first = self.outputs[0]
            out = first.path + (f" ({points_said(first.count)})" if first.count is not None and "points" not in self.counts
                                else "")
            if len(self.outputs) > 1:
                out += f" and {len(self.outputs) - 1} more"
            did += f" -> {out}"
        return one_line(f"{name}: {did}")


class JobContext:
    """Output naming, atomic writing and bookkeeping for one job."""

    def __init__(self, task: Task, output: Any, input_opts: Any, result: JobResult, params: Any = None):
        self.task = task
        self.output = output  # an OutputParams (PointOutputParams for point outputs), or None
        self.input = input_opts
        self.result = result
        self.params = params  # the task's own parameters
        #: inputs a planned job reads besides its own (:attr:`Task.plan`): neighbouring tiles
        self.neighbours: list[Path] = []
        #: processes the job may use for its chunks (``--chunk``)
        self.workers = 1
        #: the run's scratch folder, where a first pass leaves what the task's jobs read
        self.scratch: Path | None = None
        self._planned: list[Planned] | None = None
        #: the beginnings of the output names made from an input's name (:meth:`output_path`),
        #: which ``--suffix`` changes
        self.named_after_inputs: list[str] = []

    # names
    def output_path(self, source: Path, default_suffix: str, ext: str | None = None, *,
                    reader: PointReader | None = None, use_suffix_option: bool = True) -> Path:
        """``<odir or source folder>/<stem><suffix><ext>`` (the output place and name of every
        task); without ``ext``, the input's extension unless ``--out-format`` says otherwise
        (``reader`` is the input's reader, or None: the name alone decides)."""
        source = Path(source)
        suffix = default_suffix
        if use_suffix_option and self.output is not None and self.output.suffix is not None:
            suffix = self.output.suffix
        if ext is None:
            ext = output_extension(reader.path if reader is not None else source,
                                   getattr(self.output, "out_format", None))
        folder = self.output_dir(source)
        if use_suffix_option and self.output is not None:
            self.named_after_inputs.append(str(folder / f"{source.stem}{suffix}"))
        return folder / f"{source.stem}{suffix}{ext}"

    def outputs_for(self, source: Path) -> list[Planned]:
        """The outputs of ``source`` as the task's ``outputs`` hook plans them (the names the
        run was checked with before it started)."""
        assert self.task.outputs is not None, f"task {self.task.key} plans no outputs"
        return list(self.task.outputs(Path(source), self.params, self))

    def planned(self, sources: list[Path]) -> list[Planned]:
        """Every output of a job of ``sources`` (computed once)."""
        if self._planned is None:
            self._planned = self.task.planned_outputs([Path(s) for s in sources], self.params, self)
        return self._planned

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

    def write_points(self, path: Path, names: tuple[str, ...], *, like: PointSource | None = None,
                     **kwargs: Any) -> AbstractContextManager[Any]:
        """An atomic point writer honouring ``--overwrite`` and ``--delimiter``."""
        return write_points(path, names, overwrite=self.overwrite, like=like, delimiter=self.delimiter, **kwargs)

    def open_input(self, path: Path, **kwargs: Any) -> Any:
        """The reader of ``path`` in the run's ``--format``: a :class:`~aldpat.io.registry.PointReader`,
        the text or LAS one, whose own attributes (a LAS header, a text file's header lines) a
        task reads where it knows which it has."""
        fmt = self.input.format if self.input is not None else None
        return open_points(path, format=fmt, **kwargs)

    # bookkeeping
    def wrote(self, path: Path, count: int | None = None) -> None:
        """Record an output; it must be one the job planned (an output the plan missed is one the
        run's checks for outputs replacing inputs did not see: a fault of the task)."""
        planned = self._planned
        if planned is not None and not any(p.matches(path) for p in planned):
            raise AssertionError(f"{path}: written but not among the outputs {self.task.key} planned")
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

    def tally(self, **counts: int) -> None:
        """Add to what the job counted, for the line a command ends with and the run report:
        ``points`` (read from its input), ``ground`` (of those, ground), ``nodes`` and ``blank``
        (grid nodes written, and of those left blank)."""
        for key, n in counts.items():
            self.result.counts[key] = self.result.counts.get(key, 0) + int(n)
