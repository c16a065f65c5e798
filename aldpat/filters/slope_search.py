"""The maximum local slope filter's neighbour search, compiled (numba): see :mod:`aldpat.filters.slope`.

Each point visits the cells around its own nearest first and stops at the first neighbour steep
enough below it, or as soon as no cell left can hold one: a neighbour at least ``gap`` away must
lie ``max_slope`` x ``gap`` below the point, and nothing within reach lies below ``reach_min``.
"""

from __future__ import annotations

import numpy as np

from aldpat.core.compiled import compiled


@compiled()
def steep_search(x: np.ndarray, y: np.ndarray, z: np.ndarray, cell_index: np.ndarray, flat_lowest: np.ndarray,
                 reach_min: np.ndarray, dr: np.ndarray, dc: np.ndarray, gap: np.ndarray, rows: int, cols: int,
                 r2_min: float, r2_max: float, max_slope: float, steep: np.ndarray) -> None:
    """Set ``steep[i]`` for every point with an array element (``flat_lowest``: the lowest point
    of each cell, -1 where empty; ``cell_index``: each point's cell, row-major) within ``r2_max``
    (squared distance, pairs closer than ``r2_min`` not compared) that lies ``max_slope`` or more
    below it."""
    s2 = max_slope * max_slope
    for i in range(len(z)):
        floor = reach_min[cell_index[i]]
        zi = z[i]
        if not zi > floor:  # at or below every neighbour: no slope down
            continue
        row, col = divmod(cell_index[i], cols)
        for k in range(len(gap)):
            if zi - max_slope * gap[k] < floor:
                break
            r = row + dr[k]
            c = col + dc[k]
            if r < 0 or r >= rows or c < 0 or c >= cols:
                continue
            j = flat_lowest[r * cols + c]
            if j < 0:
                continue
            d2 = (x[i] - x[j]) ** 2 + (y[i] - y[j]) ** 2
            if d2 < r2_min or d2 > r2_max or d2 == 0.0:
                continue
            drop = zi - z[j]
            if drop > 0.0 and drop * drop >= s2 * d2:
                steep[i] = True
                break
