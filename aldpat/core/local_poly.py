"""Local polynomial surfaces on a grid of nodes, fitted to a set of points by least squares.

Used by the iterative polynomial filters (ALDPAT manual, Appendix "Iterative Polynomial Fitting
(IPF) Filter" and the polynomial two-surface filter, Figs. 14-15): at every node of the grid a
polynomial of degree 1 (a plane) or 2 is fitted to the points in a square window of
``(2k + 1)`` cells centred on the node, and the surface at the node is the polynomial's value
there.

Vectorised over nodes: the sums ``sum u^i v^j`` and ``sum z u^i v^j`` of the points (``u``,
``v``: position in cells) are accumulated per cell, summed over every window by a box filter,
and moved to each node's own origin by the binomial theorem, so that each node's normal
equations are solved in one batched call. Nodes whose window holds fewer than ``min_points``
points take a window twice as wide, then four times ... (up to ``MAX_GROWTH`` doublings); a node
still short of points takes the nearest fitted node's value.
"""

from __future__ import annotations

from math import comb

import numpy as np

from aldpat._lazy import lazy_import
from aldpat.core.lowest_grid import GridSpec, fill_nearest

ndimage = lazy_import("scipy.ndimage")

#: How many times a window may double to reach ``min_points``.
MAX_GROWTH = 4
#: Ridge added to the slope and curvature terms (relative to the point count): a window whose
#: points are collinear then gets the flattest polynomial through them instead of no answer.
RIDGE = 1e-6


def _monomials(degree: int) -> list[tuple[int, int]]:
    return [(i, d - i) for d in range(degree + 1) for i in range(d, -1, -1)]


def _box_sum(a: np.ndarray, k: int) -> np.ndarray:
    """Sum over the (2k+1)^2 window around every cell (zero outside the grid)."""
    if k == 0:
        return a.copy()
    size = 2 * k + 1
    return ndimage.uniform_filter(a, size=size, mode="constant", cval=0.0) * (size * size)


class PointSums:
    """Per-cell sums of the powers of a point set's position (in cells), ready to fit."""

    def __init__(self, spec: GridSpec, x: np.ndarray, y: np.ndarray, z: np.ndarray, degree: int):
        if degree not in (1, 2):
            raise ValueError(f"degree must be 1 or 2, got {degree}")
        self.spec = spec
        self.degree = degree
        rows, cols = spec.shape
        # position in cells about the grid's centre: keeps the powers small for the binomial shift
        self.u0, self.v0 = cols / 2.0, rows / 2.0
        u = (x - spec.x0) / spec.cell - 0.5 - self.u0
        v = (y - spec.y0) / spec.cell - 0.5 - self.v0
        col = np.clip(np.floor(u + self.u0 + 0.5).astype(np.int64), 0, cols - 1)
        row = np.clip(np.floor(v + self.v0 + 0.5).astype(np.int64), 0, rows - 1)
        flat = row * cols + col
        self.moments: dict[tuple[int, int], np.ndarray] = {}
        self.z_moments: dict[tuple[int, int], np.ndarray] = {}
        size = rows * cols
        for i, j in _monomials(2 * degree):
            w = u ** i * v ** j
            self.moments[i, j] = np.bincount(flat, weights=w, minlength=size).reshape(rows, cols)
            if i + j <= degree:
                self.z_moments[i, j] = np.bincount(flat, weights=w * z, minlength=size).reshape(rows, cols)


def fit_surface(sums: PointSums, k: int, *, min_points: int = 3) -> np.ndarray:
    """The local polynomial surface at every node (cell centre): window half size ``k`` cells,
    grown for nodes with fewer than ``min_points`` points; NaN only when there is no point."""
    spec = sums.spec
    rows, cols = spec.shape
    out = np.full((rows, cols), np.nan)
    todo = np.ones((rows, cols), bool)
    count_all = sums.moments[0, 0]
    if not count_all.any():
        return out
    k = max(int(k), 0)
    for growth in range(MAX_GROWTH + 1):
        last = growth == MAX_GROWTH
        count = _box_sum(count_all, k)
        ready = todo & (count >= (1 if last else min_points))
        if ready.any():
            out[ready] = _solve_nodes(sums, k, ready)
            todo &= ~ready
        if not todo.any():
            break
        k = max(2 * k, 1)
    if np.isnan(out).any():
        out = fill_nearest(out, np.isnan(out))
    return out


def _solve_nodes(sums: PointSums, k: int, nodes: np.ndarray) -> np.ndarray:
    """Fitted value at the chosen nodes, each from the window of ``k`` cells around it."""
    rr, cc = np.nonzero(nodes)
    # node position in the same centred cell units as the point sums
    un = cc - sums.u0
    vn = rr - sums.v0
    raw = {key: _box_sum(m, k)[rr, cc] for key, m in sums.moments.items()}
    raw_z = {key: _box_sum(m, k)[rr, cc] for key, m in sums.z_moments.items()}

    def centred(table: dict, a: int, b: int) -> np.ndarray:
        # sum (u - un)^a (v - vn)^b w = sum_i sum_j C(a,i) C(b,j) (-un)^(a-i) (-vn)^(b-j) S_ij
        total = np.zeros(len(rr))
        for i in range(a + 1):
            for j in range(b + 1):
                total += comb(a, i) * comb(b, j) * (-un) ** (a - i) * (-vn) ** (b - j) * table[i, j]
        return total

    if sums.degree == 1:
        return _plane_at_nodes(raw, raw_z, centred)
    terms = _monomials(sums.degree)
    m = len(terms)
    normal = np.empty((len(rr), m, m))
    rhs = np.empty((len(rr), m))
    for p, (a1, b1) in enumerate(terms):
        rhs[:, p] = centred(raw_z, a1, b1)
        for q, (a2, b2) in enumerate(terms[p:], start=p):
            normal[:, p, q] = normal[:, q, p] = centred(raw, a1 + a2, b1 + b2)
    count = normal[:, 0, 0]
    ridge = RIDGE * np.maximum(count, 1.0)
    for p in range(1, m):
        normal[:, p, p] += ridge
    few = count < m  # too few points for every term: their mean (slope terms pinned to zero)
    if few.any():
        normal[few, 0, 1:] = 0.0
        normal[few, 1:, 0] = 0.0
        normal[few, 1:, 1:] = np.eye(m - 1)
        rhs[few, 1:] = 0.0
    coef = np.linalg.solve(normal, rhs[..., None])[..., 0]
    return coef[:, 0]


def _plane_at_nodes(raw: dict, raw_z: dict, centred) -> np.ndarray:
    """The plane's value at each node by Cramer's rule on the 3 x 3 normal equations: no
    stacked matrices (as many nodes as points at 1 m cells), same answer as the general solve."""
    n = centred(raw, 0, 0)
    su, sv = centred(raw, 1, 0), centred(raw, 0, 1)
    ridge = RIDGE * np.maximum(n, 1.0)
    suu = centred(raw, 2, 0) + ridge
    svv = centred(raw, 0, 2) + ridge
    suv = centred(raw, 1, 1)
    sz, suz, svz = centred(raw_z, 0, 0), centred(raw_z, 1, 0), centred(raw_z, 0, 1)
    minor = suu * svv - suv * suv
    det = n * minor - su * (su * svv - suv * sv) + sv * (su * suv - suu * sv)
    num = sz * minor - su * (suz * svv - suv * svz) + sv * (suz * suv - suu * svz)
    with np.errstate(invalid="ignore", divide="ignore"):
        value = num / det
    few = (n < 3) | ~np.isfinite(value)  # too few points for a plane: their mean
    value[few] = sz[few] / np.maximum(n[few], 1e-300)
    return value
