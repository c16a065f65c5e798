"""``aldpat filter ALGO``: separate ground from non-ground points (ALDPAT 1.0 user manual (2007), task 8).

One task per registered filter (:data:`aldpat.filters.FILTERS`): its parameters are the
filter's own, with ``result`` and ``marks``
(:class:`~aldpat.filters.base.FilterOutputOption`) shared by every filter, so ``aldpat filter gapm --help``, the worksheet keys and the
``--params`` file all come from the filter's declaration.

Outputs (manual "Result Mode"): ``<stem>_<algo>`` holds the terrain points, ``<stem>_<algo>_nt``
the non-terrain points; ``classified`` writes every point once, with LAS class 2 (ground) / 1
(unclassified) or a last text column ``class`` holding 2 / 1. ``--marks`` adds the mark matrix
value of every point (dissertation Table 5-1: 0 ground, else the window that removed it) as a
``mark`` column / LAS extra byte. LAS inputs keep every attribute. ``--data-mode center``
writes ALDPAT's one point per cell: the cell's lowest point moved to the cell centre.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from aldpat.filters import FILTERS, ground_filter
from aldpat.io.table import PointTable
from aldpat.jobs.context import JobContext
from aldpat.jobs.registry import Task, register_task

log = logging.getLogger(__name__)

#: LAS classification codes (ASPRS): 2 ground, 1 unclassified.
CLASS_GROUND = 2
CLASS_OTHER = 1

def _output_table(table: PointTable, res, params) -> tuple[PointTable, np.ndarray, np.ndarray]:
    """Rows to write, their ground flags and marks (one per cell in ``center`` mode)."""
    if params.data_mode == "center":
        c = res.center()
        out = table.take(c.index).with_columns(x=c.x, y=c.y, z=c.z)
        return out, c.is_ground, c.marks
    return table, res.is_ground, res.point_marks


def filter_one(source: Path, params, ctx: JobContext, *, algorithm: str) -> None:
    reader = ctx.open_input(source)
    table = reader.read()
    if getattr(params, "auto", False):
        from aldpat.filters.gapm import with_auto

        params = with_auto(params, table.x, table.y, table.z)
        ctx.note(f"--auto: cell = {params.cell:g} m, window_series = {list(params.window_series)}, "
                 f"row_windows = {list(params.row_windows or ())}, column_windows = "
                 f"{list(params.column_windows or ())}")
    res = ground_filter(table.x, table.y, table.z, algorithm, params)
    rows, ground, marks = _output_table(table, res, params)
    names = tuple(reader.names)
    extra: dict[str, np.ndarray] = {}
    if params.marks:
        extra["mark"] = marks.astype(np.int32)
        names += ("mark",)
    if params.result == "classified":
        cls = np.where(ground, CLASS_GROUND, CLASS_OTHER).astype(np.uint8)
        if reader.format == "las":
            extra["classification"] = cls
            if "classification" not in names:
                names += ("classification",)
        else:
            extra["class"] = cls
            names += ("class",)
    if extra:
        rows = rows.with_columns(**extra)

    terrain_path = ctx.output_path(source, f"_{algorithm}", reader=reader)
    nonterrain_path = terrain_path.with_name(terrain_path.stem + "_nt" + terrain_path.suffix)
    n_ground = int(ground.sum())
    if n_ground == 0:
        ctx.warn(f"{source}: no point was classified as ground")
    writes: list[tuple[Path, np.ndarray | slice]]
    if params.result == "classified":
        writes = [(terrain_path, slice(None))]
    else:
        writes = []
        if params.result in ("terrain", "both"):
            writes.append((terrain_path, ground))
        if params.result in ("nonterrain", "both"):
            writes.append((nonterrain_path, ~ground))
    for path, which in writes:
        part = rows if isinstance(which, slice) else rows.take(which)
        with ctx.write_points(path, names, like=reader) as writer:
            writer.write(part)
        ctx.wrote(path, writer.count)
    log.info("%s: %d of %d points ground (%s)", source, n_ground, len(ground), algorithm)


def _register_all() -> None:
    for name, spec in sorted(FILTERS.items()):
        def run(source, params, ctx, _name=name):
            filter_one(source, params, ctx, algorithm=_name)

        register_task(Task(name=name, group="filter", summary=spec.summary, params=spec.params,
                           run_one=run))


_register_all()
