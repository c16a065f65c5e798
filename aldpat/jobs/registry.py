"""The task registry: every task registers a :class:`Task` under its command name.

A task is one module in ``aldpat/tasks/`` that declares its parameters once (a frozen dataclass
of :func:`aldpat.params.param` fields) and registers a :class:`Task` with either

* ``run_one(source, params, ctx)`` -- one job per input file, run in parallel with ``-j``; or
* ``run_all(sources, params, ctx)`` -- one job for all inputs (merge, tile, shapefile...);

and says, with ``outputs``, every file it will write before it runs (one hook for every task:
:meth:`Task.planned_outputs`), so that an output that would replace an input, or another output,
is refused before anything runs.

The CLI command and the worksheet job for a task are derived from the same registration, so
adding a task is one module plus its tests.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from aldpat.errors import UsageError
from aldpat.options import InputParams, OutputParams, PointOutputParams, RunParams
from aldpat.params import specs

if TYPE_CHECKING:
    from aldpat.jobs.context import Planned
    from aldpat.jobs.run import RunReport


@dataclass(frozen=True)
class Task:
    name: str
    summary: str
    params: type
    run_one: Callable | None = None
    run_all: Callable | None = None
    group: str | None = None  # "filter" for `aldpat filter ALGO`
    inputs: str = "many"  # "many" (at least one) or "none"
    writes_outputs: bool = True
    epilog: str | None = None
    #: ``finish(results, params, ctx)``: once, in this process, after every job (``grid --mosaic``)
    finish: Callable | None = None
    #: ``plan(sources, params, input_params) -> jobs``: a ``run_one`` task whose job reads more than its
    #: own input (``dtm``: the neighbours within its buffer) lists them after it, ``[own, *others]``
    plan: Callable | None = None
    #: the inputs are point files, so ``--format`` applies (False: grids, boundary files)
    reads_points: bool = True
    #: the outputs are point files, so ``--delimiter`` and ``--out-format`` apply (False: grids,
    #: pictures, shapefiles): a command lists only the options that do something for it
    writes_points: bool = True
    #: ``(command line, what it does)`` pairs that open the command's ``--help``
    examples: tuple[tuple[str, str], ...] = ()
    #: ``first(sources, params, input_params) -> jobs``: the jobs of a pass run before the task's own,
    #: each calling ``first_pass(source, params, ctx)``; what they write under ``ctx.scratch`` the
    #: task's jobs read (``dtm`` over tiles: every tile's ground classes, which the DTMs of its
    #: neighbours need near their shared edges). An empty list: no first pass.
    first: Callable | None = None
    first_pass: Callable | None = None
    #: ``outputs(source, params, ctx) -> [Planned]`` (``run_one``: the outputs of one input) or
    #: ``outputs(sources, params, ctx)`` (``run_all``): every file the task writes, named with
    #: ``ctx.output_path`` before anything runs; the run function takes its names from it
    #: (``ctx.outputs_for(source)``). An output made from every input (a mosaic) has no source.
    outputs: Callable | None = None

    @property
    def key(self) -> str:
        return f"{self.group} {self.name}" if self.group else self.name

    @property
    def option_classes(self) -> tuple[type, ...]:
        """Every params class a command line / worksheet job of this task accepts."""
        common: tuple[type, ...] = (InputParams,) if self.reads_points else ()
        if self.writes_outputs:
            common += (PointOutputParams,) if self.writes_points else (OutputParams,)
        return (self.params,) + common + (RunParams,)

    def planned_outputs(self, sources: list[Path], params, ctx) -> list[Planned]:
        """Every output of a run (or a job) of ``sources``, in order, each once."""
        if self.outputs is None:
            return []
        if self.run_one is not None:
            planned = [p for s in sources for p in self.outputs(s, params, ctx)]
        else:
            planned = list(self.outputs(sources, params, ctx)) if sources or self.inputs == "none" else []
        seen: set[tuple[Path, bool]] = set()
        unique = []
        for p in planned:  # an output of every input (a mosaic) is planned once
            key = (p.path, p.family)
            if p.source is None and key in seen:
                continue
            seen.add(key)
            unique.append(p)
        return unique

    def all_specs(self):
        seen = {}
        for cls in self.option_classes:
            for s in specs(cls):
                seen.setdefault(s.name, s)
        return list(seen.values())

    def __call__(self, inputs: Iterable[str | Path] = (), **kwargs) -> RunReport:
        """Run from Python with the same parameter names as the CLI and worksheets."""
        from aldpat.jobs.run import run_task

        return run_task(self, list(inputs), [("python", kwargs)])

    def __reduce__(self):
        # A task travels to worker processes by its registry key: its functions may be closures
        # (one per filter algorithm) that pickle cannot carry.
        return (_registered_task, (self.key,))


TASKS: dict[str, Task] = {}


def _registered_task(key: str) -> Task:
    import aldpat.tasks  # noqa: F401  (a spawned worker registers the tasks again)

    return TASKS[key]


def register_task(task: Task) -> Task:
    if task.key in TASKS:
        raise ValueError(f"task {task.key!r} registered twice")
    TASKS[task.key] = task
    return task


def get_task(name: str, algorithm: str | None = None) -> Task:
    import aldpat.tasks  # noqa: F401  (registers every task module)

    key = f"{name} {algorithm}" if algorithm else name
    if key not in TASKS:
        import difflib

        options = sorted(TASKS)
        hint = difflib.get_close_matches(key, options, n=1)
        did = f"; did you mean {hint[0]!r}?" if hint else ""
        raise UsageError(f"unknown task {key!r}{did}")
    return TASKS[key]
