"""Bounded-memory grouping of points by cell block: spill to temporary files, read back a bucket
at a time.

A cell-based task (thin) must see every point of a cell together, but the points of one cell can
be anywhere in a file that is not sorted in space. Each chunk is therefore split by a hash of its
cell blocks (16 x 16 cells) into K binary bucket files in a temporary folder beside the output;
every cell lies in exactly one bucket, and each bucket is then processed in memory on its own.
K is chosen from the estimated number of points so that a bucket holds about one chunk:
memory stays near one chunk whatever the input size (as long as no single cell block holds
more points than that). Small inputs (one bucket) skip the files altogether.
"""

from __future__ import annotations

import math
import os
import shutil
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from aldpat.io.atomic import scratch_dir
from aldpat.io.registry import PointReader
from aldpat.io.table import PointTable

BUCKET_POINTS = 2_000_000
BLOCK_CELLS = 16
_REC = "__record"


def estimate_points(reader: PointReader) -> int:
    """Points in a file: LAS headers know; for text, the file size over the mean line length."""
    count = reader.count
    if count:
        return int(count)
    size = os.path.getsize(reader.path)
    with open(reader.path, "rb") as fh:
        head = fh.read(1 << 16)
    lines = max(head.count(b"\n"), 1)
    return int(size / (len(head) / lines)) + 1


def bucket_count(points: int, per_bucket: int | None = None) -> int:
    return max(1, math.ceil(points / (per_bucket or BUCKET_POINTS)))


def bucket_of(i: np.ndarray, j: np.ndarray, k: int) -> np.ndarray:
    """Bucket of cells (i, j): a hash of their 16 x 16 block, so whole blocks share a bucket."""
    bi = np.floor_divide(i, BLOCK_CELLS)
    bj = np.floor_divide(j, BLOCK_CELLS)
    return np.mod(bi * 73856093 ^ bj * 19349663, k)


class Spill:
    """K bucket files of fixed-size binary rows (table columns plus the LAS record, if any)."""

    def __init__(self, folder: Path, k: int):
        self.dir = scratch_dir(".aldpat-spill-", folder)  # a killed run's buckets are removed by the next
        self.k = k
        self.dtype: np.dtype | None = None
        self.point_format = None
        self.meta: dict = {}
        self._files = [open(self.dir / f"{b}.bin", "wb") for b in range(k)]  # noqa: SIM115  (closed by close())

    def add(self, table: PointTable, bucket: np.ndarray) -> None:
        if self.dtype is None:
            fields = [(n, table.columns[n].dtype) for n in table.names]
            if table.record is not None:
                fields.append((_REC, table.record.array.dtype))
                self.point_format = table.record.point_format
            self.dtype = np.dtype(fields)
            self.meta = dict(table.meta)
        rows = np.empty(len(table), dtype=self.dtype)
        for n in table.names:
            rows[n] = table.columns[n]
        if table.record is not None:
            rows[_REC] = table.record.array
        order = np.argsort(bucket, kind="stable")
        sorted_b = bucket[order]
        starts = np.searchsorted(sorted_b, np.arange(self.k + 1))
        for b in range(self.k):
            if starts[b + 1] > starts[b]:
                rows[order[starts[b]:starts[b + 1]]].tofile(self._files[b])

    def buckets(self) -> Iterator[PointTable]:
        for fh in self._files:
            fh.close()
        if self.dtype is None:
            return
        for b in range(self.k):
            rows = np.fromfile(self.dir / f"{b}.bin", dtype=self.dtype)
            if len(rows) == 0:
                continue
            cols = {n: np.ascontiguousarray(rows[n]) for n in self.dtype.names or () if n != _REC}
            record = None
            if self.point_format is not None:
                import laspy

                record = laspy.PackedPointRecord(np.ascontiguousarray(rows[_REC]), self.point_format)
            yield PointTable(cols, record, dict(self.meta))

    def close(self) -> None:
        for fh in self._files:
            fh.close()
        shutil.rmtree(self.dir, ignore_errors=True)
