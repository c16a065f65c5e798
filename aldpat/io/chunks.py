"""Cutting a point file into square chunks with buffers, in one streaming pass, so that each
chunk can be read back alone (as lidR's LAScatalog chunk size + chunk buffer, or ``pdal tile``).

Chunks lie on a lattice of ``size`` from ``origin``; a chunk's *buffered* extent is its square
grown by ``buffer`` on every side. The pass reads the input once, chunk of rows by chunk of rows,
and appends every point to the spill file of each chunk whose buffered extent holds it (its own
chunk, and its neighbours' when it lies in their buffer), as records of its row number in the
input and x, y, z. The spill files of one chunk therefore hold its points in input order. Peak
memory is one read chunk and at most :data:`SPILL_COPIES` copies being placed, however wide the
buffers are against the chunks; the spill files take 32 bytes a point (times the buffer's share) in a
temporary folder, removed by the caller's ``with``.

:func:`map_chunks` then runs the work of each chunk here, in worker processes, or on the Dask
cluster the job itself runs on.
"""

from __future__ import annotations

import contextlib
import math
import shutil
import tempfile
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aldpat.core import units
from aldpat.core.compiled import compiled
from aldpat.core.resources import check_disk, count_text
from aldpat.core.tiles import MOST_COPIES, copies_with_buffer, least_square_for, spanned
from aldpat.core.workers import WorkerPool, workers_to_start
from aldpat.errors import ParamError, UsageError
from aldpat.io.atomic import scratch_dir
from aldpat.io.registry import PointReader
from aldpat.io.table import PointTable

#: one spilled point: its row in the input, and its coordinates
RECORD = np.dtype([("row", "<i8"), ("x", "<f8"), ("y", "<f8"), ("z", "<f8")])


@dataclass(frozen=True)
class ChunkLattice:
    size: float
    buffer: float
    origin: tuple[float, float] = (0.0, 0.0)

    def index(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Column and row of the chunk each point belongs to."""
        ox, oy = self.origin
        return (np.floor((x - ox) / self.size).astype(np.int64), np.floor((y - oy) / self.size).astype(np.int64))

    @property
    def copies(self) -> float:
        """How many chunks hold each point, its own and those whose buffers reach it (on average)."""
        return copies_with_buffer(self.size, self.size, self.buffer)

    @property
    def most_copies_of_a_point(self) -> int:
        """How many chunks hold a point at the most: a chunk with its buffer spans the whole
        chunks of ``(size + 2 buffer) / size`` in x and in y, a point in one more where it falls."""
        return math.ceil(spanned(self.size, self.buffer)) ** 2

    def check_copies(self) -> None:
        """Refuse (:class:`ParamError`: the options ask for it) chunks whose buffers copy each
        point more than :data:`MOST_COPIES` times: a rule of the options alone, checked with them."""
        if not self.copies <= MOST_COPIES:
            least = least_square_for(self.buffer)
            raise ParamError(f"--chunk {self.size:g} m with a {self.buffer:g} m buffer copies every point "
                             f"into {self.copies:,.0f} chunks (at most {MOST_COPIES}); use a --chunk of at least "
                             f"{least:.4g} m or a smaller --chunk-buffer")


#: The most point copies one step of the spill gathers before writing them (32 bytes each: 128 MiB).
#: A read chunk is placed in slices of rows this bounds: with buffers far wider than the chunks
#: (``--chunk 60`` with a 245 m buffer: 84 copies of every point) the copies of a million-row read
#: chunk took 2.7 GB at once.
SPILL_COPIES = 4_000_000
#: The most chunks one input is cut into (a spill file each, a task each): a million chunks of
#: 100 m cover 10,000 km2; more are the sign of a chunk far too small for the data.
MOST_CHUNKS = 1_000_000
#: the bytes a text point line has at the least, as files are written (``x y z`` with decimals)
_TEXT_POINT_BYTES = 24


def expected_points(reader: PointReader) -> int:
    """The points of an input: its header's count, or from a text file's size."""
    if reader.count is not None:
        return int(reader.count)
    try:
        return Path(reader.path).stat().st_size // _TEXT_POINT_BYTES
    except OSError:
        return 0


def check_spill(lattice: ChunkLattice, readers: Iterable[PointReader], folder: Path, path: Path | None = None) -> None:
    """Refuse, before a byte is spilled, spill files larger than the free disk of ``folder``;
    ``path`` is the input named. (How many copies the buffers make the options decide, and
    :meth:`ChunkLattice.check_copies` refuses with them.)"""
    points = sum(expected_points(r) for r in readers)
    check_disk(points * lattice.copies * RECORD.itemsize, folder,
               f"spilling {count_text(points)} points into chunks with buffers ({lattice.copies:.1f} copies each)",
               "give --tmpdir on a disk with room, a larger --chunk or a smaller --chunk-buffer", path=path)


def too_many_chunks(lattice: ChunkLattice, count: int) -> UsageError:
    return UsageError(f"--chunk {lattice.size:g} m cuts the input into {count:,} chunks or more (at most "
                      f"{MOST_CHUNKS:,}); use a larger --chunk")


@dataclass
class SpilledChunks:
    """The chunks a pass found, with their spill files, and the input's point count."""

    lattice: ChunkLattice
    folder: Path
    points: int
    chunks: list[tuple[int, int]]
    bounds: tuple[float, float, float, float] | None = None  # of every point: xmin, ymin, xmax, ymax
    spilled: int = 0  # points written to the chunks' files: each point once, and again for each buffer holding it

    def extent(self, col: int, row: int) -> tuple[float, float, float, float] | None:
        """The input's extent clipped to chunk (col, row) with its buffer (its last cell's edge
        kept out): where a whole-file grid has cells there, and its edges."""
        if self.bounds is None:
            return None
        ox, oy = self.lattice.origin
        size, b = self.lattice.size, self.lattice.buffer
        x0, y0 = ox + col * size - b, oy + row * size - b
        x1, y1 = x0 + size + 2 * b, y0 + size + 2 * b
        # the far edge belongs to the next chunk: a micrometre inside it lies in the last cell
        # (chunks are whole cells; a cell is far wider, the coordinates' rounding far finer)
        inside = 1e-6
        xmin, ymin, xmax, ymax = self.bounds
        return (max(xmin, x0), max(ymin, y0), min(xmax, x1 - inside), min(ymax, y1 - inside))

    def path(self, col: int, row: int) -> Path:
        return self.folder / f"chunk_{col}_{row}.bin"

    def read(self, col: int, row: int) -> np.ndarray:
        """The chunk's points with its buffer, in input order (a :data:`RECORD` array); none for
        a chunk no point reached."""
        path = self.path(col, row)
        return np.fromfile(path, dtype=RECORD) if path.exists() else np.zeros(0, RECORD)


@contextlib.contextmanager
def scratch_folder(tmpdir: str | Path | None, beside: Path) -> Iterator[Path]:
    """A hidden temporary folder for a chunked run's files, in ``tmpdir`` (default: ``beside``,
    the output folder), removed when the block ends, however it ends; named after this process
    and host, so that a later run removes it should this one be killed outright
    (:func:`aldpat.io.atomic.scratch_dir`)."""
    folder = scratch_dir(".aldpat-scratch-", Path(tmpdir) if tmpdir else Path(beside))
    try:
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)


@contextlib.contextmanager
def spill_chunks(tables: Iterable[PointTable], lattice: ChunkLattice, *, tmpdir: str | Path | None = None) -> Iterator[SpilledChunks]:
    """Spill the point tables ``tables`` (an input's chunks of rows, in order) by chunk; the
    folder is removed when the block ends, however it ends."""
    # within a scratch folder (:func:`scratch_folder`), else one of its own in the system's
    folder = Path(tempfile.mkdtemp(prefix="aldpat-chunks-", dir=tmpdir)) if tmpdir is not None \
        else scratch_dir(".aldpat-scratch-", tempfile.gettempdir())
    try:
        owned: set[tuple[int, int]] = set()
        start = spilled = 0
        low, high = np.array([np.inf, np.inf]), np.array([-np.inf, -np.inf])
        for table in tables:
            n = len(table)
            if n == 0:
                continue
            records = np.empty(n, RECORD)
            records["row"] = np.arange(start, start + n)
            records["x"], records["y"], records["z"] = table.x, table.y, table.z
            low = np.minimum(low, [records["x"].min(), records["y"].min()])
            high = np.maximum(high, [records["x"].max(), records["y"].max()])
            col, row = lattice.index(records["x"], records["y"])
            own = _distinct_chunks(col, row)
            owned.update(zip(own[:, 0].tolist(), own[:, 1].tolist(), strict=True))
            if len(owned) > MOST_CHUNKS:
                raise too_many_chunks(lattice, len(owned))
            rows = max(1, SPILL_COPIES // lattice.most_copies_of_a_point)
            for first in range(0, n, rows):
                part = slice(first, first + rows)
                spilled += _append_by_chunk(folder, records[part], col[part], row[part], own, lattice)
            start += n
        # a chunk that holds only buffer points has nothing of its own to classify
        chunks = sorted(owned, key=lambda cr: (cr[1], cr[0]))
        bounds = (float(low[0]), float(low[1]), float(high[0]), float(high[1])) if start else None
        yield SpilledChunks(lattice, folder, start, chunks, bounds, spilled)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def _distinct_chunks(col: np.ndarray, row: np.ndarray) -> np.ndarray:
    """The distinct ``(col, row)`` pairs, sorted by column then row (an array of two columns)."""
    c0, r0 = int(col.min()), int(row.min())
    cols, rows = int(col.max()) - c0 + 1, int(row.max()) - r0 + 1
    if cols * rows <= 4 * len(col) + 4096:  # the usual case: a few chunks, marked on their span
        seen = np.zeros(cols * rows, bool)
        seen[(col - c0) * rows + (row - r0)] = True
        at = np.flatnonzero(seen)
        return np.stack([at // rows + c0, at % rows + r0], axis=1)
    order = np.lexsort((row, col))  # points scattered over a wide span: sort them
    pairs = np.stack([col[order], row[order]], axis=1)
    first = np.ones(len(pairs), bool)
    first[1:] = np.any(pairs[1:] != pairs[:-1], axis=1)
    return pairs[first]


def _append_by_chunk(folder: Path, records: np.ndarray, col: np.ndarray, row: np.ndarray, own: np.ndarray,
                     lattice: ChunkLattice) -> int:
    """Append each point of ``records`` (of chunk ``col``, ``row``; ``own`` the distinct chunks of
    these points or more, sorted) to the spill file of every chunk whose buffered extent holds it, in input order;
    the number of copies written."""
    reach = math.ceil(lattice.buffer / lattice.size) if lattice.buffer > 0 else 0
    around = np.arange(-reach, reach + 1)
    near = np.stack(np.meshgrid(around, around, indexing="ij"), axis=-1).reshape(-1, 2)
    # every chunk a point's buffer may reach: its own and its neighbours within the reach, sorted
    chunks = np.unique((own[:, None, :] + near[None, :, :]).reshape(-1, 2), axis=0)
    ox, oy = lattice.origin
    args = (records["x"], records["y"], col, row, np.ascontiguousarray(chunks[:, 0]), np.ascontiguousarray(chunks[:, 1]),
            float(ox), float(oy), float(lattice.size), float(lattice.buffer), reach)
    counts = np.zeros(len(chunks), np.int64)
    _place_copies(*args, counts, np.zeros(0, np.int64))
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    order = np.empty(int(counts.sum()), np.int64)
    _place_copies(*args, starts.copy(), order)
    copies = records[order]
    for k in np.flatnonzero(counts):
        with open(folder / f"chunk_{chunks[k, 0]}_{chunks[k, 1]}.bin", "ab") as fh:
            copies[starts[k]:starts[k] + counts[k]].tofile(fh)
    return len(order)


@compiled(nogil=True)
def _place_copies(x: np.ndarray, y: np.ndarray, col: np.ndarray, row: np.ndarray, chunk_cols: np.ndarray,
                  chunk_rows: np.ndarray, ox: float, oy: float, size: float, buffer: float, reach: int,
                  at: np.ndarray, order: np.ndarray) -> None:  # pragma: no cover - compiled
    """For every point, and every chunk (``chunk_cols``, ``chunk_rows``: sorted by column, then
    row) within ``reach`` of its own whose buffered extent holds it: with an empty ``order``,
    count it in ``at`` of that chunk; else write the point's index at ``order[at[chunk]]`` and
    advance ``at``. Points are taken in input order, so each chunk's copies keep it."""
    filling = len(order) > 0
    m = len(chunk_cols)
    for i in range(len(x)):
        for dc in range(-reach, reach + 1):
            c = col[i] + dc
            x0 = ox + c * size
            if (dc != 0) and not (x[i] >= x0 - buffer and x[i] < x0 + size + buffer):
                continue
            for dr in range(-reach, reach + 1):
                r = row[i] + dr
                if dc != 0 or dr != 0:  # its own chunk holds it whatever the buffer
                    y0 = oy + r * size
                    if not (x[i] >= x0 - buffer and x[i] < x0 + size + buffer
                            and y[i] >= y0 - buffer and y[i] < y0 + size + buffer):
                        continue
                lo, hi = 0, m  # the chunk's place among the sorted chunks
                while lo < hi:
                    mid = (lo + hi) // 2
                    if chunk_cols[mid] < c or (chunk_cols[mid] == c and chunk_rows[mid] < r):
                        lo = mid + 1
                    else:
                        hi = mid
                if lo == m or chunk_cols[lo] != c or chunk_rows[lo] != r:
                    continue  # not among the chunks (cannot be: they hold every point's reach); no stray write
                if filling:
                    order[at[lo]] = i
                at[lo] += 1


def map_chunks(fn: Callable, jobs: list[tuple], workers: int = 1) -> Iterator:
    """``fn(*job)`` for each job, in order: here, in ``workers`` processes, or -- inside a job
    running on a Dask worker -- each a unit of the cluster. Each chunk is a unit of the run's
    progress (:mod:`aldpat.core.units`)."""
    units.planned(len(jobs))
    for result in _map(fn, jobs, workers):
        units.finished()
        yield result


def _map(fn: Callable, jobs: list[tuple], workers: int) -> Iterator:
    if units.on_dask_worker():
        # every chunk a unit of the cluster; the job waits for them without holding its thread
        from distributed import worker_client

        with worker_client() as client:
            yield from _each_once([client.submit(fn, *job, pure=False) for job in jobs])
        return
    workers = workers_to_start(workers, f"-j {workers} for the chunks")
    if workers <= 1 or len(jobs) <= 1:
        for job in jobs:
            yield fn(*job)
        return
    pool = WorkerPool(workers)
    try:
        yield from _each_once(pool.submit_all(fn, jobs))
    except BaseException:  # an interruption, or a chunk that failed: the others are of no use
        pool.stop()
        raise
    pool.close()


def _each_once(futures: list) -> Iterator:
    """The futures' results in order, each future let go of once its result is handed on: a
    future keeps its result (on a Dask cluster, the cluster keeps it for the future), so a list
    of every chunk's futures held every chunk's result until the last one -- memory growing with
    the file (1.2 GB more at 100 M points)."""
    futures.reverse()
    while futures:
        yield futures.pop().result()
