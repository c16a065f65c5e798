"""Ordinary kriging over local neighbourhoods with a variogram fitted to the data.

ALDPAT 1.0 user manual (2007), task 9 "Gridding Tiles": ALDPAT gridded tiles in Surfer, whose default
method is kriging with a linear variogram and no nugget; that is the default here too. Each
node is estimated from its ``max_points`` nearest points (optionally within ``radius``) by
solving the ordinary kriging system in variogram form

    [ G   1 ] [ w  ]   [ g0 ]
    [ 1'  0 ] [ mu ] = [ 1  ]

(``G`` the semivariances between the neighbours, ``g0`` those between the neighbours and the
node). ``drift="linear"`` adds the coordinates as drift terms (universal kriging, Surfer's
"linear drift"), which reproduces planes exactly; ordinary kriging reproduces constants and
honours the data points. The systems of a block of nodes are solved together with one batched
``numpy.linalg.solve``.

The experimental variogram comes from local neighbourhoods: for a fixed random sample of
points, the semivariance ``(z_i - z_j)**2 / 2`` with each of their ``2 * max_points`` nearest
neighbours, binned by distance; the model is fitted to the bins by least squares weighted by
pair counts.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from aldpat._lazy import lazy_import
from aldpat.core.grid_extent import GridSpec
from aldpat.core.grid_nodes import grid_points, node_coordinates, row_blocks, worker_count
from aldpat.core.threads import on_threads
from aldpat.errors import UsageError

optimize = lazy_import("scipy.optimize")
spatial = lazy_import("scipy.spatial")

log = logging.getLogger(__name__)

MODELS = ("linear", "spherical", "exponential")
DRIFTS = ("none", "linear")

#: nodes whose systems are solved together
_BLOCK = 8192
#: the most bytes the systems of one batch of nodes take: their matrices (and the distances,
#: variogram values and the solver's copies beside them) grow as the square of ``max_points``,
#: 2.2 MB a node at 200 neighbours, so a batch of 8,192 would take 18 GB
_BATCH_BYTES = 256 << 20
_SAMPLE = 4000
_LAGS = 16


@dataclass(frozen=True)
class Variogram:
    """``gamma(h) = nugget + sill * shape(h / range)``; for ``linear`` sill is the slope."""

    model: str
    nugget: float
    sill: float
    range: float

    def __call__(self, h: np.ndarray) -> np.ndarray:
        return _model(self.model, np.asarray(h, dtype=np.float64), self.nugget, self.sill, self.range)


def _model(model: str, h: np.ndarray, nugget: float, sill: float, rng: float) -> np.ndarray:
    if model == "linear":
        g = sill * h
    elif model == "spherical":
        r = np.minimum(h / rng, 1.0)
        g = sill * (1.5 * r - 0.5 * r**3)
    elif model == "exponential":
        g = sill * (1.0 - np.exp(-3.0 * h / rng))
    else:
        raise UsageError(f"unknown variogram model {model!r} (use {', '.join(MODELS)})")
    # gamma(0) = 0 exactly: the nugget is a jump just off the origin, data points are honoured.
    return np.where(h > 0, g + nugget, 0.0)


def experimental_variogram(x: ArrayLike, y: ArrayLike, z: ArrayLike, *, neighbours: int = 32, sample: int = _SAMPLE, lags: int = _LAGS,
                           seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lag centres, mean semivariances and pair counts from local neighbourhoods."""
    x, y, z = grid_points(x, y, z)
    ox, oy = float(x.min()), float(y.min())
    tree = spatial.cKDTree(np.column_stack([x - ox, y - oy]))
    rng = np.random.default_rng(seed)
    pick = rng.choice(len(x), size=min(sample, len(x)), replace=False)
    k = min(neighbours + 1, len(x))
    dist, idx = tree.query(np.column_stack([x[pick] - ox, y[pick] - oy]), k=k)
    dist, idx = dist[:, 1:], idx[:, 1:]  # the point itself
    gam = 0.5 * (z[idx] - z[pick][:, None]) ** 2
    d = dist.ravel()
    g = gam.ravel()
    use = d > 0
    d, g = d[use], g[use]
    if d.size == 0:
        return np.array([1.0]), np.array([0.0]), np.array([1])
    top = float(np.quantile(d, 0.95))
    edges = np.linspace(0.0, top, lags + 1)
    which = np.clip(np.digitize(d, edges) - 1, 0, lags - 1)
    counts = np.bincount(which, minlength=lags)
    sums = np.bincount(which, weights=g, minlength=lags)
    dsum = np.bincount(which, weights=d, minlength=lags)
    full = counts > 0
    return dsum[full] / counts[full], sums[full] / counts[full], counts[full]


def fit_variogram(x: ArrayLike, y: ArrayLike, z: ArrayLike, *, model: str = "linear", nugget: float = 0.0, neighbours: int = 32,
                  seed: int = 0) -> Variogram:
    """Fit ``model`` (nugget fixed) to the local experimental variogram."""
    if model not in MODELS:
        raise UsageError(f"unknown variogram model {model!r} (use {', '.join(MODELS)})")
    h, g, n = experimental_variogram(x, y, z, neighbours=neighbours, seed=seed)
    target = np.clip(g - nugget, 0.0, None)
    if model == "linear":
        slope = float(np.sum(n * target * h) / np.sum(n * h * h))
        vg = Variogram("linear", nugget, max(slope, 1e-12), 0.0)
    else:
        span = float(h.max())
        guess = (max(float(target.max()), 1e-12), span)
        try:
            (sill, rng_), _ = optimize.curve_fit(lambda hh, s, a: _model(model, hh, 0.0, s, a), h, target, p0=guess,
                                        sigma=1.0 / np.sqrt(n), bounds=([1e-12, span * 1e-3], [np.inf, span * 100]))
        except (RuntimeError, ValueError):
            sill, rng_ = guess
        vg = Variogram(model, nugget, float(sill), float(rng_))
    log.info("variogram: %s", vg)
    return vg


def _solve(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Batched solve; singular systems (coincident neighbours, collinear ones with drift) get
    the least-squares minimum-norm weights instead."""
    try:
        return np.linalg.solve(a, b[..., None])[..., 0]
    except np.linalg.LinAlgError:
        return (np.linalg.pinv(a) @ b[..., None])[..., 0]


def krige(x: ArrayLike, y: ArrayLike, z: ArrayLike, spec: GridSpec, *, model: str = "linear", nugget: float = 0.0, drift: str = "none",
          max_points: int = 16, radius: float | None = None, max_distance: float | None = None,
          variogram: Variogram | None = None, workers: int | None = None) -> np.ndarray:
    """Kriging of the points onto ``spec``'s nodes (see the module docstring)."""
    if drift not in DRIFTS:
        raise UsageError(f"unknown drift {drift!r} (use {', '.join(DRIFTS)})")
    if max_points < 1:
        raise UsageError(f"max_points must be at least 1, got {max_points}")
    if nugget < 0:
        raise UsageError(f"nugget must not be negative, got {nugget:g}")
    x, y, z = grid_points(x, y, z)
    vg = variogram or fit_variogram(x, y, z, model=model, nugget=nugget, neighbours=2 * max_points)
    origin = (float(x.min()), float(y.min()))
    pts = np.column_stack([x - origin[0], y - origin[1]])
    tree = spatial.cKDTree(pts, balanced_tree=False)
    k = min(max_points, len(x))
    nd = 1 if drift == "none" else 3
    bound = np.inf if radius is None else radius
    out = np.full(spec.shape, np.nan)

    batch = nodes_per_batch(k, nd)

    def run(rows: tuple[int, int]) -> None:
        r0, r1 = rows
        nodes = node_coordinates(spec, r0, r1, origin)
        vals = np.empty(len(nodes))
        for s in range(0, len(nodes), batch):  # each node's system is its own: batches change no value
            part = nodes[s:s + batch]
            dist, idx = tree.query(part, k=[*range(1, k + 1)], distance_upper_bound=bound)
            found = _estimate(part, dist, idx, pts, z, vg, nd)
            if max_distance is not None:
                found[dist[:, 0] > max_distance] = np.nan
            vals[s:s + batch] = found
        out[r0:r1] = vals.reshape(r1 - r0, spec.nx)

    on_threads(run, list(row_blocks(spec, _BLOCK)), worker_count(workers))  # LAPACK and the KD-tree release the GIL
    return out


def nodes_per_batch(k: int, nd: int) -> int:
    """Nodes whose kriging systems (``k`` neighbours, ``nd`` drift terms) are solved together,
    their arrays within :data:`_BATCH_BYTES`: about seven ``(k + nd)``-square float64 arrays a
    node (the pair offsets twice, their distances, the variogram values, the matrix and the
    solver's copy of it)."""
    m = k + nd
    return max(1, min(_BLOCK, _BATCH_BYTES // (7 * 8 * m * m)))


def _estimate(nodes: np.ndarray, dist: np.ndarray, idx: np.ndarray, pts: np.ndarray, z: np.ndarray,
              vg: Variogram, nd: int) -> np.ndarray:
    """Solve the kriging systems of a block of nodes; neighbours missing (beyond the radius)
    get an identity row so that their weight is zero."""
    b_nodes, k = idx.shape
    found = np.isfinite(dist)
    safe = np.where(found, idx, 0)
    # neighbour coordinates relative to their node, scaled for conditioning of the drift terms
    rel = pts[safe] - nodes[:, None, :]
    scale = np.maximum(np.nanmax(np.where(found, dist, np.nan), axis=1, initial=0.0), 1e-12)[:, None]
    dxy = rel[:, :, None, :] - rel[:, None, :, :]
    gmat = vg(np.hypot(dxy[..., 0], dxy[..., 1]))
    g0 = vg(dist.clip(max=np.finfo(float).max) * found)
    m = k + nd
    a = np.zeros((b_nodes, m, m))
    a[:, :k, :k] = gmat
    a[:, :k, k] = 1.0
    a[:, k, :k] = 1.0
    if nd == 3:
        a[:, :k, k + 1] = rel[:, :, 0] / scale
        a[:, :k, k + 2] = rel[:, :, 1] / scale
        a[:, k + 1, :k] = rel[:, :, 0] / scale
        a[:, k + 2, :k] = rel[:, :, 1] / scale
    b = np.zeros((b_nodes, m))
    b[:, :k] = g0
    b[:, k] = 1.0  # drift terms at the node itself are 0 (coordinates relative to it)
    missing = ~found
    if missing.any():
        bi, bj = np.nonzero(missing)
        a[bi, bj, :] = 0.0
        a[bi, :, bj] = 0.0
        a[bi, bj, bj] = 1.0
        b[bi, bj] = 0.0
    weights = _solve(a, b)[:, :k]
    vals = np.sum(weights * np.where(found, z[safe], 0.0), axis=1)
    vals[~found[:, 0]] = np.nan
    if nd == 3:  # a plane needs three neighbours that are not in one line
        vals[found.sum(axis=1) < 3] = np.nan
    return vals
