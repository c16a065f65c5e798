"""Aligned cell grids and the choice of one representative point per cell.

ALDPAT 1.0 user manual (2007), Miscellaneous Tasks, "Reduce Point Density": a window (cell) of
Width x Height keeps the point of minimum elevation ("Lowest"), the point of median elevation
("Median") or the point at the centre of the window ("Center"). Cui (2013) §3.1.1
"Sparse Data": the area is split into cells indexed by column and row and each cell keeps one
representative point.

Cells are aligned to whole multiples of the cell size from an origin (0, 0 unless given): cell
(i, j) covers [ox + i*w, ox + (i+1)*w) x [oy + j*h, oy + (j+1)*h), so data thinned in
pieces gives the same cells as data thinned at once.
"""

from __future__ import annotations

import numpy as np

from aldpat.errors import DataError

METHODS = ("lowest", "median", "center")
#: The most cells a point may lie from the origin. Past it a cell is below the last place of the
#: quotient (2**44 cells: its spare of a few units in the last place grows to 1/64 of a cell), and
#: past 2**63 the column wraps round int64: every point of a file at a cell of 1e-15 m fell into
#: one "cell", and ``thin`` kept one point of it, silently.
MOST_FROM_ORIGIN = 2.0**44


def cell_of(x: np.ndarray, y: np.ndarray, width: float, height: float,
            origin: tuple[float, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Column ``i`` and row ``j`` (int64) of the aligned cell holding each point: cells
    ``[i w, (i + 1) w)``, a point on an edge in the cell above it. The quotient is floored with a
    few units in its last place to spare: 512000.6 / 0.2 is 2560002.9999999995 in binary
    floating point, and a point written on an edge fell into the cell below (a fifth of the exact
    edges of 2-decimal UTM coordinates at 0.2 m cells)."""
    if not (width > 0 and height > 0):
        raise ValueError(f"cell width and height must be > 0, got {width!r} x {height!r}")
    ox, oy = origin if origin is not None else (0.0, 0.0)
    return _floored((np.asarray(x, dtype=np.float64) - ox) / width, width, "x"), \
        _floored((np.asarray(y, dtype=np.float64) - oy) / height, height, "y")


def _floored(q: np.ndarray, cell: float, axis: str) -> np.ndarray:
    """floor(q) as int64, a quotient a few units in the last place below a whole number taken as it."""
    far = float(np.max(np.abs(q), initial=0.0))
    if not far < MOST_FROM_ORIGIN:  # NaN too
        raise DataError(f"a point lies {far:.3g} cells of {cell:g} m from the origin in {axis}, more than cells "
                        f"of that size can be told apart ({MOST_FROM_ORIGIN:.3g}); use a larger cell")
    spare = np.spacing(np.abs(q))
    spare *= 8
    spare += q
    return np.floor(spare).astype(np.int64)


def _groups(sorted_i: np.ndarray, sorted_j: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and length of each run of equal (i, j) in cell-sorted arrays."""
    n = len(sorted_i)
    change = np.ones(n, dtype=bool)
    change[1:] = (sorted_i[1:] != sorted_i[:-1]) | (sorted_j[1:] != sorted_j[:-1])
    starts = np.flatnonzero(change)
    lengths = np.diff(np.append(starts, n))
    return starts, lengths


def select_per_cell(x: np.ndarray, y: np.ndarray, z: np.ndarray, width: float, height: float, *,
                    method: str = "lowest", origin: tuple[float, float] | None = None) -> np.ndarray:
    """Indices of the one point each occupied cell keeps, in ascending (input) order.

    ``lowest``: the point of minimum z. ``median``: the point of median z (for an even count the
    lower of the two middle points, so the kept point is a real one). ``center``: the point
    nearest the cell centre. Ties go to the earlier point, so results never depend on chance.
    One stable sort by (row, column, criterion); no loop over points or cells.
    """
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; expected one of {', '.join(METHODS)}")
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    z = np.asarray(z, dtype=np.float64)
    if len(x) == 0:
        return np.zeros(0, dtype=np.int64)
    i, j = cell_of(x, y, width, height, origin)
    if method == "center":
        ox, oy = origin if origin is not None else (0.0, 0.0)
        dx = x - (ox + (i + 0.5) * width)
        dy = y - (oy + (j + 0.5) * height)
        key = dx * dx + dy * dy
    else:
        key = z
    order = np.lexsort((key, i, j))  # stable: equal keys keep input order
    starts, lengths = _groups(i[order], j[order])
    pick = starts + (lengths - 1) // 2 if method == "median" else starts
    return np.sort(order[pick])
