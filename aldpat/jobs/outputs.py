"""Outputs that would destroy data, refused before anything runs.

Each task plans its outputs before it runs (:attr:`aldpat.jobs.task.Task.outputs`). From the
plan a run refuses, naming both files:

* an output that is one of the run's inputs -- the same path, or the same file reached through
  a symbolic or hard link (``filter pm a.txt --suffix "" --overwrite`` would replace ``a.txt``
  with its ground points), or a file a path parameter reads (a polygon, a reference);
* two outputs of one run with one name (``filter pm d1/x.txt d2/x.txt --odir o``: the second
  would replace the first).

A worksheet adds (:func:`aldpat.worksheet.model.load_worksheet`): no job may replace a file an
earlier job (or itself) read as an original input, nor an output of another job; a job reading
an earlier job's outputs is the usual chaining.
"""

from __future__ import annotations

import bisect
import fnmatch
import functools
import os
import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

from aldpat.core.paths import folds_case
from aldpat.errors import UsageError
from aldpat.io.atomic import not_replaceable
from aldpat.jobs.context import JobContext, JobResult
from aldpat.jobs.joblog import MARK as JOB_LOG_MARK
from aldpat.jobs.resolve import ResolvedRun
from aldpat.jobs.task import Planned, Task


def plan_outputs(task: Task, sources: list[Path], run: ResolvedRun) -> list[Planned]:
    """The outputs a run of ``task`` over ``sources`` will write (nothing is read or written)."""
    ctx = JobContext(task, run.output.values if run.output else None, run.input.values if run.input else None,
                     JobResult([]), run.params.values)
    return task.planned_outputs(sources, run.params.values, ctx)


@functools.lru_cache(maxsize=1 << 16)
def _real_folder(folder: str) -> str:
    return os.path.realpath(folder)


def real(path: str | Path) -> str:
    """``os.path.realpath`` of ``path``, its folder's resolved once for all the files in it (a
    worksheet of 10,000 jobs names few folders)."""
    path = os.path.abspath(path)
    if os.path.islink(path):
        return os.path.realpath(path)
    return os.path.join(_real_folder(os.path.dirname(path)), os.path.basename(path))


def forget_folders() -> None:
    """Resolve folders afresh (links may have changed since the last check)."""
    _real_folder.cache_clear()


def _identity(path: Path) -> tuple[int, int] | None:
    """The file ``path`` is (device and inode, through links), or None where there is none."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_dev, st.st_ino


@dataclass
class Reads:
    """Files read, found by path (links resolved), by identity (hard links too) and, for a family
    of outputs, by folder and name."""

    paths: dict[str, Path] = field(default_factory=dict)
    identities: dict[tuple[int, int], Path] = field(default_factory=dict)
    _names: dict[str, list[str]] | None = None  # folder -> sorted names, made when a family asks

    def add(self, path: Path) -> None:
        self.paths.setdefault(real(path), path)
        identity = _identity(path)
        if identity is not None:
            self.identities.setdefault(identity, path)
        self._names = None

    def replaced_by(self, output: Planned) -> Path | None:
        """The file read that ``output`` would replace, if any."""
        if output.family:
            return self._in_family(output)
        hit = self.paths.get(real(output.path))
        if hit is None:
            identity = _identity(output.path)
            hit = self.identities.get(identity) if identity is not None else None
        return hit

    def _in_family(self, output: Planned) -> Path | None:
        if self._names is None:
            self._names = {}
            for resolved in self.paths:
                self._names.setdefault(os.path.dirname(resolved), []).append(os.path.basename(resolved))
            for names in self._names.values():
                names.sort()
        folder = real(output.path.parent)
        names = self._names.get(folder, [])
        prefix = literal_prefix(output.path.name)
        for name in names[bisect.bisect_left(names, prefix):]:  # only the names the pattern can begin
            if not name.startswith(prefix):
                break
            if fnmatch.fnmatchcase(name, output.path.name):
                return self.paths[os.path.join(folder, name)]
        return None


def literal_prefix(pattern: str) -> str:
    """What every name a glob pattern matches begins with (``[*]`` stands for ``*``)."""
    out = []
    k = 0
    while k < len(pattern):
        c = pattern[k]
        if c in "*?":
            break
        if c == "[":
            end = pattern.find("]", k + 2)
            if end == k + 2:  # one character in brackets: that character
                out.append(pattern[k + 1])
                k = end + 1
                continue
            break
        out.append(c)
        k += 1
    return "".join(out)


def path_parameter_files(run: ResolvedRun, planned: Iterable[Planned]) -> list[Path]:
    """Files the run's path parameters name that exist (a polygon, a reference, tile parameters,
    a geoid grid): they are read too -- all but the parameters that name outputs (``mosaic``) --
    and the parameter files (``--params``) its values came from."""
    outputs = {p.named_by for p in planned}
    paths = {s.name for s in run.task.all_specs() if s.path} - outputs
    out = [p for p in run.params_files if p.is_file()]
    for part in (run.params, run.input):
        if part is None:
            continue
        for name in part.sources:
            value = getattr(part.values, name)
            if name in paths and isinstance(value, str) and value and os.path.isfile(value):
                out.append(Path(value))
    return out


def without_own_outputs(task: Task, sources: list[Path], run: ResolvedRun,
                        gathered: set[Path]) -> tuple[list[Path], str | None]:
    """``sources`` but the files found in a folder or by a pattern (``gathered``) that this run
    writes from its other inputs and that aldpat's job log beside them lists as an output it
    wrote, and one line naming those left out (None: none is).

    Outputs written beside their inputs -- the default -- are in the folder the next run is given:
    ``filter pm tiles/`` run again took ``a_pm.laz`` for an input whose output ``a_pm.laz`` (from
    ``a.laz``) would replace it, and refused the run, ``--overwrite`` or not; a worksheet's job so
    laid out could not be run again or resumed. A file named on its own, or one no job log says
    aldpat wrote (the user's ``a.laz`` beside ``a.txt`` for ``convert --out-format laz``), is still
    refused so."""
    if not gathered:
        return sources, None
    found = {real(p) for p in gathered}
    planned = plan_outputs(task, sources, run)
    writes = {real(out.path): out for out in planned if not out.family}
    first_of: dict[str | None, Planned] = {}
    for out in planned:
        first_of.setdefault(None if out.source is None else real(out.source), out)
    kept, left = [], []
    for source in sources:
        key = real(source)
        writer = writes.get(key)
        if (writer is not None and key in found and (writer.source is None or real(writer.source) != key)
                and _logged_as_output(first_of[None if writer.source is None else real(writer.source)].path, source)):
            left.append(source)
        else:
            kept.append(source)
    if not left:
        return sources, None
    named = ", ".join(p.name for p in left[:5]) + (f" and {len(left) - 5} more" if len(left) > 5 else "")
    return kept, (f"not taken as input{'s' if len(left) > 1 else ''}: {named}, which this run writes from "
                  "its other inputs")


#: the most of a job log read to find an output in it
_LOG_BYTES = 4 << 20


def _logged_as_output(first: Path, path: Path) -> bool:
    """Whether aldpat's job log of a job whose first output is ``first`` (``<stem>.log`` beside
    it, :mod:`aldpat.jobs.joblog`) lists ``path`` among its outputs: a file of the user's that
    only bears an output's name (``a.laz`` beside ``a.txt`` for ``convert --out-format laz``)
    stays an input, which the run refuses to replace."""
    log_file = first.with_name(first.stem + ".log")
    try:
        with open(log_file, "rb") as fh:
            text = fh.read(_LOG_BYTES)
    except OSError:
        return False
    if not JOB_LOG_MARK.match(text):
        return False
    in_outputs = False
    for line in text.decode("utf-8", "replace").splitlines():
        if not line.startswith("  "):
            in_outputs = line == "outputs:"
        elif in_outputs and Path(re.sub(r"  \(\d+ points\)$", "", line.strip())).name == path.name:
            return True
    return False


def existing_outputs_refused(planned: Iterable[Planned], run: ResolvedRun) -> list[str]:
    """What a run refuses when it comes to write ``planned`` -- each output that exists, without
    ``--overwrite`` -- said as the run says it, without writing or creating anything: for
    ``--dry-run``, which said "writes a_pm.laz" of a file the run then refused."""
    if any(getattr(part.values, "overwrite", False) for part in (run.params, run.output) if part is not None):
        return []
    return [f"{out.path}: output exists (use --overwrite to replace it)" for out in planned
            if not out.family and os.path.lexists(out.path)]


def check_outputs(task: Task, sources: list[Path], run: ResolvedRun) -> list[Planned]:
    """Refuse (:class:`UsageError`, naming both files) an output that would replace an input or
    another output of the same run, or an output folder that is a file; return the plan."""
    odir = getattr(run.output.values, "odir", None) if run.output is not None else None
    if odir and os.path.lexists(odir) and not os.path.isdir(odir):
        raise UsageError(f"--odir {odir} is a file, not a folder: give a folder (made if missing)")
    planned = plan_outputs(task, sources, run)
    reads = Reads()
    for s in [*sources, *path_parameter_files(run, planned)]:
        reads.add(s)
    check_planned(planned, reads)
    return planned


def check_planned(planned: list[Planned], reads: Reads, *, where: str = "") -> None:
    """The checks of :func:`check_outputs` on a plan, against the files ``reads``."""
    mine: dict[str, Planned] = {}
    folded: dict[str, str] = {}  # casefolded path -> the path of the first output so named
    for out in planned:
        victim = reads.replaced_by(out)
        if victim is not None:
            made = f" (made from {out.source})" if out.source is not None and Path(out.source) != victim else ""
            raise UsageError(f"{where}output {out.path}{made} would replace the input {victim}; {out.rename}")
        if out.family:
            continue
        kind = not_replaceable(out.path)
        if kind is not None:
            raise UsageError(f"{where}output {out.path} is {kind}, not a file: no output replaces one")
        key = real(out.path)
        twin = case_twin(key, folded)
        other = mine.get(key if twin is None else twin)
        if other is not None and not (other.source is None and out.source is None):
            told = "" if twin is None else f" (and {other.path}: names apart in case only are one file there)"
            raise UsageError(f"{where}{_from(other)} and {_from(out)} would both write {out.path}{told}; "
                             f"{out.rename} so that each has its own name")
        mine[key] = out
        folded.setdefault(key.casefold(), key)


def case_twin(key: str, folded: dict[str, str]) -> str | None:
    """The path in ``folded`` (casefolded path -> path) naming the file ``key`` names, another
    spelling of it in case, where its folder's file system folds case (:func:`folds_case`:
    ``A_pm.txt`` and ``a_pm.txt`` from ``d1/A.txt`` and ``d2/a.txt`` on macOS or Windows are
    one file, the second would replace the first); else None. Only a name that matches another
    but for case is probed."""
    other = folded.get(key.casefold())
    if other is None or other == key:
        return None
    return other if folds_case(os.path.dirname(key)) else None


def _from(out: Planned) -> str:
    return str(out.source) if out.source is not None else "the run"
