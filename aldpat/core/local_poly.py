"""Local polynomial surfaces on a grid of nodes, fitted to a set of points by least squares.

Used by the iterative polynomial filters (ALDPAT manual, Appendix "Iterative Polynomial Fitting
(IPF) Filter" and the polynomial two-surface filter, Figs. 14-15): at every node of the grid a
polynomial of degree 1 (a plane) or 2 is fitted to the points in a square window of
``(2k + 1)`` cells centred on the node, and the surface at the node is the polynomial's value
there.

Vectorised over nodes: the sums ``sum u^i v^j`` and ``sum z u^i v^j`` of the points (``u``,
``v``: position in cells) are accumulated per cell, summed over every window by a box filter,
and moved to each node's own origin by the binomial theorem, one band of rows at a time; each
node's normal equations are then solved at once for the band (Cramer's rule for planes, one
batched solve for quadratics). Nodes whose window holds fewer than ``min_points``
points take a window twice as wide, then four times ... (up to ``MAX_GROWTH`` doublings); a node
still short of points takes the nearest fitted node's value.
"""

from __future__ import annotations

from collections.abc import Callable
from math import comb

import numpy as np

from aldpat._lazy import lazy_import
from aldpat.core.lowest_grid import CellGridSpec, fill_nearest
from aldpat.core.morphology import within

ndimage = lazy_import("scipy.ndimage")
plane_sums = lazy_import("aldpat.core.plane_sums")

#: Nodes solved per band of rows (bounds the window sums held at once).
BAND_CELLS = 1 << 20
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
    size = 2 * within(k, a.shape) + 1
    return ndimage.uniform_filter(a, size=size, mode="constant", cval=0.0) * (size * size)


def _window_counts(count: np.ndarray, k: int) -> np.ndarray:
    """Points in the window around every cell, as whole numbers. The box filter's running sums
    leave roundoff that depends on where the grid starts (3 points read as 2.9999999996 in one
    grid and 3.0000000002 in a grid cut from it): every test of a count against a threshold would
    then depend on the grid's extent, and a file filtered in chunks would not match the whole."""
    return np.rint(_box_sum(count, k))


class PointSums:
    """Sums of the powers of a point set's position (in cells) per cell, ready to fit.

    Built from any points (``PointSums(spec, x, y, z, degree)``: every sum held as a grid), or
    from at most one point per cell (:meth:`one_per_cell`: the points' grids are held and the
    sums of a band of rows are formed when it is solved -- four grids instead of nine).
    """

    def __init__(self, spec: CellGridSpec, x: np.ndarray, y: np.ndarray, z: np.ndarray, degree: int):
        self._start(spec, degree)
        rows, cols = spec.shape
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
        self._cells: tuple[np.ndarray, ...] | None = None

    def _start(self, spec: CellGridSpec, degree: int) -> None:
        if degree not in (1, 2):
            raise ValueError(f"degree must be 1 or 2, got {degree}")
        self.spec = spec
        self.degree = degree
        rows, cols = spec.shape
        # position in cells about the grid's centre: keeps the powers small for the binomial shift
        self.u0, self.v0 = cols / 2.0, rows / 2.0

    @classmethod
    def one_per_cell(cls, spec: CellGridSpec, x: np.ndarray, y: np.ndarray, z: np.ndarray, has: np.ndarray,
                     degree: int) -> PointSums:
        """Sums of the points ``x[r, c], y[r, c], z[r, c]`` of the cells where ``has``."""
        self = cls.__new__(cls)
        self._start(spec, degree)
        self._cells = (x, y, z, has)  # held as given: positions in cells are made a band at a time
        return self

    def _positions(self, x: np.ndarray, y: np.ndarray, z: np.ndarray, has: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Position in cells about the grid's centre, height and weight of cells (zero where empty)."""
        spec = self.spec
        u = np.where(has, (x - spec.x0) / spec.cell - 0.5 - self.u0, 0.0)
        v = np.where(has, (y - spec.y0) / spec.cell - 0.5 - self.v0, 0.0)
        return u, v, np.where(has, z, 0.0), has.astype(np.float64)

    def position_map(self) -> tuple[float, float, float]:
        """(scale, ou, ov): the position in cells of :meth:`_positions` as ``x * scale - ou``,
        ``y * scale - ov``, for code that forms it point by point."""
        spec = self.spec
        return 1.0 / spec.cell, spec.x0 / spec.cell + 0.5 + self.u0, spec.y0 / spec.cell + 0.5 + self.v0

    def count(self) -> np.ndarray:
        """Points per cell."""
        return self._cells[3].astype(np.float64) if self._cells is not None else self.moments[0, 0]

    def band(self, lo: int, hi: int) -> tuple[dict, dict]:
        """The sums of rows lo to hi: powers of position, and the same times z."""
        if self._cells is None:
            return ({key: m[lo:hi] for key, m in self.moments.items()},
                    {key: m[lo:hi] for key, m in self.z_moments.items()})
        u, v, z, w = self._positions(*(a[lo:hi] for a in self._cells))
        moments, z_moments = {}, {}
        for i, j in _monomials(2 * self.degree):
            t = w * u ** i * v ** j
            moments[i, j] = t
            if i + j <= self.degree:
                z_moments[i, j] = t * z
        return moments, z_moments


def fit_surface(sums: PointSums, k: int, *, min_points: int = 3) -> np.ndarray:
    """The local polynomial surface at every node (cell centre): window half size ``k`` cells,
    grown for nodes with fewer than ``min_points`` points; NaN only when there is no point."""
    spec = sums.spec
    rows, cols = spec.shape
    out = np.full((rows, cols), np.nan)
    todo = np.ones((rows, cols), bool)
    count_all = sums.count()
    if not count_all.any():
        return out
    k = max(int(k), 0)
    # in bands of rows, so that the window sums of every moment are held for a band only
    band = max(64, BAND_CELLS // max(cols, 1))
    for growth in range(MAX_GROWTH + 1):
        last = growth == MAX_GROWTH
        count = _window_counts(count_all, k)
        ready = todo & (count >= (1 if last else min_points))
        for r0 in range(0, rows, band):
            r1 = min(rows, r0 + band)
            if ready[r0:r1].any():
                out[r0:r1][ready[r0:r1]] = _solve_nodes(sums, k, ready, r0, r1)
        todo &= ~ready
        if not todo.any():
            break
        k = max(2 * k, 1)
    if np.isnan(out).any():
        out = fill_nearest(out, np.isnan(out))
    return out


def _solve_nodes(sums: PointSums, k: int, nodes: np.ndarray, r0: int, r1: int) -> np.ndarray:
    """Fitted value at the chosen nodes of rows r0 to r1, each from the window of ``k`` cells
    around it (row-major order, as ``nodes[r0:r1]`` lists them)."""
    k = within(k, nodes.shape)
    if sums.degree == 1 and sums._cells is not None:
        # planes on one point per cell (ipf, poly2 as shipped): sums and solve in one compiled pass
        scale, ou, ov = sums.position_map()
        return plane_sums.planes_at_nodes(*sums._cells, nodes, r0, r1, k, ou, ov, scale, sums.u0, sums.v0, RIDGE)
    rows = nodes.shape[0]
    lo, hi = max(0, r0 - k), min(rows, r1 + k)  # the rows the band's windows reach
    rr, cc = np.nonzero(nodes[r0:r1])
    at = rr + (r0 - lo)
    # node position in the same centred cell units as the point sums
    un = cc - sums.u0
    vn = rr + r0 - sums.v0
    moments, z_moments = sums.band(lo, hi)
    raw = {key: _box_sum(m, k)[at, cc] for key, m in moments.items()}
    raw[0, 0] = np.rint(raw[0, 0])  # the points in each window, a count (see _window_counts)
    raw_z = {key: _box_sum(m, k)[at, cc] for key, m in z_moments.items()}
    del moments, z_moments

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


def _plane_at_nodes(raw: dict, raw_z: dict, centred: Callable[[dict, int, int], np.ndarray]) -> np.ndarray:
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
