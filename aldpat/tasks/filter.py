"""``aldpat filter ALGO``: separate ground from non-ground points (ALDPAT 1.0 user manual (2007), task 8).

One task per registered filter (:data:`aldpat.filters.FILTERS`): its parameters are the
filter's own, with ``result`` and ``marks``
(:class:`~aldpat.filters.options.FilterOutputOption`) shared by every filter, so ``aldpat filter gapm --help``, the worksheet keys and the
``--params`` file all come from the filter's declaration.

Outputs (manual "Result Mode"): ``<stem>_<algo>`` holds the terrain points, ``<stem>_<algo>_nt``
the non-terrain points; ``classified`` -- the default for a LAS/LAZ output, as lasground, PDAL's
smrf and lidR's classify_ground give it -- writes every point once, in input order, with every
attribute, ground as LAS class 2 and the other classes as :func:`aldpat.filters.survey.survey_classes`
says (or a last text column ``class`` holding 2 / 1). The points a survey file sets aside --
withheld, or of a class in ``ignore_classes`` (7 and 18, noise) -- and the returns ``returns``
leaves out take no part in finding ground and keep their class (:mod:`aldpat.filters.survey`). ``--marks`` adds the mark matrix
value of every point (dissertation Table 5-1: 0 ground, else the window that removed it) as a
``mark`` column / LAS extra byte. LAS inputs keep every attribute. ``--data-mode center``
writes ALDPAT's one point per cell: the cell's lowest point moved to the cell centre.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import logging
from collections.abc import Callable
from pathlib import Path

import numpy as np

from aldpat.core import units
from aldpat.core.compiled import load_compiler_in_background
from aldpat.core.crs import output_crs, say_cell_in_degrees
from aldpat.errors import AldpatError, DataError, ParamError
from aldpat.filters import FILTERS, FilterResult, ground_filter
from aldpat.filters.marks import MARK_LOW_OUTLIER
from aldpat.filters.streamed import streamable
from aldpat.filters.survey import TAKING_PART_FIELDS, ground_flags, survey_classes, taking_part
from aldpat.io.atomic import check_writable
from aldpat.io.classified import GROUND, HIGH_NOISE, LOW_NOISE, UNCLASSIFIED, classes_of_table, for_point_format
from aldpat.io.las import BUFFER_DIMENSION, new_point_format
from aldpat.io.prefetch import WriteBehind, read_ahead
from aldpat.io.table import PointTable
from aldpat.io.tile_project import find_tile_job
from aldpat.jobs.context import JobContext
from aldpat.jobs.registry import register_task
from aldpat.jobs.task import Planned, Task
from aldpat.params import spec_map

log = logging.getLogger(__name__)

#: Points per chunk of a file filtered in two streaming passes: small enough that a chunk's
#: scratch arrays stay a fraction of the grid's memory.
STREAM_CHUNK = 200_000
#: Mark of a point that took no part in finding ground (withheld, an ignored class or return).
MARK_SET_ASIDE = -8000


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
    return cls if noise is None else with_noise(cls, noise(res, z, params))


def with_noise(cls: np.ndarray, kind: np.ndarray) -> np.ndarray:
    """``cls`` (in place) with the noise a filter found: ``kind`` -1 low noise (7), +1 high (18)."""
    cls[kind < 0] = LOW_NOISE
    cls[kind > 0] = HIGH_NOISE
    return cls


def check_filter_run(params, *, algorithm: str) -> None:
    """The rules of ``aldpat filter ALGO`` that relate its options to the filter's declaration
    (:class:`~aldpat.filters.registry.FilterSpec`), which its params class cannot see: checked
    when a run's parameters are resolved (``Task.check``), so that ``--dry-run`` and ``aldpat run
    --dry-run`` refuse, with the same message, what the run would refuse before reading a point.

    ``--chunk`` filters each chunk with its buffer on its own: not with ``--data-mode center``
    (one point per cell of the whole file) nor with parameters derived from every point at once;
    and its chunks must be ones the options can make (:func:`aldpat.filters.chunked.chunk_plan`).
    """
    from aldpat.filters.chunked import chunk_plan

    if params.chunk is None:
        return
    if params.data_mode == "center":
        raise ParamError("chunk: --data-mode center writes one point per cell of the whole file; run it whole "
                         "(without --chunk)")
    FILTERS[algorithm].check_chunks(params)
    chunk_plan(algorithm, params)


def classify_points(table: PointTable, algorithm: str, params, note: Callable[[str], None] | None = None
                    ) -> tuple[FilterResult, np.ndarray]:
    """The filter's result on the points of ``table`` held in memory, and every point's ASPRS
    class (:func:`point_classes`): what ``aldpat filter`` writes for a file read whole, and what
    :func:`aldpat.ground` returns. The filter runs on the points taking part
    (:func:`~aldpat.filters.survey.taking_part`); the others are unclassified here. Params the
    filter derives from every point (gapm's ``--auto``) are told to ``note``."""
    part = taking_part(table, params)  # withheld points and ignored classes take no part
    taken = table if part is None else table.take(part)
    res = ground_filter(taken.x, taken.y, taken.z, algorithm, params, note=note)
    return res, _every_point(point_classes(res, taken.z, res.params, algorithm), part, UNCLASSIFIED)


def _output_point_format(reader, ctx: JobContext, source: Path) -> int | None:
    """The LAS point format the classified output gets (None for text)."""
    path = ctx.output_path(source, "", reader=reader)
    if path.suffix.lower() not in (".las", ".laz"):
        return None
    if reader.format == "las":
        return int(reader.header.point_format.id)
    return new_point_format(reader.names)


def with_result(params, source: Path, ctx: JobContext, reader):
    """``params`` with ``result`` decided: when not given, ``classified`` for a LAS/LAZ output
    (every point back, ground as class 2, as LAS users expect) and ``terrain`` for text, as ALDPAT."""
    if params.result is not None:
        return params
    las = ctx.output_path(source, "", reader=reader).suffix.lower() in (".las", ".laz")
    return dataclasses.replace(params, result="classified" if las else "terrain")


def _output_names(reader, params, warn: Callable[[str], None]) -> tuple[str, ...]:
    """The columns of the outputs: the input's, then ``mark`` and the class where asked. An
    input's own ``mark`` (a vendor's extra bytes, an earlier ``--marks``) is replaced by the
    filter's, and said: it was replaced without a word."""
    names = tuple(reader.names)
    dims = set(reader.header.point_format.dimension_names) if reader.format == "las" else set()
    if params.marks and "mark" in dims:
        kind = reader.header.point_format.dimension_by_name("mark").dtype
        if not (kind.kind == "f" or np.can_cast(np.int32, kind)):  # -9000 and windows of 100,000 cells
            raise DataError(f"its own dimension mark ({kind}) cannot hold the filter's marks (--marks writes "
                            "int32): leave out --marks, or remove that dimension", path=reader.path)
        warn(f"{reader.path}: its own dimension mark is replaced by the filter's marks (--marks)")
    if params.marks and "mark" not in names:
        names += ("mark",)
    if params.result == "classified" and not ("classification" in names or "class" in names):
        names += ("classification",) if reader.format == "las" else ("class",)
    return names


def _with_classes(rows: PointTable, reader, params, marks: np.ndarray, cls: np.ndarray) -> PointTable:
    """``rows`` with the filter's marks (``--marks``) and its classes (:func:`classes_written`):
    in a classified output, and in every output whose points carry a class (a LAS's, a text
    column ``classification`` or ``class``), so that a terrain output's points are class 2 and a
    non-terrain output's hold no class 2 -- the classified output's points split in two. A LAS
    terrain output that kept the input's classes (1, 64...) read as no ground at all to
    ``evaluate`` and to every tool that takes class 2 for ground."""
    extra: dict[str, np.ndarray] = {}
    if params.marks:
        extra["mark"] = marks.astype(np.int32)
    carried = next((n for n in ("classification", "class") if n in rows.columns), None)
    if params.result == "classified" or carried is not None or reader.format == "las":
        extra[carried or ("classification" if reader.format == "las" else "class")] = cls
    return rows.with_columns(**extra) if extra else rows


def filter_outputs(source: Path, params, ctx: JobContext, *, algorithm: str) -> list[Planned]:
    """Every output, its role the points it holds: ``all``, ``ground`` or ``object``."""
    terrain_path = ctx.output_path(source, f"_{algorithm}")
    nonterrain_path = terrain_path.with_name(terrain_path.stem + "_nt" + terrain_path.suffix)
    result = params.result  # not given: decided by the output's format, as with_result does
    if result is None:
        result = "classified" if terrain_path.suffix.lower() in (".las", ".laz") else "terrain"
    if result == "classified":
        return [Planned(terrain_path, source, "all")]
    outputs = []
    if result in ("terrain", "both"):
        outputs.append(Planned(terrain_path, source, "ground"))
    if result in ("nonterrain", "both"):
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
    load_compiler_in_background()  # while the points are read: every filter runs compiled loops
    reader = ctx.open_input(source)
    cell = getattr(params, "cell", None)  # a filter without a cell of its own has none to misread
    if cell is not None:
        say_cell_in_degrees(params.crs, reader.crs, cell, source.name, ctx.warn)
    params = with_result(params, source, ctx, reader)
    if (reader.format == "las" and params.data_mode == "real" and streamable(algorithm, params)
            and filter_streamed(source, reader, params, ctx, algorithm=algorithm)):
        return
    table = reader.read()
    res, found = classify_points(table, algorithm, params, ctx.note)
    part = taking_part(table, params)
    marks = _every_point(res.point_marks, part, MARK_SET_ASIDE)
    if params.data_mode == "center":
        c = res.center()
        rows_of = c.index if part is None else np.flatnonzero(part)[c.index]
        rows = table.take(rows_of).with_columns(x=c.x, y=c.y, z=c.z)
        found, marks, part = found[rows_of], marks[rows_of], None
    else:
        rows = table
    cls = classes_written(found, rows, part, params, algorithm, _output_point_format(reader, ctx, source))
    ground = ground_flags(found, part)
    rows = _with_classes(rows, reader, params, marks, cls)
    names = _output_names(reader, params, ctx.warn)
    n_ground = int(ground.sum())
    if n_ground == 0:
        ctx.warn(f"{source}: no point was classified as ground")
    _note_set_aside(ctx, params, len(table) - (len(table) if part is None else int(part.sum())), len(table))
    units.stage("write", len(rows))
    for path, which in _outputs(source, params, ctx, reader, algorithm):
        with ctx.write_points(path, names, like=reader, crs=output_crs(params.crs, reader.crs, path, ctx.warn)) as writer:
            writer.write(_part(rows, which, ground))
        ctx.wrote(path, writer.count)
    units.advance(len(rows))
    _tally(ctx, algorithm, len(table), int(res.is_ground.sum()), _noise_found(found))
    log.info("%s: %d of %d points ground (%s)", source, n_ground, len(ground), algorithm)


def _noise_found(found: np.ndarray) -> int:
    return int(np.count_nonzero((found == LOW_NOISE) | (found == HIGH_NOISE)))


def _tally(ctx: JobContext, algorithm: str, points: int, ground: int, noise: int) -> None:
    """The job's counts for its summary: the ground points of a ground filter; of a filter that
    finds noise (``outlier``), whose other points are not ground, the noise points."""
    if FILTERS[algorithm].noise is None:
        ctx.tally(points=points, ground=ground)
    else:
        ctx.tally(points=points, noise=noise)


def _every_point(values: np.ndarray, part: np.ndarray | None, fill) -> np.ndarray:
    """``values`` of the points that took part, spread over every point (``fill`` for the others)."""
    if part is None:
        return np.asarray(values)
    out = np.full(len(part), fill, dtype=np.asarray(values).dtype)
    out[part] = values
    return out


def classes_written(found: np.ndarray, table: PointTable, part: np.ndarray | None, params, algorithm: str,
                    point_format: int | None) -> np.ndarray:
    """The class of every point of ``table`` in classified output: what the filter found
    (``found``, as the output's point format holds it) where it decides, the input's own class
    elsewhere (:func:`aldpat.filters.survey.survey_classes`)."""
    return survey_classes(for_point_format(found, point_format), classes_of_table(table), part,
                          noise_only=FILTERS[algorithm].noise is not None)


def _note_set_aside(ctx: JobContext, params, set_aside: int, n: int) -> None:
    if set_aside:
        ignored = ",".join(map(str, params.ignore_classes or ())) or "none"
        ctx.note(f"{set_aside} of {n} points took no part in finding ground and kept their class "
                 f"(withheld, classes {ignored}, returns {params.returns})")


def filter_streamed(source: Path, reader, params, ctx: JobContext, *, algorithm: str) -> bool:
    """A LAS/LAZ file in two streaming passes (:mod:`aldpat.filters.streamed`): the grid from the
    first, the classes and outputs from the second; memory holds the grid, not the points.
    False (nothing written) when the file cannot go this way -- a point outside the header's
    bounds, a z scale that is not positive: the caller then reads the file whole."""
    from aldpat.filters.streamed import ChunkNoise, Unstreamable, grid_bounds, stream_classes
    from aldpat.io.las import z_codes

    outputs = _outputs(source, params, ctx, reader, algorithm)
    for path, _ in outputs:  # refuse an existing output before the long part
        check_writable(path, overwrite=ctx.overwrite)

    def coded_chunks():
        # the grid's pass reads x, y, z and what says whether a point takes part (a LAZ of point
        # formats 6-10 decodes no other layer), the next chunk read while this one is gridded
        chunks = reader.chunks(STREAM_CHUNK, only=TAKING_PART_FIELDS, ahead=True)
        for table in units.counted(chunks, "read + grid", reader.count):
            part = taking_part(table, params)  # the points set aside are no cell's lowest
            if part is None:
                yield table.x, table.y, z_codes(table)
            else:
                yield table.x[part], table.y[part], z_codes(table)[part]

    heights = reader.height_codes()
    if heights is None:
        log.info("%s: z scale not positive; reading the file whole", source)
        return False
    try:
        classes = stream_classes(coded_chunks, grid_bounds(reader, params, STREAM_CHUNK), heights, algorithm, params)
    except Unstreamable as exc:
        log.info("%s: %s; reading the file whole", source, exc)
        return False

    spec = FILTERS[algorithm]
    noise = ChunkNoise(classes, spec.noise, params) if spec.noise is not None else None

    def classes_of(table, _start, _stop):
        if noise is None:
            marks, ground = classes.classify(table.x, table.y, table.z, marks=params.marks)
            return marks, ground_classes(ground, marks)
        marks, ground, kind = noise.classify(table.x, table.y, table.z, marks=params.marks)
        return marks, with_noise(ground_classes(ground, marks), kind)

    _write_from_classes(source, reader, outputs, params, ctx, classes_of, algorithm, STREAM_CHUNK)
    return True


def filter_chunked(source: Path, params, ctx: JobContext, *, algorithm: str) -> None:
    """``--chunk``: the input (with ``--catalog``, every input of the run, as one) spilled into
    chunks with buffers, each filtered on its own (in ``-j`` processes when this is the run's one
    job), and each input's outputs written in its order with every attribute, as a whole-file run
    writes them (:mod:`aldpat.filters.chunked`)."""
    from aldpat.core.units import on_dask_worker
    from aldpat.filters.chunked import chunk_plan, filter_chunks
    from aldpat.io.chunks import check_spill, scratch_folder

    # --data-mode center and filters needing every point were refused with the parameters (check_filter_run)
    sources = [source, *ctx.neighbours]  # the catalog's other inputs (--catalog), else none
    readers = [ctx.open_input(s) for s in sources]
    if ctx.neighbours:
        _warn_buffered_tiles(readers, ctx)
    params = with_result(params, source, ctx, readers[0])
    plan = chunk_plan(algorithm, params)
    outputs = [_outputs(s, params, ctx, r, algorithm) for s, r in zip(sources, readers, strict=False)]
    check_spill(plan.lattice, readers, Path(params.tmpdir) if params.tmpdir else outputs[0][0][0].parent, source)
    for path, _ in (o for outs in outputs for o in outs):  # refuse an existing output before the long part
        check_writable(path, overwrite=ctx.overwrite)
    counts: list[int] = []

    def every_table():  # the points taking part, input after input
        for reader in readers:
            counts.append(0)
            # the spill keeps x, y, z alone: of a LAS/LAZ (a LAZ of point formats 6-10 decodes no
            # other layer) only what says whether a point takes part besides, the next chunk read
            # while this one spills
            tables = reader.chunks(only=TAKING_PART_FIELDS, ahead=True) if reader.format == "las" else reader.chunks()
            for table in tables:
                part = taking_part(table, params)
                taken = table if part is None else table.take(part)
                counts[-1] += len(taken)
                yield taken

    classes_of = functools.partial(point_classes, algorithm=algorithm)
    with scratch_folder(params.tmpdir, outputs[0][0][0].parent) as scratch:
        done = filter_chunks(every_table(), algorithm, params, plan, scratch, classes_of=classes_of,
                             workers=ctx.workers)
        where = "the Dask cluster" if on_dask_worker() else f"{ctx.workers} process(es)"
        ctx.note(f"--chunk: {done.chunks} chunks of {plan.lattice.size:g} m ({plan.cells} cells) with "
                 f"{plan.lattice.buffer:g} m buffers over {len(sources)} input(s), {done.points} points "
                 f"({done.filtered} filtered with the buffers' copies), on {where}; the chunks' own "
                 f"filtering {done.seconds:.1f} s")
        offset = 0
        for src, reader, outs, count in zip(sources, readers, outputs, counts, strict=False):
            _write_from_classes(src, reader, outs, params, ctx, StoredClasses(done.marks, done.classes, offset, params),
                                algorithm)
            offset += count
        del done  # the memory maps close before their folder goes


class StoredClasses:
    """The marks and classes of an input's rows, table after table, from arrays of the whole run
    that hold the points taking part (from the run's row ``offset`` on)."""

    def __init__(self, marks: np.ndarray, classes: np.ndarray, offset: int, params):
        self.marks, self.classes, self.at, self.params = marks, classes, offset, params

    def __call__(self, table: PointTable, _start: int, _stop: int) -> tuple[np.ndarray, np.ndarray]:
        part = taking_part(table, self.params)
        k = len(table) if part is None else int(part.sum())
        marks = np.asarray(self.marks[self.at:self.at + k])
        classes = np.asarray(self.classes[self.at:self.at + k])
        self.at += k
        return _every_point(marks, part, MARK_SET_ASIDE), _every_point(classes, part, UNCLASSIFIED)


def _write_from_classes(source: Path, reader, outputs: list[tuple[Path, str]], params, ctx: JobContext,
                        classes_of, algorithm: str, chunk: int | None = None) -> None:
    """One input's outputs, streamed from the input again; ``classes_of(table, start, stop)``
    gives the marks and the classes the filter found of its rows ``start:stop`` (the table)."""
    names = _output_names(reader, params, ctx.warn)
    point_format = _output_point_format(reader, ctx, source)
    n_ground = n_noise = n = set_aside = 0
    with contextlib.ExitStack() as stack:
        writers = [(stack.enter_context(ctx.write_points(path, names, like=reader,
                                                         crs=output_crs(params.crs, reader.crs, path, ctx.warn))), path, which)
                   for path, which in outputs]
        tables = reader.chunks() if chunk is None else reader.chunks(chunk)
        # a LAS/LAZ input's next chunk is read, and its last one written, beside the classifying of
        # this one; a text input's chunks may widen the decimals the writers share, so they are read,
        # classified and written in turn (the same file whatever the timing)
        overlap = reader.format == "las"
        behind = stack.enter_context(WriteBehind()) if overlap else None
        start = 0
        for table in units.counted(read_ahead(tables) if overlap else tables, "classify + write", reader.count):
            stop = start + len(table)
            marks, found = classes_of(table, start, stop)
            part = taking_part(table, params)
            if part is not None:
                marks = np.where(part, marks, MARK_SET_ASIDE)
                set_aside += len(table) - int(part.sum())
            cls = classes_written(found, table, part, params, algorithm, point_format)
            ground = ground_flags(found, part)
            n_ground += int(ground.sum())
            n_noise += _noise_found(found)
            n += len(table)
            rows = _with_classes(table, reader, params, marks, cls)
            if behind is None:
                _write_rows(writers, rows, ground)
            else:
                behind.submit(_write_rows, writers, rows, ground)
            start = stop
    for writer, path, _ in writers:
        ctx.wrote(path, writer.count)
    _tally(ctx, algorithm, n, n_ground, n_noise)
    _note_set_aside(ctx, params, set_aside, n)
    if n_ground == 0:
        ctx.warn(f"{source}: no point was classified as ground")
    log.info("%s: %d of %d points ground (in chunks)", source, n_ground, n)


def _write_rows(writers: list, rows: PointTable, ground: np.ndarray) -> None:
    """A chunk's rows into each output: every row, or its ground or its object rows."""
    for writer, _, which in writers:
        writer.write(_part(rows, which, ground))


def _warn_buffered_tiles(readers: list, ctx: JobContext) -> None:
    """``--catalog`` over tiles holding buffer points (``aldpat tile --buffer``, marked
    ``tile_buffer``): the catalog takes every input as one, so each buffer point is there twice,
    once as the copy and once as the point its own tile holds -- two points where the survey has
    one, for a filter's density, distances and triangles. Said once for the run, of the tiles
    whose row in ``tile_parameter.txt`` has a buffer (tiles made with ``--buffer 0`` carry the
    mark on none of their points)."""
    def buffered(reader) -> bool:
        if reader.format != "las" or BUFFER_DIMENSION not in reader.header.point_format.dimension_names:
            return False
        try:
            tile = find_tile_job(reader.path, None)
        except AldpatError:  # a tile parameter file of its own faults: the warning is no place for them
            return False
        return tile is not None and tile.row.buffer > 0

    marked = [r.path.name for r in readers if buffered(r)]
    if marked:
        more = f" and {len(marked) - 3} more" if len(marked) > 3 else ""
        ctx.warn(f"{', '.join(marked[:3])}{more}: tiles with buffer points ({BUFFER_DIMENSION}), which --catalog "
                 "takes as points beside the ones they copy; give it the tiles without buffers (aldpat tile "
                 "--buffer 0) or filter the tiles without --catalog")


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
                           check=functools.partial(check_filter_run, algorithm=name),
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
