"""Synthetic terrain with known ground for the dissertation's filters (tests only)."""

from __future__ import annotations

import numpy as np


def scene(rows: int = 120, cols: int = 160, seed: int = 0):
    """Rolling ground with buildings and trees on a 1 m grid.

    Returns ``z`` and the bool mask of object cells (everything else is ground).
    """
    rng = np.random.default_rng(seed)
    r, c = np.mgrid[0:rows, 0:cols].astype(float)
    ground = 3.0 * np.sin(c / 25.0) + 2.0 * np.cos(r / 30.0) + 0.05 * c + rng.normal(0, 0.05, (rows, cols))
    z = ground.copy()
    obj = np.zeros((rows, cols), bool)
    for r0, c0, h, w, height in [(10, 10, 20, 25, 8.0), (60, 90, 30, 18, 12.0), (85, 20, 15, 15, 6.0)]:
        obj[r0:r0 + h, c0:c0 + w] = True
        z[r0:r0 + h, c0:c0 + w] = ground[r0:r0 + h, c0:c0 + w].max() + height
    for _ in range(25):  # trees: small blobs
        tr, tc = rng.integers(2, rows - 4), rng.integers(2, cols - 4)
        if obj[tr - 1:tr + 3, tc - 1:tc + 3].any():
            continue
        obj[tr:tr + 3, tc:tc + 3] = True
        z[tr:tr + 3, tc:tc + 3] = ground[tr:tr + 3, tc:tc + 3] + rng.uniform(4, 10, (3, 3))
    return z, obj


def errors(marks: np.ndarray, obj: np.ndarray) -> tuple[float, float]:
    """(Type I %, Type II %) of a mark matrix against the object mask."""
    removed = marks > 0
    t1 = 100.0 * (removed & ~obj).sum() / (~obj).sum()
    t2 = 100.0 * (~removed & obj).sum() / obj.sum()
    return t1, t2


def slope_with_low_clump(isolated: int = 0, seed: int = 5):
    """20,000 ground points on a 100 m x 100 m slope, a clump of 40 multipath points 3-8 m below
    it (a 3 m square at its centre) and ``isolated`` single low points 3-8 m below it elsewhere.

    Returns ``x, y, z`` and the bool mask of ground points (the low points last).
    """
    rng = np.random.default_rng(seed)
    n = 20_000
    x, y = rng.uniform(0, 100, n), rng.uniform(0, 100, n)
    z = 50 + 0.05 * x + rng.normal(0, 0.03, n)
    cx, cy = rng.uniform(48, 51, 40), rng.uniform(48, 51, 40)
    ix, iy = (rng.uniform(5, 95, isolated), rng.uniform(5, 95, isolated)) if isolated else (np.zeros(0), np.zeros(0))
    xs, ys = np.r_[x, cx, ix], np.r_[y, cy, iy]
    zs = np.r_[z, 50 + 0.05 * cx - rng.uniform(3, 8, 40)]
    if isolated:
        zs = np.r_[zs, 50 + 0.05 * ix - rng.uniform(3, 8, isolated)]
    ground = np.r_[np.ones(n, bool), np.zeros(40 + isolated, bool)]
    return xs, ys, zs, ground


def walled_terraces(seed: int = 3):
    """Disconnected terrain: five 30 m terraces behind 3.5 m retaining walls, each running the
    whole width of the data, with a 25 m x 18 m building on two of them; 1 point per m2.

    Returns ``x, y, z`` and the bool mask of ground points.
    """
    rng = np.random.default_rng(seed)
    n = 200 * 150
    x, y = rng.uniform(0, 200, n), rng.uniform(0, 150, n)
    ground = 200 + 3.5 * np.floor(y / 30) + 0.02 * x + rng.normal(0, 0.05, n)
    building = np.zeros(n, bool)
    for x0, y0 in ((30, 5), (120, 65)):
        building |= (x >= x0) & (x < x0 + 25) & (y >= y0) & (y < y0 + 18)
    z = np.where(building, ground + 8.0, ground)
    return x, y, z, ~building
