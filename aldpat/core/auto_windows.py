"""The cell and windows of the adaptive morphological filter derived from the data (``--auto``).

The dissertation (Cui 2013, ch. 6, Tables 6-8, 6-10, 6-13) publishes three parameter sets for
three terrains, each a cell, a window series and its cluster thresholds chosen by hand. Here
they are chosen from the points instead:

* the cell follows the point density: the mean point spacing over the occupied ground
  (:func:`occupied_spacing`), in steps of 5 cm, never coarser than set 01's cell (on the ISPRS
  samples, 0.16-0.97 points/m2, coarser cells for sparser data lost 0.7 points of mean total
  error, bench/README.md: a cell under the spacing keeps each point's place in its own cell);
* the largest window is the largest object the data hold (:func:`largest_object`: the widest
  raised segment of :mod:`aldpat.core.segments`), within :data:`AUTO_REACH` and no wider than a
  quarter of the data's shorter side, where a window would take the whole slope for an object;
  the windows are those of :data:`AUTO_WINDOWS` up to it, kept at their extent in metres
  whatever the cell.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from aldpat._lazy import lazy_import
from aldpat.core.lowest_grid import fill_nearest, lowest_grid
from aldpat.core.segments import raised_segments

ndimage = lazy_import("scipy.ndimage")

#: Cell size of parameter set 01 (dissertation Table 6-8); :data:`AUTO_WINDOWS` are in its cells,
#: and the derived cell is never coarser.
SET01_CELL = 0.75
#: Coarse cells (m) over which the occupied area, and so the point density, is measured.
DENSITY_CELL = 5.0
#: The windows chosen from, in cells of set 01's 0.75 m: set 01's series (Table 6-8) extended by
#: the 30 and 40 of sets 02 and 03 (Tables 6-10, 6-13), with their cluster thresholds; columns
#: stop at 16 as in all three sets.
AUTO_WINDOWS = (1, 2, 4, 8, 12, 16, 20, 30, 40)
AUTO_THRESHOLDS = (0.3, 0.5, 1.0, 1.0, 1.0, 2.0, 2.0, 2.0, 2.0)
AUTO_MAX_COLUMN_WINDOW = 16
#: Bounds of the largest half window derived (m): at least a tree crown's, at most set 03's.
AUTO_REACH = (6.0, 30.0)


class AutoWindows(NamedTuple):
    """What ``--auto`` derives: the cell (m) and, for rows and for columns, the half windows (cells)
    with their cluster thresholds (m), ascending."""

    cell: float
    rows: dict[int, float]
    columns: dict[int, float]


def occupied_spacing(x: np.ndarray, y: np.ndarray) -> float:
    """Mean point spacing: 1 / sqrt(points per m2 of occupied ground), water and gaps left out."""
    if len(x) == 0:
        return 1.0
    cx = np.floor((x - x.min()) / DENSITY_CELL).astype(np.int64)
    cy = np.floor((y - y.min()) / DENSITY_CELL).astype(np.int64)
    occupied = len(np.unique(cy * (int(cx.max()) + 1) + cx))
    return float(np.sqrt(occupied * DENSITY_CELL ** 2 / len(x)))


def largest_object(x: np.ndarray, y: np.ndarray, z: np.ndarray, *, step: float, share: float,
                   origin: tuple[float, float] | None = None) -> float:
    """Half-width (m) of the largest object the data hold: the widest inscribed half-width of a
    raised segment (:func:`aldpat.core.segments.raised_segments` with ``step`` and ``share``) of
    the lowest-point grid on set 01's cells."""
    grid = lowest_grid(x, y, z, SET01_CELL, origin=origin)
    spacing = np.empty(grid.z.shape, np.uint8)
    filled = fill_nearest(grid.z, grid.empty, spacing=spacing)
    raised = raised_segments(filled, step, share, spacing=spacing, cell=SET01_CELL)
    if not raised.any():
        return 0.0
    return float(ndimage.distance_transform_edt(raised).max()) * SET01_CELL


def auto_windows(x: np.ndarray, y: np.ndarray, z: np.ndarray, *, step: float, share: float,
                 origin: tuple[float, float] | None = None) -> AutoWindows:
    """The cell and windows for the points ``x, y, z`` (module docstring); ``step`` and ``share``
    are the raised-segment test's, ``origin`` the grid's."""
    x = np.asarray(x, np.float64)
    y = np.asarray(y, np.float64)
    z = np.asarray(z, np.float64)
    cell = min(SET01_CELL, max(0.05, round(occupied_spacing(x, y) / 0.05) * 0.05))
    reach = min(max(largest_object(x, y, z, step=step, share=share, origin=origin), AUTO_REACH[0]), AUTO_REACH[1])
    if len(x):
        reach = min(reach, 0.25 * min(np.ptp(x), np.ptp(y)))

    def scaled(windows: tuple[int, ...]) -> dict[int, float]:
        out: dict[int, float] = {}
        for k, threshold in zip(AUTO_WINDOWS, AUTO_THRESHOLDS, strict=True):
            if k not in windows or (out and k * SET01_CELL > reach + 1e-9):
                continue
            out.setdefault(max(1, round(k * SET01_CELL / cell)), threshold)
        return out

    columns = tuple(k for k in AUTO_WINDOWS if k <= AUTO_MAX_COLUMN_WINDOW)
    return AutoWindows(cell, scaled(AUTO_WINDOWS), scaled(columns))
