"""The in-memory point table every reader yields and every writer takes.

A table is an ordered mapping of column name -> 1-D numpy array, all the same length. Names
used across the project:

* points: ``x y z`` and optionally ``intensity`` (ALDPAT's ``x y z i``);
* ALTM tapes and strips: ``t x2 y2 z2 i2 x1 y1 z1 i1`` (1 = first return, 2 = last return);
* added by tasks: ``class``, ``mark``...

LAS tables also carry ``record``, the laspy point record the rows came from, so that a task
which subsets or reclassifies points writes every other LAS attribute back unchanged.
``meta["in_record"]`` names the columns that still equal the record's fields; a writer copies
those straight from the record instead of converting them again. Change columns only through
:meth:`PointTable.with_columns`, which keeps that set honest.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass
class PointTable:
    columns: dict[str, np.ndarray]
    record: Any = None  # laspy.PackedPointRecord (LAS/LAZ only), row-aligned with columns
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        lengths = {len(v) for v in self.columns.values()}
        if len(lengths) > 1:
            raise ValueError(f"columns of unequal length: {lengths}")

    def __len__(self) -> int:
        for v in self.columns.values():
            return len(v)
        return 0 if self.record is None else len(self.record)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __contains__(self, name: str) -> bool:
        return name in self.columns

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.columns)

    @property
    def x(self) -> np.ndarray:
        return self.columns["x"]

    @property
    def y(self) -> np.ndarray:
        return self.columns["y"]

    @property
    def z(self) -> np.ndarray:
        return self.columns["z"]

    def take(self, index: np.ndarray | slice) -> PointTable:
        """Rows selected by a boolean mask or an integer index (record included)."""
        cols = {k: v[index] for k, v in self.columns.items()}
        rec = None if self.record is None else self.record[index]
        return PointTable(cols, rec, dict(self.meta))

    def with_columns(self, **new: np.ndarray) -> PointTable:
        """A table with columns added or replaced (same rows)."""
        cols = dict(self.columns)
        meta = dict(self.meta)
        if "in_record" in meta:
            meta["in_record"] = frozenset(meta["in_record"]) - set(new)
        for k, v in new.items():
            v = np.asarray(v)
            if len(v) != len(self):
                raise ValueError(f"column {k!r} has {len(v)} rows, table has {len(self)}")
            cols[k] = v
        return PointTable(cols, self.record, meta)

    def select(self, names: Iterable[str]) -> PointTable:
        """A table with only the named columns, in that order."""
        return PointTable({n: self.columns[n] for n in names}, self.record, dict(self.meta))

    def rename(self, mapping: dict[str, str]) -> PointTable:
        return PointTable({mapping.get(k, k): v for k, v in self.columns.items()}, self.record, dict(self.meta))

    @staticmethod
    def concat(tables: list[PointTable]) -> PointTable:
        if not tables:
            return PointTable({})
        names = tables[0].names
        cols = {n: np.concatenate([t.columns[n] for t in tables]) for n in names}
        rec = None
        if tables[0].record is not None:
            import laspy

            first = tables[0].record
            array = np.concatenate([t.record.array for t in tables])
            rec = laspy.PackedPointRecord(array, first.point_format)
        meta = dict(tables[0].meta)
        if "in_record" in meta:
            meta["in_record"] = frozenset.intersection(*(frozenset(t.meta.get("in_record", ())) for t in tables))
        return PointTable(cols, rec, meta)
