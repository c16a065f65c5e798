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

import contextlib
import functools
import logging
from collections.abc import Callable
from pathlib import Path

import numpy as np

from aldpat.core import units
from aldpat.errors import UsageError
from aldpat.filters import FILTERS, FilterResult, ground_filter
from aldpat.filters.base import MARK_LOW_OUTLIER
from aldpat.filters.streamed import streamable
from aldpat.io.atomic import check_writable
from aldpat.io.classified import GROUND, HIGH_NOISE, LOW_NOISE, UNCLASSIFIED, for_point_format
from aldpat.io.las import new_point_format
from aldpat.io.table import PointTable
from aldpat.jobs.context import JobContext, Planned
from aldpat.jobs.registry import Task, register_task
from aldpat.params import spec_map

log = logging.getLogger(__name__)

#: Points per chunk of a file filtered in two streaming passes: small enough that a chunk's
#: scratch arrays stay a fraction of the grid's memory.
STREAM_CHUNK = 200_000


def ground_classes(is_ground: np.ndarray, marks: np.ndarray) -> np.ndarray:
    """ASPRS classes from ground flags and marks: 2 ground, 7 a low outlier, else 1."""
    cls = np.where(is_ground, GROUND, UNCLASSIFIED).astype(np.uint8)
    cls[marks == MARK_LOW_OUTLIER] = LOW_NOISE
    return cls


def point_classes(res, z: np.ndarray, params, algorithm: str) -> np.ndarray:
    """ASPRS classes of every point: 2 ground, 7 low outliers, 1 unclassified, and for a filter
    that finds noise (``outlier``) 7 low noise and 18 high noise (made 7 where written to LAS
    point formats 0-5, which reserve 18: :func:`aldpat.io.classified.for_point_format`)."""
    cls = ground_classes(res.is_ground, res.point_marks)
    noise = FILTERS[algorithm].noise
    if noise is not None:
        kind = noise(res, z, params)
        cls[kind < 0] = LOW_NOISE
        cls[kind > 0] = HIGH_NOISE
    return cls


def apply_auto(params, x: np.ndarray, y: np.ndarray, z: np.ndarray, note: Callable[[str], None] | None = None):
    """``params`` with ``--auto``'s cell and windows derived from the points (gapm), told to
    ``note`` (a job's log: ``ctx.note``; else this module's logger); unchanged without ``auto``."""
    if not getattr(params, "auto", False):
        return params
    from aldpat.filters.gapm import with_auto

    params = with_auto(params, x, y, z)
    (note or log.info)(f"--auto: cell = {params.cell:g} m, window_series = {list(params.window_series)}, "
                       f"row_windows = {list(params.row_windows or ())}, column_windows = "
                       f"{list(params.column_windows or ())}")
    return params


def classify_points(table: PointTable, algorithm: str, params, note: Callable[[str], None] | None = None
                    ) -> tuple[FilterResult, np.ndarray]:
    """The filter's result on the points of ``table`` held in memory, and every point's ASPRS
    class (:func:`point_classes`): what ``aldpat filter`` writes for a file read whole, and what
    :func:`aldpat.ground` returns."""
    params = apply_auto(params, table.x, table.y, table.z, note)
    res = ground_filter(table.x, table.y, table.z, algorithm, params)
    return res, point_classes(res, table.z, params, algorithm)


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


def _output_names(reader, params) -> tuple[str, ...]:
    """The columns of the outputs: the input's, then ``mark`` and the class where asked."""
    names = tuple(reader.names)
    if params.marks:
        names += ("mark",)
    if params.result == "classified" and not (reader.format == "las" and "classification" in names):
        names += ("classification",) if reader.format == "las" else ("class",)
    return names


def _with_classes(rows: PointTable, reader, params, marks: np.ndarray, cls: np.ndarray | None) -> PointTable:
    extra: dict[str, np.ndarray] = {}
    if params.marks:
        extra["mark"] = marks.astype(np.int32)
    if cls is not None:
        extra["classification" if reader.format == "las" else "class"] = cls
    return rows.with_columns(**extra) if extra else rows


def filter_outputs(source: Path, params, ctx: JobContext, *, algorithm: str) -> list[Planned]:
    """Every output, its role the points it holds: ``all``, ``ground`` or ``object``."""
    terrain_path = ctx.output_path(source, f"_{algorithm}")
    nonterrain_path = terrain_path.with_name(terrain_path.stem + "_nt" + terrain_path.suffix)
    if params.result == "classified":
        return [Planned(terrain_path, source, "all")]
    outputs = []
    if params.result in ("terrain", "both"):
        outputs.append(Planned(terrain_path, source, "ground"))
    if params.result in ("nonterrain", "both"):
        outputs.append(Planned(nonterrain_path, source, "object"))
    return outputs


def _outputs(source: Path, params, ctx: JobContext, reader, algorithm: str) -> list[tuple[Path, str]]:
    """(path, which points) of every output, as planned (:func:`filter_outputs`)."""
    return [(p.path, p.role) for p in ctx.outputs_for(source)]


def _part(rows: PointTable, which: str, ground: np.ndarray) -> PointTable:
    return rows if which == "all" else rows.take(ground if which == "ground" else ~ground)


def filter_one(source: Path, params, ctx: JobContext, *, algorithm: str) -> None:
    if params.chunk is not None:
        filter_chunked(source, params, ctx, algorithm=algorithm)
        return
    reader = ctx.open_input(source)
    if (reader.format == "las" and params.data_mode == "real" and streamable(algorithm, params)
            and filter_streamed(source, reader, params, ctx, algorithm=algorithm)):
        return
    table = reader.read()
    res, classes = classify_points(table, algorithm, params, ctx.note)
    rows, origin_rows, ground, marks = _output_table(table, res, params)
    cls = None
    if params.result == "classified":
        cls = for_point_format(classes[origin_rows], _output_point_format(reader, ctx, source))
    rows = _with_classes(rows, reader, params, marks, cls)
    names = _output_names(reader, params)
    n_ground = int(ground.sum())
    if n_ground == 0:
        ctx.warn(f"{source}: no point was classified as ground")
    units.stage("write", len(rows))
    for path, which in _outputs(source, params, ctx, reader, algorithm):
        with ctx.write_points(path, names, like=reader) as writer:
            writer.write(_part(rows, which, ground))
        ctx.wrote(path, writer.count)
    units.advance(len(rows))
    ctx.tally(points=len(table), ground=int(res.is_ground.sum()))
    log.info("%s: %d of %d points ground (%s)", source, n_ground, len(ground), algorithm)


def filter_streamed(source: Path, reader, params, ctx: JobContext, *, algorithm: str) -> bool:
    """A LAS/LAZ file in two streaming passes (:mod:`aldpat.filters.streamed`): the grid from the
    first, the classes and outputs from the second; memory holds the grid, not the points.
    False (nothing written) when the file cannot go this way -- a point outside the header's
    bounds, a z scale that is not positive: the caller then reads the file whole."""
    from aldpat.filters.streamed import Unstreamable, stream_classes
    from aldpat.io.las import z_codes

    outputs = _outputs(source, params, ctx, reader, algorithm)
    for path, _ in outputs:  # refuse an existing output before the long part
        check_writable(path, overwrite=ctx.overwrite)

    def coded_chunks():
        for table in units.counted(reader.chunks(STREAM_CHUNK), "read + grid", reader.count):
            yield table.x, table.y, z_codes(table)

    heights = reader.height_codes()
    if heights is None:
        log.info("%s: z scale not positive; reading the file whole", source)
        return False
    try:
        classes = stream_classes(coded_chunks, reader.bounds, heights, algorithm, params)
    except Unstreamable as exc:
        log.info("%s: %s; reading the file whole", source, exc)
        return False

    def classes_of(table, _start, _stop):
        marks, ground = classes.classify(table.x, table.y, table.z, marks=params.marks)
        return marks, ground_classes(ground, marks)

    _write_from_classes(source, reader, outputs, params, ctx, classes_of, STREAM_CHUNK)
    return True


def filter_chunked(source: Path, params, ctx: JobContext, *, algorithm: str) -> None:
    """``--chunk``: the input (with ``--catalog``, every input of the run, as one) spilled into
    chunks with buffers, each filtered on its own (in ``-j`` processes when this is the run's one
    job), and each input's outputs written in its order with every attribute, as a whole-file run
    writes them (:mod:`aldpat.filters.chunked`)."""
    from aldpat.core.units import on_dask_worker
    from aldpat.filters.chunked import chunk_plan, filter_chunks
    from aldpat.io.chunks import check_spill, scratch_folder

    if params.data_mode == "center":
        raise UsageError("--chunk: --data-mode center writes one point per cell of the whole file; run it whole")
    if getattr(params, "auto", False):
        raise UsageError("--chunk with --auto: --auto derives its windows from all the points; derive them once "
                         "(aldpat filter gapm --auto on the file writes them to its log) and pass them")
    sources = [source, *ctx.neighbours]  # the catalog's other inputs (--catalog), else none
    readers = [ctx.open_input(s) for s in sources]
    plan = chunk_plan(algorithm, params, params.chunk, params.chunk_buffer)
    outputs = [_outputs(s, params, ctx, r, algorithm) for s, r in zip(sources, readers)]
    check_spill(plan.lattice, readers, Path(params.tmpdir) if params.tmpdir else outputs[0][0][0].parent, source)
    for path, _ in (o for outs in outputs for o in outs):  # refuse an existing output before the long part
        check_writable(path, overwrite=ctx.overwrite)
    counts: list[int] = []

    def every_table():
        for reader in readers:
            counts.append(0)
            for table in reader.chunks():
                counts[-1] += len(table)
                yield table

    classes_of = functools.partial(point_classes, algorithm=algorithm)
    with scratch_folder(params.tmpdir, outputs[0][0][0].parent) as scratch:
        done = filter_chunks(every_table(), algorithm, params, plan, scratch, classes_of=classes_of,
                             workers=ctx.workers)
        where = "the Dask cluster" if on_dask_worker() else f"{ctx.workers} process(es)"
        ctx.note(f"--chunk: {done.chunks} chunks of {plan.lattice.size:g} m ({plan.cells} cells) with "
                 f"{plan.lattice.buffer:g} m buffers over {len(sources)} input(s), {done.points} points, on "
                 f"{where}; the chunks' own filtering {done.seconds:.1f} s")
        offset = 0
        for src, reader, outs, count in zip(sources, readers, outputs, counts):
            _write_from_classes(src, reader, outs, params, ctx, functools.partial(
                _stored_classes, done.marks, done.classes, offset))
            offset += count
        del done  # the memory maps close before their folder goes


def _stored_classes(marks: np.ndarray, classes: np.ndarray, offset: int, _table, start: int, stop: int
                    ) -> tuple[np.ndarray, np.ndarray]:
    """The marks and classes of input rows ``start:stop`` from arrays of the whole run (which
    begin at the run's row ``offset``)."""
    return np.asarray(marks[offset + start:offset + stop]), np.asarray(classes[offset + start:offset + stop])


def _write_from_classes(source: Path, reader, outputs: list[tuple[Path, str]], params, ctx: JobContext,
                        classes_of, chunk: int | None = None) -> None:
    """One input's outputs, streamed from the input again; ``classes_of(table, start, stop)``
    gives the marks and classes of its rows ``start:stop`` (the table)."""
    names = _output_names(reader, params)
    point_format = _output_point_format(reader, ctx, source)
    n_ground = n = 0
    with contextlib.ExitStack() as stack:
        writers = [(stack.enter_context(ctx.write_points(path, names, like=reader)), path, which)
                   for path, which in outputs]
        start = 0
        for table in units.counted(reader.chunks() if chunk is None else reader.chunks(chunk), "classify + write",
                                   reader.count):
            stop = start + len(table)
            marks, classes = classes_of(table, start, stop)
            cls = for_point_format(classes, point_format)
            ground = cls == GROUND
            n_ground += int(ground.sum())
            n += len(table)
            rows = _with_classes(table, reader, params, marks, cls if params.result == "classified" else None)
            for writer, _, which in writers:
                writer.write(_part(rows, which, ground))
            start = stop
    for writer, path, _ in writers:
        ctx.wrote(path, writer.count)
    ctx.tally(points=n, ground=n_ground)
    if n_ground == 0:
        ctx.warn(f"{source}: no point was classified as ground")
    log.info("%s: %d of %d points ground (in chunks)", source, n_ground, n)


def plan_catalog(sources: list[Path], params, _input) -> list[list[str]]:
    """``--catalog``: one job for all inputs (the chunks cross the files); else one per input."""
    if params.chunk is not None and params.catalog:
        return [[str(s) for s in sources]]
    return [[str(s)] for s in sources]


def _register_all() -> None:
    for name, spec in sorted(FILTERS.items()):
        def run(source, params, ctx, _name=name):
            filter_one(source, params, ctx, algorithm=_name)

        register_task(Task(name=name, group="filter", summary=spec.summary, params=spec.params,
                           run_one=run, plan=plan_catalog, examples=filter_examples(name, spec.params),
                           outputs=functools.partial(filter_outputs, algorithm=name)))


def filter_examples(name: str, params: type) -> tuple[tuple[str, str], ...]:
    """The examples opening ``aldpat filter NAME --help``: one file, a folder of tiles, and the
    parameters the filter derives from the data (``--auto``) or reads from a file."""
    if "auto" in spec_map(params):
        last = (f"aldpat filter {name} site.laz --auto", "the cell and windows derived from the data (the log says which)")
    else:
        last = (f"aldpat filter {name} site.laz --params {name}.toml",
                "the parameters from a TOML file (keys as the options, without --)")
    return (
        (f"aldpat filter {name} site.laz", "the ground of one file, written beside it"),
        (f"aldpat filter {name} tiles/ -j 0 --odir ground/", "every point file of a folder, on all cores"),
        last,
    )


_register_all()
