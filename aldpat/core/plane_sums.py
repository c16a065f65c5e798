"""Local planes at the nodes of a band of rows, compiled (numba): the hot loop of
:mod:`aldpat.core.local_poly` for planes fitted to at most one point per cell.

For every node of the band, the sums over the ``(2k + 1)^2`` window around it of
``w, w u, w v, w u^2, w u v, w v^2, w z, w u z, w v z`` (``w``: 1 where the cell holds a point,
``u, v``: its position in cells, ``z``: its height) are formed by running sums along the rows,
then down the columns, each moment made as its cell is read -- one pass over the cells for all
nine, where a box filter per moment reads and writes every cell eighteen times -- and the
plane's normal equations, moved to the node's own origin by the binomial theorem, are solved by
Cramer's rule, as :func:`aldpat.core.local_poly._plane_at_nodes` does for the general case.
"""

from __future__ import annotations

import numpy as np

from aldpat.core.compiled import compiled


@compiled()
def _row_sums(x: np.ndarray, y: np.ndarray, z: np.ndarray, has: np.ndarray, lo: int, hi: int, k: int, ou: float,
              ov: float, scale: float, h: np.ndarray) -> None:
    """h[r - lo, c, :] = the nine sums over columns c - k .. c + k of row r."""
    cols = x.shape[1]
    for r in range(lo, hi):
        s0 = s1 = s2 = s3 = s4 = s5 = s6 = s7 = s8 = 0.0
        for c in range(-k, cols):
            enter = c + k
            if enter < cols and has[r, enter]:
                u = x[r, enter] * scale - ou
                v = y[r, enter] * scale - ov
                zz = z[r, enter]
                s0 += 1.0
                s1 += u
                s2 += v
                s3 += u * u
                s4 += u * v
                s5 += v * v
                s6 += zz
                s7 += u * zz
                s8 += v * zz
            leave = c - k - 1
            if leave >= 0 and has[r, leave]:
                u = x[r, leave] * scale - ou
                v = y[r, leave] * scale - ov
                zz = z[r, leave]
                s0 -= 1.0
                s1 -= u
                s2 -= v
                s3 -= u * u
                s4 -= u * v
                s5 -= v * v
                s6 -= zz
                s7 -= u * zz
                s8 -= v * zz
            if c >= 0:
                row = h[r - lo, c]
                row[0], row[1], row[2], row[3], row[4] = s0, s1, s2, s3, s4
                row[5], row[6], row[7], row[8] = s5, s6, s7, s8


@compiled(inline="always")
def _plane(s: np.ndarray, un: float, vn: float, ridge_share: float) -> float:
    """The plane's value at the node (un, vn) from the window sums ``s`` (Cramer's rule)."""
    n = np.rint(s[0])  # a count: see local_poly._window_counts
    su = s[1] - un * n
    sv = s[2] - vn * n
    suu = s[3] - 2.0 * un * s[1] + un * un * n
    suv = s[4] - un * s[2] - vn * s[1] + un * vn * n
    svv = s[5] - 2.0 * vn * s[2] + vn * vn * n
    sz = s[6]
    suz = s[7] - un * s[6]
    svz = s[8] - vn * s[6]
    ridge = ridge_share * max(n, 1.0)
    suu += ridge
    svv += ridge
    minor = suu * svv - suv * suv
    det = n * minor - su * (su * svv - suv * sv) + sv * (su * suv - suu * sv)
    num = sz * minor - su * (suz * svv - suv * svz) + sv * (suz * suv - suu * svz)
    value = num / det if det != 0.0 else np.nan
    if n < 3 or not np.isfinite(value):  # too few points for a plane: their mean
        value = sz / max(n, 1e-300)
    return value


@compiled()
def _planes(h: np.ndarray, lo: int, hi: int, r0: int, r1: int, k: int, nodes: np.ndarray, u0: float, v0: float,
            ridge: float, out: np.ndarray) -> None:
    cols = h.shape[1]
    s = np.zeros((cols, 9))
    for r in range(max(r0 - k, lo), min(r0 + k, hi - 1) + 1):  # the window of row r0
        for c in range(cols):
            for m in range(9):
                s[c, m] += h[r - lo, c, m]
    at = 0
    for r in range(r0, r1):
        for c in range(cols):
            if nodes[r, c]:
                out[at] = _plane(s[c], c - u0, r - v0, ridge)
                at += 1
        enter = r + k + 1
        leave = r - k
        for c in range(cols):
            for m in range(9):
                if enter < hi:
                    s[c, m] += h[enter - lo, c, m]
                if leave >= lo:
                    s[c, m] -= h[leave - lo, c, m]


def planes_at_nodes(x: np.ndarray, y: np.ndarray, z: np.ndarray, has: np.ndarray, nodes: np.ndarray, r0: int,
                    r1: int, k: int, ou: float, ov: float, scale: float, u0: float, v0: float, ridge: float
                    ) -> np.ndarray:
    """The plane fitted over the window of ``k`` cells at each node of rows r0 to r1
    (row-major, as ``nodes[r0:r1]`` lists them) to the point ``x, y, z`` of each cell where
    ``has``; a point's position in cells is ``x * scale - ou``, ``y * scale - ov``, that of the
    node of cell (r, c) is (c - u0, r - v0); cells outside the grid count as empty; ``ridge`` times the count
    is added to the slope terms."""
    rows, cols = x.shape
    lo, hi = max(0, r0 - k), min(rows, r1 + k)
    h = np.empty((hi - lo, cols, 9))
    _row_sums(x, y, z, has, lo, hi, k, float(ou), float(ov), float(scale), h)
    out = np.empty(int(nodes[r0:r1].sum()))
    _planes(h, lo, hi, r0, r1, k, nodes, float(u0), float(v0), float(ridge), out)
    return out
