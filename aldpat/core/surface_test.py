"""The final ground test against an interpolated provisional surface (SMRF's last step).

Pingel, Clarke & McBride (2013), "An improved simple morphological filter for the terrain
classification of airborne LIDAR data", ISPRS J. Photogramm. Remote Sens. 77, §2.4: once the
morphological passes have decided which *cells* are ground, the ground cells are interpolated
into a provisional terrain surface, and every *point* -- the lowest of its cell or not -- is
ground when its height above or below that surface is within an elevation threshold plus a
scalar times the local slope of the surface. The slope term keeps points on steep terrain whose
cell-sized surface lags the ground, and the two-sided test drops points left below the surface.

The surface is a Delaunay TIN of the ground cells' lowest points at their cell centres: ground
cells keep their heights, the cells between them are interpolated linearly, cells outside the
ground cells' hull take the nearest ground value.
"""

from __future__ import annotations

import numpy as np

from aldpat._lazy import lazy_import
from aldpat.core.grid_extent import GridSpec as NodeSpec
from aldpat.core.lowest_grid import GridSpec, fill_nearest

ndimage = lazy_import("scipy.ndimage")

#: Points tested at once (bounds temporaries on large inputs).
_CHUNK = 1 << 21


def provisional_surface(z: np.ndarray, ground: np.ndarray, spec: GridSpec) -> np.ndarray:
    """Ground cells' heights, and the cells between them interpolated; NaN only when nothing is
    ground.

    A ground cell keeps its own height (it is a node of the TIN). Only the other cells need
    interpolating, and the triangles that cover them join ground cells on the rims of the holes
    they form, so the TIN (:func:`aldpat.core.interpolate.linear`, blocked and threaded) is
    built from those rim cells alone. Cells outside the rims' hull take the nearest ground
    height.
    """
    if not ground.any():
        return np.full(z.shape, np.nan)
    holes = ~ground
    surface = np.where(ground, z, np.nan)
    if not holes.any():
        return surface
    rim = ground & ndimage.binary_dilation(holes, structure=np.ones((3, 3), bool))
    rr, rc = np.nonzero(rim)
    del rim
    if len(rr) >= 3 and min(z.shape) >= 2:
        from aldpat.core.interpolate import linear

        xc, yc = spec.centers()
        nodes = NodeSpec(xmin=xc[0], ymin=yc[0], dx=spec.cell, dy=spec.cell, nx=spec.cols, ny=spec.rows)
        # blocked and threaded; rim cells on one line triangulate to nothing (all blank)
        tin = linear(xc[rc], yc[rr], z[rr, rc], nodes).reshape(z.shape)
        del rr, rc
        np.copyto(surface, tin, where=holes)
        del tin
    blank = np.isnan(surface)
    if blank.any():
        surface = fill_nearest(surface, blank)
    return surface


def slope_of(surface: np.ndarray, cell: float) -> np.ndarray:
    """Gradient magnitude of a grid surface (m/m, float32: a tolerance needs no more), central
    differences."""
    if min(surface.shape) < 2:
        return np.zeros(surface.shape, np.float32)
    gy, gx = np.gradient(surface, cell)
    out = np.hypot(gx, gy, out=gx).astype(np.float32)
    return out


def bilinear(grid: np.ndarray, spec: GridSpec, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``grid`` (values at cell centres) at points x, y, bilinearly; edges held constant."""
    rows, cols = grid.shape
    fc = np.clip((np.asarray(x) - spec.x0) / spec.cell - 0.5, 0.0, cols - 1.0)
    fr = np.clip((np.asarray(y) - spec.y0) / spec.cell - 0.5, 0.0, rows - 1.0)
    c0 = np.minimum(fc.astype(np.int64), max(cols - 2, 0))
    r0 = np.minimum(fr.astype(np.int64), max(rows - 2, 0))
    tc = fc - c0
    tr = fr - r0
    c1 = np.minimum(c0 + 1, cols - 1)
    r1 = np.minimum(r0 + 1, rows - 1)
    return ((grid[r0, c0] * (1 - tc) + grid[r0, c1] * tc) * (1 - tr)
            + (grid[r1, c0] * (1 - tc) + grid[r1, c1] * tc) * tr)


def within_surface(x: np.ndarray, y: np.ndarray, z: np.ndarray, surface: np.ndarray, spec: GridSpec, *,
                   threshold: float, slope_scalar: float) -> np.ndarray:
    """True where ``|z - surface| <= threshold + slope_scalar * slope`` at the point."""
    slope = slope_of(surface, spec.cell)
    out = np.empty(len(z), bool)
    for a in range(0, len(z), _CHUNK):
        b = min(len(z), a + _CHUNK)
        h = np.abs(z[a:b] - bilinear(surface, spec, x[a:b], y[a:b]))
        out[a:b] = h <= threshold + slope_scalar * bilinear(slope, spec, x[a:b], y[a:b])
    return out
