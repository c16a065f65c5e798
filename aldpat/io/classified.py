"""Where a classified point file keeps its classes: LAS ``classification`` (ASPRS: 2 ground), or
in text the column ``aldpat filter --result classified`` writes -- the last column after x y z
holding only ASPRS codes 1, 2, 7 and 18 (a ``mark`` column may follow it).

The codes are the ASPRS LAS 1.4 standard classes (R15, Table 17): 1 unclassified, 2 ground,
7 low point (noise), 18 high noise. LAS point formats 0-5 (LAS 1.2/1.3) reserve 18, so there
high noise is written as 7, the one noise class they define."""

from __future__ import annotations

import numpy as np

from aldpat.io.registry import PointReader
from aldpat.io.table import PointTable

#: ASPRS classes written by ``aldpat filter --result classified``
UNCLASSIFIED = 1
GROUND = 2
LOW_NOISE = 7
HIGH_NOISE = 18
CLASSES = (UNCLASSIFIED, GROUND, LOW_NOISE, HIGH_NOISE)


def for_point_format(classes: np.ndarray, las_point_format: int | None) -> np.ndarray:
    """``classes`` as an output of ``las_point_format`` may hold them: high noise (18) stays 18 in
    text (None) and LAS point formats 6-10, and becomes 7 in formats 0-5."""
    if las_point_format is None or las_point_format >= 6:
        return classes
    return np.where(classes == HIGH_NOISE, LOW_NOISE, classes).astype(classes.dtype)


def class_column_of(reader: PointReader, table: PointTable) -> int | None:
    """The column of a classified text result: the last one after x y z whose values are all
    ASPRS codes 1, 2, 7 or 18 with some 2."""
    for k in range(len(reader.names) - 1, 2, -1):
        values = table[reader.names[k]]
        if np.isin(values, CLASSES).all() and (values == GROUND).any():
            return k
    return None


def ground_of(reader: PointReader, table: PointTable) -> np.ndarray | None:
    """Ground flags of a classified file, or None when it holds no classes."""
    if reader.format == "las":
        return np.asarray(table["classification"]) == GROUND
    k = class_column_of(reader, table)
    return None if k is None else np.asarray(table[reader.names[k]]) == GROUND


def parse_classes(text: str) -> tuple[int, ...] | None:
    """``--classes``: ``all`` (None: every point) or a list of ASPRS classes ``2`` / ``2,9``;
    ValueError for anything else."""
    value = str(text).strip().lower()
    if value == "all":
        return None
    items = [v for v in value.replace(";", ",").replace(" ", ",").split(",") if v]
    if not items:
        raise ValueError("expected 'all' or a list of LAS classes such as 2 or 2,9")
    out = []
    for item in items:
        if not (item.isascii() and item.isdigit()) or not 0 <= int(item) <= 255:
            raise ValueError(f"{item!r} is not a LAS class (0 to 255); expected 'all' or a list such as 2,9")
        out.append(int(item))
    return tuple(sorted(set(out)))


def classes_of_table(table: PointTable) -> np.ndarray | None:
    """The classes a point table carries: LAS ``classification`` or a text column ``class``."""
    for name in ("classification", "class"):
        if name in table.columns:
            return np.asarray(table.columns[name])
    return None


def in_classes(table: PointTable, classes: tuple[int, ...] | None) -> np.ndarray:
    """Which points of ``table`` are of ``classes`` (every point for None). A table without
    classes has none of them."""
    if classes is None:
        return np.ones(len(table), bool)
    held = classes_of_table(table)
    if held is None:
        return np.zeros(len(table), bool)
    return np.isin(held, np.asarray(classes, dtype=np.int64))


def withheld(table: PointTable) -> np.ndarray | None:
    """The withheld flag of a LAS table's points (None for other tables): points a LAS says are
    not to be used (LAS 1.4 R15: "should be considered deleted")."""
    record = table.record
    if record is None or "withheld" not in record.point_format.dimension_names:
        return None
    return np.asarray(record["withheld"]).astype(bool)


def product_points(table: PointTable, classes: tuple[int, ...] | None) -> np.ndarray:
    """The points of ``table`` a grid or DTM of ``classes`` is made from: those of the classes
    (every one for None, ``--classes all``), withheld points only with ``all``."""
    keep = in_classes(table, classes)
    held = withheld(table) if classes is not None else None
    return keep if held is None else keep & ~held


def held_classes(reader: PointReader) -> str:
    """What classes the points of ``reader`` hold, with their counts, for a message saying why a
    choice of classes left no point (``--classes 9`` of a file without water): "it holds class 0
    (131,622 points)", "classes 1 (20), 2 (180)", or that it holds none (text without a class
    column). Read in full, which such a message can afford."""
    counts = np.zeros(256, np.int64)
    for table in reader.chunks():
        held = classes_of_table(table)
        if held is None:
            return "it holds no classes"
        counts += np.bincount(np.asarray(held).astype(np.int64) & 255, minlength=256)[:256]
    found = [(c, int(n)) for c, n in enumerate(counts) if n]
    if not found:
        return "it holds no points"
    if len(found) == 1:
        return f"it holds class {found[0][0]} ({found[0][1]:,} points)"
    return "it holds classes " + ", ".join(f"{c} ({n:,})" for c, n in found)
