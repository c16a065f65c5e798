"""What a task is: :class:`Task`, the one declaration a task module registers (its parameters,
its run functions, the outputs it plans), and :class:`Planned`, an output known before it runs.

A leaf of :mod:`aldpat.jobs`: every module that runs tasks imports it, and it imports none of
them. Registering a task and calling it from Python live a layer up, in
:mod:`aldpat.jobs.registry`.
"""

from __future__ import annotations

import fnmatch
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aldpat.options import InputParams, OutputParams, PointOutputParams, RunParams
from aldpat.params import Spec, specs


@dataclass(frozen=True)
class Planned:
    """An output a job will write, known before it runs: a file, or (``family``) the files of a
    folder whose names match a pattern (``*``, ``?``, ``[...]`` in the name only), as many as
    the data make (split-tape's strips, tile's tiles)."""

    path: Path
    source: Path | None = None  # the input it is made from; None: made from every input (a mosaic)
    role: str = ""  # what the task calls it (filter: "ground", "object", "all")
    family: bool = False
    #: how a user gives it another name, said when it clashes
    rename: str = "give --odir or another --suffix"
    #: the path parameter that names it (``mosaic``, ``map``, ``output``): that one is not an input
    named_by: str | None = None

    def matches(self, path: str | Path) -> bool:
        """Whether ``path`` is this output (or one of this family)."""
        path = Path(path)
        if self.family:
            return (os.path.abspath(path.parent) == os.path.abspath(self.path.parent)
                    and fnmatch.fnmatchcase(path.name, self.path.name))
        return os.path.abspath(path) == os.path.abspath(self.path)



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
    #: extensions of the files other than points a points task reads too (``preview``: grids)
    other_inputs: tuple[str, ...] = ()
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
    #: ``check(params)``: the task's rules that relate its parameters to what their class cannot
    #: see itself (``aldpat filter``: the filter's registered reach, whether it needs every point
    #: at once), raising :class:`~aldpat.errors.ParamError`; run when a run's parameters are
    #: resolved, right after the class's own :meth:`~aldpat.params.Checked.check`, so a dry run
    #: refuses what the run would. Rules of the parameters alone belong in that class.
    check: Callable[[Any], None] | None = None

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

    def planned_outputs(self, sources: list[Path], params: Any, ctx: Any) -> list[Planned]:
        """Every output of a run (or a job) of ``sources``, in order, each once."""
        if self.outputs is None:
            return []
        if self.run_one is not None:
            planned = [p for s in sources for p in self.outputs(s, params, ctx)]
        else:
            planned = list(self.outputs(sources, params, ctx)) if sources or self.inputs == "none" else []
        mosaics: set[tuple[Path, bool]] = set()
        unique = []
        for p in planned:  # an output of every input (a mosaic) is planned once
            if p.source is None:
                # against the other outputs of every input only: a mosaic named like one input's
                # grid is a second output of that name, which the plan's check refuses
                key = (p.path, p.family)
                if key in mosaics:
                    continue
                mosaics.add(key)
            unique.append(p)
        return unique

    def all_specs(self) -> list[Spec]:
        """Every parameter of the task's command or worksheet job, each once, its own first."""
        seen: dict[str, Spec] = {}
        for cls in self.option_classes:
            for s in specs(cls):
                seen.setdefault(s.name, s)
        return list(seen.values())
