"""Raised segments: objects found by the steps around them, whatever their size.

A morphological filter removes only objects smaller than its largest window; widening the
window to a railway shed or a department store cuts hilltops and embankments instead. A
connected-operator view (after Mongus & Žalik 2014, and the segment-based filters compared by
Sithole & Vosselman 2004) asks another question: split the lowest-point grid into segments of
cells joined wherever neighbouring cells differ by no more than ``step``; a building roof is then
one segment bounded by steps *down* to the ground on nearly all of its perimeter, while a
hilltop or the upper side of an embankment joins the surrounding terrain through cells of
gentle slope and is bounded by steps on little or none of it. Cells on the border of the grid
count as open perimeter, so a terrace above a cliff that runs out of the data is not taken for
a roof (a building cut by the border of a tile is left to the buffer of the next one).

:func:`raised_segments` marks the cells of every segment whose perimeter steps are mostly
down-steps (the segment stands above what surrounds it), except the largest segment, which is
the connected terrain itself. Work is one sparse connected-components pass over the grid's
4-neighbour graph (scipy.sparse.csgraph) and a few ``bincount`` calls: linear in the number of
cells, no loop over cells.
"""

from __future__ import annotations

import numpy as np

from aldpat._lazy import lazy_import

sparse = lazy_import("scipy.sparse")
csgraph = lazy_import("scipy.sparse.csgraph")


def raised_segments(z: np.ndarray, step: float, down_share: float) -> np.ndarray:
    """Cells of segments that stand above their surroundings (bool, the shape of ``z``).

    Parameters
    ----------
    z : (rows, cols) float
        lowest-point grid with empty cells filled.
    step : float
        neighbouring cells whose heights differ by more than this are in different segments (m).
    down_share : float
        a segment is raised when at least this share of the steps on its perimeter go down from it.
    """
    z = np.asarray(z, dtype=np.float64)
    rows, cols = z.shape
    if rows * cols < 2:
        return np.zeros(z.shape, bool)
    index = np.arange(rows * cols, dtype=np.int64).reshape(rows, cols)
    a = np.concatenate([index[:, :-1].ravel(), index[:-1, :].ravel()])
    b = np.concatenate([index[:, 1:].ravel(), index[1:, :].ravel()])
    del index
    flat = z.ravel()
    rise = flat[b] - flat[a]  # from cell a to its east or north neighbour b
    joined = np.abs(rise) <= step
    n_cells = rows * cols
    graph = sparse.coo_matrix((np.ones(int(joined.sum()), np.int8), (a[joined], b[joined])),
                              shape=(n_cells, n_cells))
    count, label = csgraph.connected_components(graph, directed=False)
    del graph
    cut = ~joined
    la, lb, r = label[a[cut]], label[b[cut]], rise[cut]
    down = np.bincount(la, weights=r < 0, minlength=count) + np.bincount(lb, weights=r > 0, minlength=count)
    steps = np.bincount(la, minlength=count) + np.bincount(lb, minlength=count)
    size = np.bincount(label, minlength=count)
    # the grid's own edge is open perimeter: a terrace running out of the data is not enclosed
    # by down-steps the way a roof is
    edge = np.zeros((rows, cols), bool)
    edge[0, :] = edge[-1, :] = edge[:, 0] = edge[:, -1] = True
    open_edge = np.bincount(label[edge.ravel()], minlength=count)
    raised = (steps > 0) & (down >= down_share * (steps + open_edge))
    raised[np.argmax(size)] = False  # the connected terrain
    return raised[label].reshape(rows, cols)
