"""``aldpat evaluate``: Type I / II / total error and kappa of a ground classification.

The result is either a terrain output (every point in it is called ground; every reference point
missing from it, object) or a classified output (LAS class 2, or a text ``class`` column: 2 or 0
ground, anything else object). Reference labels come from ISPRS text ``x y z label``
(0 = bare earth, 1 = object) or LAS class 2 = ground. Points are matched by coordinates snapped
to ``tolerance``; duplicates count as many times as they occur (see
:func:`aldpat.core.accuracy.match_accuracy`).

``--map FILE.png`` draws the calls over the reference points, north up
(:func:`aldpat.tasks.preview.calls_rgba`): bare earth rejected (Type I) red, objects accepted
(Type II) blue, right calls green (ground) and grey (object). With several results, ``{stem}`` in
the name stands for each result's name.
"""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aldpat.core.accuracy import coordinate_keys, match_accuracy, reference_calls
from aldpat.errors import DataError, InputFormatError, InputMissingError, UsageError
from aldpat.io.classified import class_column_of
from aldpat.io.registry import open_points
from aldpat.io.worldfile import world_path
from aldpat.jobs.context import JobContext, Record
from aldpat.jobs.registry import register_task
from aldpat.jobs.task import Planned, Task
from aldpat.options import JsonOption, OverwriteOption
from aldpat.params import param
from aldpat.tasks.preview import calls_place, calls_rgba, save_png


@dataclass(frozen=True)
class EvaluateParams(JsonOption, OverwriteOption):
    reference: str | None = param(None, "reference points with labels (ISPRS text x y z label, or LAS class 2 = ground)",
                                  path=True, metavar="REF", required=True)
    mode: str = param("auto", "how the result marks ground: terrain (every point is ground), classified "
                      "(LAS class 2, or a text class column: 2 or 0 ground), auto (LAS: classified; text: "
                      "classified when a column after x y z holds only 1 and 2, else terrain)",
                      choices=("auto", "terrain", "classified"))
    class_column: int | None = param(None, "1-based column holding the class in a classified text result "
                                     "(default: found as --mode says)", ge=1, le=256, level="advanced")
    tolerance: float = param(0.001, "coordinates closer than this match", unit="m", gt=0, level="advanced")
    map: str | None = param(None, "also draw the calls over the reference as a PNG: bare earth rejected red, "
                            "objects accepted blue, right calls green / grey ({stem}: the result's name)",
                            path=True, metavar="FILE.png")


def _result_ground(reader, table, params: EvaluateParams) -> np.ndarray:
    if reader.format == "las":
        if params.mode == "terrain":
            return np.ones(len(table), dtype=bool)
        return table["classification"] == 2
    if params.class_column is not None:
        k = params.class_column - 1
        if k >= len(reader.names):
            raise UsageError(f"--class-column {k + 1}: the file has {len(reader.names)} columns", path=reader.path)
    elif params.mode == "terrain":
        return np.ones(len(table), dtype=bool)
    else:
        found = class_column_of(reader, table)
        if found is None:
            if params.mode == "classified":
                raise UsageError("no class column (values 1 and 2) found; give --class-column", path=reader.path)
            return np.ones(len(table), dtype=bool)  # auto: a terrain file
        k = found
    cls = table[reader.names[k]]
    return (cls == 2) | (cls == 0)


def reference_labels(path: Path, tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """Coordinate keys and ground flags of a reference file, read once for all results scored
    against it (the cache is keyed by the file's size and modification time too)."""
    st = os.stat(path)
    return _reference_labels(str(path), tolerance, st.st_size, st.st_mtime_ns)


@functools.lru_cache(maxsize=2)
def _reference_labels(path: str, tolerance: float, size: int, mtime_ns: int) -> tuple[np.ndarray, np.ndarray]:
    ref = open_points(path).read()
    if "classification" in ref:
        ground = ref["classification"] == 2
    elif "intensity" in ref:
        labels = ref["intensity"]
        if not np.isin(labels, (0, 1)).all():
            raise InputFormatError("reference labels must be 0 (bare earth) or 1 (object) in column 4", path=path)
        ground = labels == 0
    else:
        raise InputFormatError("reference has no label column (x y z label) or LAS classification", path=path)
    return coordinate_keys(ref.x, ref.y, ref.z, tolerance), ground


class AccuracyRecord(Record):
    """What ``aldpat evaluate`` reports of one result file."""

    def lines(self) -> list[str]:
        wrong = self["ground_as_object"] + self["object_as_ground"]
        out = [
            f"{self['path']}  vs  {self['reference']}",
            (f"  Type I   {self['type1']:7.2f} %   ({self['ground_as_object']} of "
            f"{self['ground_as_ground'] + self['ground_as_object']} bare-earth points rejected)"),
            (f"  Type II  {self['type2']:7.2f} %   ({self['object_as_ground']} of "
            f"{self['object_as_ground'] + self['object_as_object']} object points accepted)"),
            f"  total    {self['total']:7.2f} %   ({wrong} of {self['points']} points)",
            f"  kappa    {self['kappa']:7.4f}",
        ]
        if self.get("unmatched"):
            out.append(f"  ({self['unmatched']} result points matched no reference point)")
        if self.get("map"):
            out.append(f"  map      {self['map']}")
        return out


def evaluate_one(source: Path, params: EvaluateParams, ctx: JobContext) -> None:
    tol = params.tolerance
    assert params.reference is not None  # required
    ref_path = Path(params.reference)
    if not ref_path.exists():
        raise InputMissingError("no such file", path=ref_path)
    ref_keys, ref_ground = reference_labels(ref_path, tol)
    reader = ctx.open_input(source)
    table = reader.read()
    res_ground = _result_ground(reader, table, params)
    res_keys = coordinate_keys(table.x, table.y, table.z, tol)
    acc, unmatched = match_accuracy(ref_keys, ref_ground, res_keys, res_ground)
    if unmatched and unmatched == len(table):  # scores of nothing matched would read as a filter's
        raise DataError(f"none of its {unmatched:,} points matches a point of {ref_path.name} (within "
                        f"{tol:g} m): another sample's reference, or shifted coordinates?", path=source)
    if unmatched:
        ctx.warn(f"{source}: {unmatched} result points match no reference point (not counted)")
    record = AccuracyRecord({"path": str(source), "reference": str(ref_path)})
    record.update(acc.as_dict())
    record["unmatched"] = unmatched
    if params.map is not None:
        calls = reference_calls(ref_keys, ref_ground, res_keys, res_ground)
        ref_x, ref_y = ref_keys[:, 0] * tol, ref_keys[:, 1] * tol  # the reference's points, snapped
        out = ctx.outputs_for(source)[0].path
        out.parent.mkdir(parents=True, exist_ok=True)
        for path in save_png(calls_rgba(ref_x, ref_y, ref_ground, calls, MAP_SIZE), out, params.overwrite,
                             calls_place(ref_x, ref_y, MAP_SIZE)):
            ctx.wrote(path)
        record["map"] = str(out)
    ctx.emit(record)


#: longest side of an ``evaluate --map`` before enlarging (pixels): one pixel per point spacing
#: on every ISPRS sample (the largest is 560 m across at 1 m spacing)
MAP_SIZE = 2000


def map_path(template: str, source: Path) -> Path:
    return Path(template.replace("{stem}", Path(source).stem))


def evaluate_outputs(source: Path, params: EvaluateParams, ctx: JobContext) -> list[Planned]:
    """The map of ``--map`` (``{stem}`` the result's name) and its world file, if asked for."""
    if params.map is None:
        return []
    out = map_path(params.map, source)
    return [Planned(path, source, rename="put {stem} in --map (maps/{stem}.png)", named_by="map")
            for path in (out, world_path(out))]


register_task(Task(
    name="evaluate",
    summary="Type I, Type II, total error and kappa of a ground classification against reference labels.",
    params=EvaluateParams,
    run_one=evaluate_one,
    writes_outputs=False,
    examples=(
        ("aldpat evaluate samp24_gapm.txt --reference samp24.txt",
         "Type I / II / total error and kappa against ISPRS labels"),
        ("aldpat evaluate site_gapm.laz --reference site.laz --map calls.png",
         "against a reference LAS's class 2, with a map of the wrong calls"),
        ("aldpat evaluate ground/*.txt --reference samp24.txt --json",
         "one JSON object per result"),
    ),
    outputs=evaluate_outputs,
))
