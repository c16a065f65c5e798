"""Where a classified point file keeps its classes: LAS ``classification`` (ASPRS: 2 ground), or
in text the column ``aldpat filter --result classified`` writes -- the last column after x y z
holding only 1 and 2 (a ``mark`` column may follow it)."""

from __future__ import annotations

import numpy as np

#: ASPRS class of ground points
GROUND = 2


def class_column_of(reader, table) -> int | None:
    """The column of a classified text result: the last one after x y z whose values are all
    1 or 2 with some 2."""
    for k in range(len(reader.names) - 1, 2, -1):
        values = table[reader.names[k]]
        if np.isin(values, (1, 2)).all() and (values == GROUND).any():
            return k
    return None


def ground_of(reader, table) -> np.ndarray | None:
    """Ground flags of a classified file, or None when it holds no classes."""
    if reader.format == "las":
        return np.asarray(table["classification"]) == GROUND
    k = class_column_of(reader, table)
    return None if k is None else np.asarray(table[reader.names[k]]) == GROUND
