"""Filtering a file chunk by chunk, each chunk with a buffer, in bounded memory and in parallel.

The input is spilled once into square chunks with buffers (:mod:`aldpat.io.chunks`); each chunk
is filtered with its buffer on its own -- in ``workers`` processes -- and only its own points'
classes are kept: the buffer gives the filter the surroundings a whole-file run would have seen,
then is dropped. The classes go into two files indexed by the points' rows in the input (marks as
int32, ASPRS classes as uint8: 5 bytes a point, on disk, not in memory), which the writer reads
back in input order.

Chunks lie on whole multiples of the cell from the filter's origin, so a chunk's cells are the
whole file's cells. With a buffer of twice the filter's reach (:attr:`FilterSpec.reach`: the
cells its marks depend on; twice, because an empty cell within that reach takes the height of
its nearest point, which lies within twice the reach), the filters whose marks depend only on
the cells within their windows -- ``etew``, ``pm``, ``pm2d``, ``pmcircle`` without rotation --
give exactly the whole file's classes, and so does ``slope`` with its buffer (its search radius
and two cells, :attr:`FilterSpec.buffer`). The others have steps that are not bounded (gapm's
raised segments and surface test, cluster-pm's recovery along a row, multipass's interpolation,
the spreading of ipf's, poly2's and atin's ground sets from window to window or round to round),
so their agreement with a whole-file run is measured (``bench/bench_chunks.py``), not promised.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aldpat.core.low_points import point_spacing
from aldpat.errors import ParamError
from aldpat.filters.classify import FilterResult
from aldpat.filters.driver import ground_filter
from aldpat.filters.grid_stage import low_outlier_reach
from aldpat.filters.options import GroundParams, PointFilterParams
from aldpat.filters.registry import get_filter
from aldpat.io.chunks import ChunkLattice, SpilledChunks, map_chunks, spill_chunks
from aldpat.io.table import PointTable

#: ``classes_of(result, z, params) -> uint8``: each point's ASPRS class from the filter's result.
ClassesOf = Callable[[FilterResult, np.ndarray, Any], np.ndarray]


@dataclass(frozen=True)
class ChunkPlan:
    lattice: ChunkLattice
    cells: int  # chunk side in cells
    buffer_cells: int


def chunk_plan(algorithm: str, params: GroundParams | PointFilterParams) -> ChunkPlan:
    """The chunks of ``params.chunk`` m (rounded to whole cells) with a buffer of
    ``params.chunk_buffer`` m (rounded up to whole cells), or with ``auto`` what the filter needs
    (its reach, or its own buffer). A :class:`ParamError` when the options cannot make chunks:
    ``auto`` for a filter that knows no buffer, or buffers that copy each point too many times
    (:meth:`ChunkLattice.check_copies`). The filter task checks this plan with its parameters
    (:func:`aldpat.tasks.filter.check_filter_run`), so a dry run refuses what the run would."""
    cell, origin = params.chunk_lattice()
    cells = params.chunk_cells(cell)
    spec = get_filter(algorithm)
    given = params.buffer_metres()
    if given is not None:
        buffer_cells = math.ceil(given / cell - 1e-9)
    elif spec.reach is not None:
        # empty cells are filled from their nearest point: for a cell within the reach of a point
        # that point lies within twice the reach, so twice the reach sees every value used
        buffer_cells = 2 * int(spec.reach(params)) + 1
    elif spec.buffer is not None:
        # and the low-outlier test's reach, doubled as the grid filters' (it fills empty cells)
        buffer_cells = math.ceil(spec.buffer(params) / cell - 1e-9) + 2 * low_outlier_reach(params)
    else:
        raise ParamError(f"chunk_buffer: {algorithm} has no bounded reach to size an auto buffer; give the buffer in metres")
    lattice = ChunkLattice(cells * cell, buffer_cells * cell, origin)
    try:
        lattice.check_copies()
    except ParamError as exc:
        if params.chunk is not None and not math.isclose(params.chunk, lattice.size):
            # the message names the rounded size, which the user never typed: say where it came from
            raise ParamError(f"{exc.message} (the --chunk {params.chunk:g} m given, rounded to whole cells of "
                             f"{cell:g} m)") from None
        raise
    return ChunkPlan(lattice, cells, buffer_cells)


def filter_chunks(tables: Iterable[PointTable], algorithm: str, params: GroundParams | PointFilterParams, plan: ChunkPlan, scratch: Path, *,
                  classes_of: ClassesOf, workers: int = 1) -> ChunkRun:
    """Filter the points of ``tables`` (one input, in row order) chunk by chunk.

    ``classes_of(result, z, params) -> uint8`` gives each point's ASPRS class. Returns the marks
    and classes of every row (memory-mapped files in ``scratch``) and what the run did.
    """
    # every chunk's grid on the file's lattice: a grid aligned to the data's own minimum would
    # shift with each chunk's extent
    params = params.on_lattice(plan.lattice.origin)
    with spill_chunks(tables, plan.lattice, tmpdir=scratch) as spilled:
        n = spilled.points
        marks = np.lib.format.open_memmap(scratch / "marks.npy", mode="w+", dtype=np.int32, shape=(max(n, 1),))
        classes = np.lib.format.open_memmap(scratch / "classes.npy", mode="w+", dtype=np.uint8, shape=(max(n, 1),))
        # the whole input's spacing: every chunk's low-outlier test takes the blocks a whole-file run takes
        spacing = point_spacing(spilled.points, spilled.bounds)
        jobs = [(spilled, col, row, algorithm, params, classes_of, spacing) for col, row in spilled.chunks]
        seconds = 0.0
        for rows, m, c, t in map_chunks(_filter_one_chunk, jobs, workers):
            marks[rows] = m
            classes[rows] = c
            seconds += t
        marks.flush()
        classes.flush()
        return ChunkRun(marks, classes, n, len(spilled.chunks), seconds, spilled.spilled)


@dataclass
class ChunkRun:
    marks: np.ndarray  # int32 per input row (memory-mapped)
    classes: np.ndarray  # uint8 per input row (memory-mapped)
    points: int
    chunks: int
    seconds: float  # the chunks' own filtering time, summed over them
    filtered: int  # points the chunks filtered: their own, and their buffers' copies


def _filter_one_chunk(spilled: SpilledChunks, col: int, row: int, algorithm: str, params: Any, classes_of: ClassesOf,
                      spacing: float | None) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The rows, marks and classes of the points of chunk (col, row), filtered with its buffer,
    and the seconds it took."""
    start = time.perf_counter()
    points = spilled.read(col, row)
    x, y, z = points["x"], points["y"], points["z"]
    own_col, own_row = spilled.lattice.index(x, y)
    own = (own_col == col) & (own_row == row)
    # the grid of the whole file's cells there, edges included: a grid on the chunk's own points
    # would end where they end, and an opening at a grid's edge sees other cells than inside it
    res = ground_filter(x, y, z, algorithm, params, extent=spilled.extent(col, row), spacing=spacing)
    cls = classes_of(res, z, params)
    return points["row"][own], res.point_marks[own], cls[own], time.perf_counter() - start
