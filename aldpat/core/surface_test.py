"""The final ground test against an interpolated provisional surface (SMRF's last step).

Pingel, Clarke & McBride (2013), "An improved simple morphological filter for the terrain
classification of airborne LIDAR data", ISPRS J. Photogramm. Remote Sens. 77, §2.4: once the
morphological passes have decided which *cells* are ground, the ground cells are interpolated
into a provisional terrain surface, and every *point* -- the lowest of its cell or not -- is
ground when its height above or below that surface is within an elevation threshold plus a
scalar times the local slope of the surface. The slope term keeps points on steep terrain whose
cell-sized surface lags the ground, and the two-sided test drops points left below the surface.

The surface keeps the ground cells' lowest points and fills every other cell harmonically
(:func:`provisional_surface`), as SMRF fills its provisional surface by inpainting.
"""

from __future__ import annotations

import numpy as np

from aldpat.core.lowest_grid import CellGridSpec

#: Points tested at once (bounds temporaries on large inputs).
_CHUNK = 1 << 21
#: Jacobi sweeps at each level of the pyramid on the way back up (more change the result
#: by under 0.01 points of ISPRS error: the coarse levels have already carried the far field).
SWEEPS = 4


def provisional_surface(z: np.ndarray, ground: np.ndarray, spec: CellGridSpec) -> np.ndarray:
    """Ground cells' heights, every other cell filled smoothly from them; NaN only when nothing
    is ground.

    SMRF fills its provisional surface by inpainting (Pingel et al. 2013); here the fill is a
    pull-push (Gortler et al. 1996, "The Lumigraph", §3.3) with Jacobi relaxation: the ground
    cells are averaged down a pyramid of 2 x 2 blocks until every block holds ground (pull);
    then, from the coarsest level up, each level starts from its parent's values and takes a
    few Jacobi sweeps of Laplace's equation with its ground-holding cells fixed (push). The
    result spans a building's footprint or a gap between sparse points with a smooth membrane
    from the ground around it -- close to, not exactly, the harmonic fill (a 20 m hole in a
    plane of slope 0.3 is filled within 0.25 m); ground cells keep their heights exactly.
    Work and memory are linear in the number of cells. Against a Delaunay TIN of the ground
    cells it scores the same on the ISPRS samples at a third of the time (bench/README.md).
    """
    if not ground.any():
        return np.full(z.shape, np.nan)
    # float32: a tolerance test needs no finer than 0.1 mm, and the pyramid is grid-sized
    value = np.where(ground, z, 0.0).astype(np.float32)
    weight = ground.astype(np.float32)
    levels = []
    while True:
        levels.append((value, weight))
        if min(value.shape) <= 2 or weight.min() >= 1.0:
            break
        value, weight = _pull(value, weight)
    value = _relax(levels[-1][0], levels[-1][1] >= 1.0, 4 * SWEEPS)
    for fine_value, fine_weight in reversed(levels[:-1]):
        rows, cols = fine_value.shape
        up = np.repeat(np.repeat(value, 2, axis=0), 2, axis=1)[:rows, :cols]
        fixed = fine_weight >= 1.0
        value = _relax(np.where(fixed, fine_value, up), fixed, SWEEPS)
    surface = value.astype(np.float64)
    surface[ground] = z[ground]  # the ground cells' own heights, to the last digit
    return surface


def _pull(value: np.ndarray, weight: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One level down: weighted means of 2 x 2 blocks, weights summed and capped at 1 (a block
    holding any ground is held at its ground cells' mean)."""
    rows, cols = value.shape
    pr, pc = rows + rows % 2, cols + cols % 2
    v = np.zeros((pr, pc), np.float32)
    w = np.zeros((pr, pc), np.float32)
    v[:rows, :cols] = value * weight
    w[:rows, :cols] = weight
    ws = w.reshape(pr // 2, 2, pc // 2, 2).sum(axis=(1, 3))
    vs = v.reshape(pr // 2, 2, pc // 2, 2).sum(axis=(1, 3))
    return np.divide(vs, ws, out=np.zeros_like(vs), where=ws > 0), np.minimum(ws, np.float32(1.0))


def _relax(value: np.ndarray, fixed: np.ndarray, sweeps: int) -> np.ndarray:
    """Jacobi sweeps of Laplace's equation on the cells not ``fixed`` (edges mirror)."""
    if value.shape[0] < 2 or value.shape[1] < 2:
        return value
    held = value[fixed]
    for _ in range(sweeps):
        padded = np.pad(value, 1, mode="edge")
        value = padded[:-2, 1:-1] + padded[2:, 1:-1]
        value += padded[1:-1, :-2]
        value += padded[1:-1, 2:]
        value *= np.float32(0.25)
        value[fixed] = held
    return value


def slope_of(surface: np.ndarray, cell: float) -> np.ndarray:
    """Gradient magnitude of a grid surface (m/m, float32: a tolerance needs no more), central
    differences."""
    if min(surface.shape) < 2:
        return np.zeros(surface.shape, np.float32)
    gy, gx = np.gradient(surface, cell)
    return np.hypot(gx, gy, out=gx).astype(np.float32)


def bilinear(grid: np.ndarray, spec: CellGridSpec, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``grid`` (values at cell centres) at points x, y, bilinearly; edges held constant."""
    return _blend(grid, _corners(grid.shape, spec, x, y))


def _corners(shape: tuple[int, int], spec: CellGridSpec, x: np.ndarray, y: np.ndarray) -> tuple:
    """The four cell centres around each point and its place between them (row, column)."""
    rows, cols = shape
    fc = np.clip((np.asarray(x) - spec.x0) / spec.cell - 0.5, 0.0, cols - 1.0)
    fr = np.clip((np.asarray(y) - spec.y0) / spec.cell - 0.5, 0.0, rows - 1.0)
    c0 = np.minimum(fc.astype(np.int64), max(cols - 2, 0))
    r0 = np.minimum(fr.astype(np.int64), max(rows - 2, 0))
    return r0, np.minimum(r0 + 1, rows - 1), c0, np.minimum(c0 + 1, cols - 1), fr - r0, fc - c0


def _blend(grid: np.ndarray, corners: tuple) -> np.ndarray:
    r0, r1, c0, c1, tr, tc = corners
    return ((grid[r0, c0] * (1 - tc) + grid[r0, c1] * tc) * (1 - tr)
            + (grid[r1, c0] * (1 - tc) + grid[r1, c1] * tc) * tr)


def within_surface(x: np.ndarray, y: np.ndarray, z: np.ndarray, surface: np.ndarray, spec: CellGridSpec, *,
                   threshold: float, slope_scalar: float) -> np.ndarray:
    """True where ``|z - surface| <= threshold + slope_scalar * slope`` at the point (a fixed
    tolerance when ``slope_scalar`` is 0)."""
    slope = slope_of(surface, spec.cell) if slope_scalar else None
    out = np.empty(len(z), bool)
    for a in range(0, len(z), _CHUNK):
        b = min(len(z), a + _CHUNK)
        corners = _corners(surface.shape, spec, x[a:b], y[a:b])  # once for both grids
        h = np.abs(z[a:b] - _blend(surface, corners))
        out[a:b] = h <= (threshold if slope is None else threshold + slope_scalar * _blend(slope, corners))
    return out
