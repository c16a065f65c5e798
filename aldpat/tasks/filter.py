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
from aldpat.io.classified import GROUND, LOW_NOISE, UNCLASSIFIED, high_noise_class
from aldpat.io.las import new_point_format
from aldpat.io.table import PointTable
from aldpat.jobs.context import JobContext
from aldpat.jobs.registry import Task, register_task

log = logging.getLogger(__name__)


def point_classes(res, z: np.ndarray, params, algorithm: str, las_point_format: int | None) -> np.ndarray:
    """ASPRS classes of every point: 2 ground, 1 unclassified, and for a filter that finds noise
    (``outlier``) 7 low noise and 18 high noise (7 in LAS point formats 0-5, which reserve 18)."""
    cls = np.where(res.is_ground, GROUND, UNCLASSIFIED).astype(np.uint8)
    noise = FILTERS[algorithm].noise
    if noise is not None:
        kind = noise(res, z, params)
        cls[kind < 0] = LOW_NOISE
        cls[kind > 0] = high_noise_class(las_point_format)
    return cls


def apply_auto(params, x: np.ndarray, y: np.ndarray, z: np.ndarray, ctx: JobContext):
    """``params`` with ``--auto``'s cell and windows derived from the points (gapm), recorded in
    the job's log; unchanged without ``auto``."""
    if not getattr(params, "auto", False):
        return params
    from aldpat.filters.gapm import with_auto

    params = with_auto(params, x, y, z)
    ctx.note(f"--auto: cell = {params.cell:g} m, window_series = {list(params.window_series)}, "
             f"row_windows = {list(params.row_windows or ())}, column_windows = "
             f"{list(params.column_windows or ())}")
    return params


def _output_table(table: PointTable, res, params) -> tuple[PointTable, np.ndarray | slice, np.ndarray, np.ndarray]:
    """Rows to write, the input rows they come from, their ground flags and marks (one per
    cell in ``center`` mode)."""
    if params.data_mode == "center":
        c = res.center()
        out = table.take(c.index).with_columns(x=c.x, y=c.y, z=c.z)
        return out, c.index, c.is_ground, c.marks
    return table, slice(None), res.is_ground, res.point_marks


def _output_point_format(reader, ctx: JobContext, source: Path) -> int | None:
    """The LAS point format the classified output gets (None for text)."""
    path = ctx.output_path(source, "", reader=reader)
    if path.suffix.lower() not in (".las", ".laz"):
        return None
    if reader.format == "las":
        return int(reader.header.point_format.id)
    return new_point_format(reader.names)


def filter_one(source: Path, params, ctx: JobContext, *, algorithm: str) -> None:
    reader = ctx.open_input(source)
    table = reader.read()
    params = apply_auto(params, table.x, table.y, table.z, ctx)
    res = ground_filter(table.x, table.y, table.z, algorithm, params)
    rows, origin_rows, ground, marks = _output_table(table, res, params)
    names = tuple(reader.names)
    extra: dict[str, np.ndarray] = {}
    if params.marks:
        extra["mark"] = marks.astype(np.int32)
        names += ("mark",)
    if params.result == "classified":
        point_format = _output_point_format(reader, ctx, source)
        cls = point_classes(res, table.z, params, algorithm, point_format)[origin_rows]
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
