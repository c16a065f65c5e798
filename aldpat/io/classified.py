"""Where a classified point file keeps its classes: LAS ``classification`` (ASPRS: 2 ground), or
in text the column ``aldpat filter --result classified`` writes -- the last column after x y z
holding only ASPRS codes 1, 2, 7 and 18 (a ``mark`` column may follow it).

The codes are the ASPRS LAS 1.4 standard classes (R15, Table 17): 1 unclassified, 2 ground,
7 low point (noise), 18 high noise. LAS point formats 0-5 (LAS 1.2/1.3) reserve 18, so there
high noise is written as 7, the one noise class they define."""

from __future__ import annotations

import numpy as np

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


def class_column_of(reader, table) -> int | None:
    """The column of a classified text result: the last one after x y z whose values are all
    ASPRS codes 1, 2, 7 or 18 with some 2."""
    for k in range(len(reader.names) - 1, 2, -1):
        values = table[reader.names[k]]
        if np.isin(values, CLASSES).all() and (values == GROUND).any():
            return k
    return None


def ground_of(reader, table) -> np.ndarray | None:
    """Ground flags of a classified file, or None when it holds no classes."""
    if reader.format == "las":
        return np.asarray(table["classification"]) == GROUND
    k = class_column_of(reader, table)
    return None if k is None else np.asarray(table[reader.names[k]]) == GROUND
