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

import math
from collections.abc import Callable
from dataclasses import dataclass
from itertools import pairwise
from typing import Protocol

import numpy as np

from aldpat.core.compiled import PREFETCH_BLOCK, compiled, prefetch_cells
from aldpat.core.height_codes import Decode, Heights
from aldpat.core.lowest_grid import CellGridSpec, fill_nearest
from aldpat.core.memory import release_free_memory
from aldpat.core.rise import compiled_decoding, scale_and_offset
from aldpat.core.threads import on_threads, thread_budget

#: Points tested at once in numpy (bounds temporaries on large inputs).
_CHUNK = 1 << 21
#: Fewer points than this a thread, and the compiled test runs on fewer threads (starting one costs more).
_POINTS_PER_THREAD = 1 << 16
#: Jacobi sweeps at each level of the pyramid on the way back up (more change the result
#: by under 0.01 points of ISPRS error: the coarse levels have already carried the far field).
SWEEPS = 4


#: Rows of the finest level handled at a time (even: a strip pulls into whole coarser rows).
STRIP_ROWS = 128


class CodedCells(Protocol):
    """The lowest height of every cell of a grid, kept as codes (what
    :class:`aldpat.filters.classify.CellHeights` holds)."""

    @property
    def spec(self) -> CellGridSpec: ...
    @property
    def codes(self) -> np.ndarray: ...
    @property
    def heights(self) -> Heights: ...


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
    surface = relaxed_surface(lambda a, b: np.asarray(z[a:b], dtype=np.float64), ground).astype(np.float64)
    surface[ground] = z[ground]  # the ground cells' own heights, to the last digit
    return surface


def relaxed_surface(heights: Callable[[int, int], np.ndarray], ground: np.ndarray, *,
                    codes: tuple[np.ndarray, float, float] | None = None) -> np.ndarray:
    """The pull-push fill of :func:`provisional_surface` as float32 (a tolerance test needs no
    finer than 0.1 mm), ground cells holding their heights rounded to float32;
    ``heights(a, b)`` gives rows ``a:b`` of the heights as float64, ``ground`` is the mask of
    ground cells or any grid whose zero cells are the ground ones (a mark matrix). ``codes``:
    the grid of codes ``heights`` decodes and its scale and offset (``code * scale + offset``),
    read by a compiled loop in its place (the same heights, without their float64 rows).

    The finest level -- all but a third of the pyramid's cells -- is made and relaxed a strip of
    rows at a time (each strip with ``SWEEPS`` rows of margin, the reach of its sweeps), so that
    only the result is held whole: the values are those of relaxing the whole level at once. The
    strips are independent, and are taken on the process's threads at once.
    """
    rows, cols = ground.shape

    def ground_rows(a: int, b: int) -> np.ndarray:
        return ground[a:b] if ground.dtype == bool else ground[a:b] == 0

    def finest(a: int, b: int) -> tuple[np.ndarray, np.ndarray]:
        if codes is not None:
            return _finest_rows(codes[0], ground, ground.dtype == bool, a, min(rows, b), codes[1], codes[2])
        on = ground_rows(a, b)
        return np.where(on, heights(a, b), 0.0).astype(np.float32), on.astype(np.float32)

    everywhere = all(ground_rows(a, a + STRIP_ROWS).all() for a in range(0, rows, STRIP_ROWS))
    if min(rows, cols) <= 2 or everywhere:  # the finest level is the coarsest: relax it whole
        value, weight = finest(0, rows)
        fixed = weight >= 1.0
        return _relax(_seeded(value, fixed), fixed, 4 * SWEEPS)
    value = np.empty(((rows + 1) // 2, (cols + 1) // 2), np.float32)
    weight = np.empty_like(value)

    def pull_strip(a: int) -> None:
        strip_value, strip_weight = _pull(*finest(a, min(rows, a + STRIP_ROWS)))
        value[a // 2:a // 2 + len(strip_value)] = strip_value
        weight[a // 2:a // 2 + len(strip_weight)] = strip_weight

    strips = range(0, rows, STRIP_ROWS)
    on_threads(pull_strip, strips)  # each strip writes its own rows; the compiled steps let go of the lock
    levels = []
    while True:
        levels.append((value, weight))
        if min(value.shape) <= 2 or weight.min() >= 1.0:
            break
        value, weight = _pull(value, weight)
    value = _push_up(levels)
    del levels  # nothing else holds a level now (the pushes' own names went with them)
    release_free_memory()  # the coarser levels' scratch, before the finest level's grid
    out = np.empty((rows, cols), np.float32)

    def relax_strip(a: int) -> None:
        b = min(rows, a + STRIP_ROWS)
        lo, hi = max(0, a - SWEEPS), min(rows, b + SWEEPS)
        fine_value, fine_weight = finest(lo, hi)
        fixed = fine_weight >= 1.0
        out[a:b] = _relax(_spread(value, fine_value, fixed, lo), fixed, SWEEPS)[a - lo:b - lo]

    on_threads(relax_strip, strips)
    return out


@compiled(nogil=True)
def _finest_rows(codes: np.ndarray, ground: np.ndarray, mask: bool, a: int, b: int, scale: float,
                 offset: float) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    """Rows ``a:b`` of the finest level: the ground cells' heights (``code * scale + offset``
    unfused, rounded to float32) and weights 1, every other cell 0 and 0. ``ground`` is the
    mask of the ground cells (``mask``) or a grid whose zero cells are they."""
    cols = codes.shape[1]
    value = np.empty((b - a, cols), np.float32)
    weight = np.empty((b - a, cols), np.float32)
    for i in range(a, b):
        for j in range(cols):
            on = ground[i, j] if mask else ground[i, j] == 0
            if on:
                h = codes[i, j] * scale
                value[i - a, j] = np.float32(h + offset)
                weight[i - a, j] = np.float32(1.0)
            else:
                value[i - a, j] = np.float32(0.0)
                weight[i - a, j] = np.float32(0.0)
    return value, weight


def _push_up(levels: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """The pyramid's ``(value, weight)`` levels, finest first, relaxed from the coarsest up to the
    finest of them (:func:`_push`)."""
    fixed = levels[-1][1] >= 1.0
    value = _relax(_seeded(levels[-1][0], fixed), fixed, 4 * SWEEPS)
    for fine_value, fine_weight in reversed(levels[:-1]):
        value = _push(value, fine_value, fine_weight >= 1.0)
    return value


def _seeded(value: np.ndarray, fixed: np.ndarray) -> np.ndarray:
    """The coarsest level's cells without ground given the value of the nearest cell with ground,
    the start of its sweeps. The pyramid stops at two cells across, so on a long narrow grid (a
    corridor, a strip of a tile, points along one line) that level can still hold long runs
    without ground; sweeps started from 0 there reach a few cells in, and the surface sagged
    towards 0 m between ground cells tens of metres apart (every point above it not ground)."""
    if fixed.all() or not fixed.any():
        return value
    # the exact Euclidean feature transform, ties broken as scipy's distance transform breaks them
    return fill_nearest(value, ~fixed)


def _push(value: np.ndarray, fine_value: np.ndarray, fixed: np.ndarray) -> np.ndarray:
    """One level up: the parent's values spread to their 2 x 2 children, the fixed cells' own
    kept, then ``SWEEPS`` Jacobi sweeps."""
    return _relax(_spread(value, fine_value, fixed, 0), fixed, SWEEPS)


@compiled(nogil=True)
def _spread(value: np.ndarray, fine_value: np.ndarray, fixed: np.ndarray,
            first_row: int) -> np.ndarray:  # pragma: no cover - compiled
    """The finer level's rows ``first_row:`` (as many as ``fine_value`` has): its ``fixed`` cells'
    own values, every other cell its parent's (cell i, j of ``value`` holds 2i..2i+1, 2j..2j+1)."""
    rows, cols = fine_value.shape
    out = np.empty((rows, cols), np.float32)
    for i in range(rows):
        for j in range(cols):
            out[i, j] = fine_value[i, j] if fixed[i, j] else value[(first_row + i) // 2, j // 2]
    return out


@compiled(nogil=True)
def _pull(value: np.ndarray, weight: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    """One level down: weighted means of 2 x 2 blocks, weights summed and capped at 1 (a block
    holding any ground is held at its ground cells' mean). float32, each block summed as
    ``(v00 + v01) + (v10 + v11)`` (in order on a grid one block wide) -- the order of numpy's
    ``sum(axis=(1, 3))`` over the blocks, which this replaces -- cells past an odd edge as 0."""
    rows, cols = value.shape
    pr, pc = (rows + 1) // 2, (cols + 1) // 2
    means = np.empty((pr, pc), np.float32)
    weights = np.empty((pr, pc), np.float32)
    zero = np.float32(0.0)
    for i in range(pr):
        for j in range(pc):
            r, c = 2 * i, 2 * j
            v00 = value[r, c] * weight[r, c]
            w00 = weight[r, c]
            v01 = value[r, c + 1] * weight[r, c + 1] if c + 1 < cols else zero
            w01 = weight[r, c + 1] if c + 1 < cols else zero
            v10 = value[r + 1, c] * weight[r + 1, c] if r + 1 < rows else zero
            w10 = weight[r + 1, c] if r + 1 < rows else zero
            v11 = value[r + 1, c + 1] * weight[r + 1, c + 1] if r + 1 < rows and c + 1 < cols else zero
            w11 = weight[r + 1, c + 1] if r + 1 < rows and c + 1 < cols else zero
            if pc == 1:  # numpy sums a block held in one run of memory in order
                vs = ((v00 + v01) + v10) + v11
                ws = ((w00 + w01) + w10) + w11
            else:
                vs = (v00 + v01) + (v10 + v11)
                ws = (w00 + w01) + (w10 + w11)
            means[i, j] = vs / ws if ws > zero else zero
            weights[i, j] = min(ws, np.float32(1.0))
    return means, weights


@compiled(nogil=True)
def _relax(value: np.ndarray, fixed: np.ndarray, sweeps: int) -> np.ndarray:  # pragma: no cover - compiled
    """Jacobi sweeps of Laplace's equation on the cells not ``fixed`` (edges mirror): each cell
    the float32 ``(((up + down) + left) + right) * 0.25`` of its neighbours before the sweep."""
    rows, cols = value.shape
    now = value.copy()
    after = value.copy()
    quarter = np.float32(0.25)
    for _ in range(sweeps):
        for i in range(rows):
            up, down = max(i - 1, 0), min(i + 1, rows - 1)
            for j in (0, cols - 1):  # the edges, mirrored (once where the grid is one column wide)
                if not fixed[i, j] and (j == 0 or cols > 1):
                    left, right = max(j - 1, 0), min(j + 1, cols - 1)
                    after[i, j] = (((now[up, j] + now[down, j]) + now[i, left]) + now[i, right]) * quarter
            # inside them every cell's mean is worked out and a fixed cell keeps its own (it holds
            # the same value in both grids): a select, which the compiler runs several cells at once
            for j in range(1, cols - 1):
                mean = (((now[up, j] + now[down, j]) + now[i, j - 1]) + now[i, j + 1]) * quarter
                after[i, j] = now[i, j] if fixed[i, j] else mean
        now, after = after, now
    return now


def slope_of(surface: np.ndarray, cell: float) -> np.ndarray:
    """Gradient magnitude of a grid surface (m/m, float32: a tolerance needs no more), central
    differences."""
    out = np.zeros(surface.shape, np.float32)
    if min(surface.shape) >= 2:
        none = np.zeros((1, 1), np.int8)
        _slope_grid(surface, none, none, False, False, 1.0, 0.0, float(cell), out)
    return out


#: Relative distance within which ``sqrt(gx * gx + gy * gy)`` and ``hypot(gx, gy)`` lie (each is
#: within about 2.2e-16 of the true length: three roundings halved by the root, against hypot's
#: one), with a margin for the two products that test it.
_HYPOT_SPREAD = 1e-15


@compiled(nogil=True)
def hypot32(gx: float, gy: float) -> np.float32:  # pragma: no cover - compiled
    """``np.float32(math.hypot(gx, gy))`` at a third of its cost: the root of the squares, unless
    the float32 value is not the same across :data:`_HYPOT_SPREAD` around it (the length lies by a
    float32 rounding boundary), where hypot itself decides. Rounding is monotonic, so when both
    ends of that interval round alike, hypot's value, which lies inside it, rounds to the same."""
    root = math.sqrt(gx * gx + gy * gy)
    low = np.float32(root * (1.0 - _HYPOT_SPREAD))
    if low == np.float32(root * (1.0 + _HYPOT_SPREAD)):
        return low
    return np.float32(math.hypot(gx, gy))


@compiled(nogil=True)
def _height_at(surface: np.ndarray, marks: np.ndarray, codes: np.ndarray, exact: bool, scaled: bool, scale: float,
               offset: float, i: int, j: int) -> float:  # pragma: no cover - compiled
    """The surface at cell (i, j) as float64; with ``exact``, a ground cell's (mark 0) own height
    from its code (``code * scale + offset`` unfused, or the code itself when not ``scaled``)."""
    held = np.float64(surface[i, j])
    if not exact:
        return held
    own = codes[i, j] * scale if scaled else np.float64(codes[i, j])
    own = own + offset if scaled else own
    return own if marks[i, j] == 0 else held  # both worked out: a select, not a branch per cell


@compiled(nogil=True)
def _cell_slope(surface: np.ndarray, marks: np.ndarray, codes: np.ndarray, exact: bool, scaled: bool, scale: float,
                offset: float, cell: float, i: int, j: int) -> np.float32:  # pragma: no cover - compiled
    """``hypot(gx, gy)`` of ``np.gradient`` of the surface (:func:`_height_at`) at cell (i, j),
    rounded to float32: central differences ``(f[k + 1] - f[k - 1]) / (2 * cell)``, one-sided
    ``(f[1] - f[0]) / cell`` at the grid's edges. The grid is at least 2 x 2."""
    rows, cols = surface.shape
    twice = 2.0 * cell
    if i == 0:
        gy = (_height_at(surface, marks, codes, exact, scaled, scale, offset, 1, j)
              - _height_at(surface, marks, codes, exact, scaled, scale, offset, 0, j)) / cell
    elif i == rows - 1:
        gy = (_height_at(surface, marks, codes, exact, scaled, scale, offset, i, j)
              - _height_at(surface, marks, codes, exact, scaled, scale, offset, i - 1, j)) / cell
    else:
        gy = (_height_at(surface, marks, codes, exact, scaled, scale, offset, i + 1, j)
              - _height_at(surface, marks, codes, exact, scaled, scale, offset, i - 1, j)) / twice
    if j == 0:
        gx = (_height_at(surface, marks, codes, exact, scaled, scale, offset, i, 1)
              - _height_at(surface, marks, codes, exact, scaled, scale, offset, i, 0)) / cell
    elif j == cols - 1:
        gx = (_height_at(surface, marks, codes, exact, scaled, scale, offset, i, j)
              - _height_at(surface, marks, codes, exact, scaled, scale, offset, i, j - 1)) / cell
    else:
        gx = (_height_at(surface, marks, codes, exact, scaled, scale, offset, i, j + 1)
              - _height_at(surface, marks, codes, exact, scaled, scale, offset, i, j - 1)) / twice
    return hypot32(gx, gy)


@compiled(nogil=True)
def _slope_grid(surface: np.ndarray, marks: np.ndarray, codes: np.ndarray, exact: bool, scaled: bool, scale: float,
                offset: float, cell: float, out: np.ndarray) -> None:  # pragma: no cover - compiled
    rows, cols = surface.shape
    for i in range(rows):
        for j in range(cols):
            out[i, j] = _cell_slope(surface, marks, codes, exact, scaled, scale, offset, cell, i, j)


@compiled(nogil=True)
def _slopes_at(surface: np.ndarray, marks: np.ndarray, codes: np.ndarray, scaled: bool, scale: float, offset: float,
               cell: float, r: np.ndarray, c: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    out = np.zeros(len(r), np.float32)
    if surface.shape[0] >= 2 and surface.shape[1] >= 2:
        for k in range(len(r)):
            out[k] = _cell_slope(surface, marks, codes, True, scaled, scale, offset, cell, r[k], c[k])
    return out


def bilinear(grid: np.ndarray, spec: CellGridSpec, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``grid`` (values at cell centres) at points x, y, bilinearly; edges held constant."""
    return _blend(lambda r, c: grid[r, c], _corners(grid.shape, spec, x, y))


def _corners(shape: tuple[int, int], spec: CellGridSpec, x: np.ndarray, y: np.ndarray) -> tuple:
    """The four cell centres around each point and its place between them (row, column)."""
    rows, cols = shape
    fc = np.clip((np.asarray(x) - spec.x0) / spec.cell - 0.5, 0.0, cols - 1.0)
    fr = np.clip((np.asarray(y) - spec.y0) / spec.cell - 0.5, 0.0, rows - 1.0)
    c0 = np.minimum(fc.astype(np.int64), max(cols - 2, 0))
    r0 = np.minimum(fr.astype(np.int64), max(rows - 2, 0))
    return r0, np.minimum(r0 + 1, rows - 1), c0, np.minimum(c0 + 1, cols - 1), fr - r0, fc - c0


def _blend(at: Callable[[np.ndarray, np.ndarray], np.ndarray], corners: tuple) -> np.ndarray:
    """Bilinear blend of the values ``at(rows, cols)`` gives at the four corners."""
    r0, r1, c0, c1, tr, tc = corners
    return ((at(r0, c0) * (1 - tc) + at(r0, c1) * tc) * (1 - tr)
            + (at(r1, c0) * (1 - tc) + at(r1, c1) * tc) * tr)


@dataclass
class SurfaceTest:
    """The final test of SMRF against a provisional surface, ready for points in any pieces:
    a point is ground when ``|z - surface| <= threshold + slope_scalar * slope`` at it (a fixed
    tolerance when ``slope_scalar`` is 0). No surface (nothing was ground): no point is.

    The surface is held as float32 (:func:`relaxed_surface`) with, where ``marks`` is given,
    the ground cells' (mark 0) exact heights read from ``heights`` (a grid and a function
    turning rows of it into float64 heights): the values of the float64 surface of
    :func:`provisional_surface` at half its memory. Built over cells (:meth:`build`), its slope
    is taken at the cells a point's tolerance reads, when it reads them (``slope`` None): the
    values of :func:`slope_of` on that surface, without a second grid.
    """

    surface: np.ndarray | None
    slope: np.ndarray | None
    spec: CellGridSpec
    threshold: float
    slope_scalar: float
    marks: np.ndarray | None = None  # ground where 0
    heights: tuple[np.ndarray, Decode] | None = None

    @classmethod
    def build(cls, cells: CodedCells, marks: np.ndarray, *, threshold: float, slope_scalar: float) -> SurfaceTest:
        """The test over the provisional surface of the ground cells (``marks`` 0) of ``cells``
        (:class:`aldpat.filters.classify.CellHeights`: their heights are read from its codes)."""
        if not (marks == 0).any():
            return cls(None, None, cells.spec, threshold, slope_scalar)
        codes, decode = cells.codes, cells.heights.decode
        linear = scale_and_offset(decode)
        surface = relaxed_surface(lambda a, b: decode(codes[a:b]), marks,
                                  codes=None if linear is None else (codes, *linear))
        release_free_memory()  # the pyramid's and the strips' scratch, before the points' pass
        return cls(surface, None, cells.spec, threshold, slope_scalar, marks, (codes, decode))

    @classmethod
    def over(cls, surface: np.ndarray, spec: CellGridSpec, *, threshold: float, slope_scalar: float) -> SurfaceTest:
        """The test over a given surface grid."""
        slope = slope_of(surface, spec.cell) if slope_scalar else None
        return cls(surface, slope, spec, threshold, slope_scalar)

    def _at(self, r: np.ndarray, c: np.ndarray) -> np.ndarray:
        assert self.surface is not None
        flat = r * self.surface.shape[1]
        flat += c
        values = self.surface.ravel().take(flat).astype(np.float64)
        if self.marks is not None and self.heights is not None:
            codes, decode = self.heights
            exact = self.marks.ravel().take(flat) == 0
            values[exact] = decode(codes.ravel().take(flat[exact]))
        return values

    def _slopes(self, r: np.ndarray, c: np.ndarray) -> np.ndarray:
        """The slope (float32) at cells ``r, c``: held, or taken from the surface and the ground
        cells' exact heights (:func:`slope_of` of the surface :meth:`_at` reads)."""
        assert self.surface is not None
        if self.slope is not None:
            return self.slope.ravel().take(r * self.slope.shape[1] + c)
        assert self.marks is not None and self.heights is not None
        codes, decode = self.heights
        scaled, scale, offset = compiled_decoding(decode)
        return _slopes_at(self.surface, self.marks, codes, scaled, scale, offset, float(self.spec.cell),
                          np.ascontiguousarray(r), np.ascontiguousarray(c))

    def test(self, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
        """Which points are ground. Built over cells (:meth:`build`): one compiled loop over the
        points (:func:`_test_points`), split among the process's threads; over a given surface, the
        numpy form (:meth:`test_in_numpy`). Both give the same answer to the bit."""
        if self.surface is None:
            return np.zeros(len(z), bool)
        if self.slope is not None or self.marks is None or self.heights is None:
            return self.test_in_numpy(x, y, z)
        codes, decode = self.heights
        scaled, scale, offset = compiled_decoding(decode)
        out = np.empty(len(z), bool)
        x, y, z = (np.ascontiguousarray(v, dtype=np.float64) for v in (x, y, z))

        def run(piece: tuple[int, int]) -> None:
            a, b = piece
            _test_points(self.surface, self.marks, codes, scaled, scale, offset, float(self.spec.cell), float(self.spec.x0), float(self.spec.y0),
                         float(self.threshold), float(self.slope_scalar), x[a:b], y[a:b], z[a:b], out[a:b])

        pieces = min(thread_budget(), max(1, len(z) // _POINTS_PER_THREAD))
        bounds = np.linspace(0, len(z), pieces + 1).astype(np.int64).tolist()
        on_threads(run, list(pairwise(bounds)), pieces)  # the compiled loop releases the GIL
        return out

    def test_in_numpy(self, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
        """:meth:`test` in numpy, a block of points at a time: the form for a given surface and
        slope grid, and the reference the compiled loop is held to."""
        out = np.zeros(len(z), bool)
        if self.surface is None:
            return out
        for a in range(0, len(z), _CHUNK):
            b = min(len(z), a + _CHUNK)
            corners = _corners(self.surface.shape, self.spec, x[a:b], y[a:b])  # once for both grids
            h = np.abs(z[a:b] - _blend(self._at, corners))
            tolerance = self.threshold if not self.slope_scalar else (
                self.threshold + self.slope_scalar * _blend(self._slopes, corners))
            out[a:b] = h <= tolerance
        return out


@compiled(nogil=True)
def _test_points(surface: np.ndarray, marks: np.ndarray, codes: np.ndarray, scaled: bool, scale: float,
                 offset: float, cell: float, x0: float, y0: float, threshold: float, slope_scalar: float,
                 x: np.ndarray, y: np.ndarray, z: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover
    """:meth:`SurfaceTest.test_in_numpy` point by point, its operations in its order: the four
    cell centres around a point (:func:`_corners`), the surface's and the slope's bilinear blends
    (:func:`_blend` of :func:`_height_at` and of :func:`_cell_slope`'s float32 slopes, widened),
    ``|z - surface| <= threshold + slope_scalar * slope``. The heights a point's four slopes read
    -- the 4 x 4 cells around its corners, less theirs -- are read once into ``patch``, and only for
    a point the threshold alone does not take. The cells of each block of points are asked for
    while the block before is tested (:func:`aldpat.core.compiled.prefetch_cells`)."""
    rows, cols = surface.shape
    last_c, last_r = max(cols - 2, 0), max(rows - 2, 0)
    sloped = slope_scalar != 0.0 and rows >= 2 and cols >= 2
    patch = np.zeros((4, 4))  # rows r0 - 1 .. r0 + 2, columns c0 - 1 .. c0 + 2
    n = len(z)
    grids = (surface, marks, codes)
    prefetch_cells(grids, x, y, 0, min(n, PREFETCH_BLOCK), x0, y0, cell)
    for first in range(0, n, PREFETCH_BLOCK):
        stop = min(n, first + PREFETCH_BLOCK)
        prefetch_cells(grids, x, y, stop, min(n, stop + PREFETCH_BLOCK), x0, y0, cell)
        for k in range(first, stop):
            fc = min(max((x[k] - x0) / cell - 0.5, 0.0), cols - 1.0)
            fr = min(max((y[k] - y0) / cell - 0.5, 0.0), rows - 1.0)
            c0 = min(np.int64(fc), last_c)
            r0 = min(np.int64(fr), last_r)
            c1, r1 = min(c0 + 1, cols - 1), min(r0 + 1, rows - 1)
            tc, tr = fc - c0, fr - r0
            h00 = _height_at(surface, marks, codes, True, scaled, scale, offset, r0, c0)
            h01 = _height_at(surface, marks, codes, True, scaled, scale, offset, r0, c1)
            h10 = _height_at(surface, marks, codes, True, scaled, scale, offset, r1, c0)
            h11 = _height_at(surface, marks, codes, True, scaled, scale, offset, r1, c1)
            at = (h00 * (1 - tc) + h01 * tc) * (1 - tr) + (h10 * (1 - tc) + h11 * tc) * tr
            off = abs(z[k] - at)
            tolerance = threshold
            if slope_scalar > 0.0 and off <= threshold:
                # the slope term only widens the tolerance (a positive scalar times a blend of slopes,
                # none negative, with weights none negative): within the threshold, ground whatever it is
                out[k] = True
                continue
            if slope_scalar != 0.0:
                s00 = s01 = s10 = s11 = 0.0
                if sloped:  # r1 = r0 + 1 and c1 = c0 + 1 here
                    patch[1, 1], patch[1, 2], patch[2, 1], patch[2, 2] = h00, h01, h10, h11
                    for a in range(4):
                        i = r0 - 1 + a
                        for b in range(4):
                            j = c0 - 1 + b
                            if (a == 0 or a == 3) == (b == 0 or b == 3) or i < 0 or j < 0 or i >= rows or j >= cols:
                                continue  # a corner of the patch, a corner cell (read above), or off the grid
                            patch[a, b] = _height_at(surface, marks, codes, True, scaled, scale, offset, i, j)
                    s00 = np.float64(_patch_slope(patch, 1, 1, r0, c0, rows, cols, cell))
                    s01 = np.float64(_patch_slope(patch, 1, 2, r0, c1, rows, cols, cell))
                    s10 = np.float64(_patch_slope(patch, 2, 1, r1, c0, rows, cols, cell))
                    s11 = np.float64(_patch_slope(patch, 2, 2, r1, c1, rows, cols, cell))
                tolerance = threshold + slope_scalar * ((s00 * (1 - tc) + s01 * tc) * (1 - tr)
                                                        + (s10 * (1 - tc) + s11 * tc) * tr)
            out[k] = off <= tolerance


@compiled(nogil=True)
def _patch_slope(patch: np.ndarray, a: int, b: int, i: int, j: int, rows: int, cols: int,
                 cell: float) -> np.float32:  # pragma: no cover - compiled
    """:func:`_cell_slope` at cell (i, j), held at (a, b) of a patch of the heights around it."""
    twice = 2.0 * cell
    if i == 0:
        gy = (patch[a + 1, b] - patch[a, b]) / cell
    elif i == rows - 1:
        gy = (patch[a, b] - patch[a - 1, b]) / cell
    else:
        gy = (patch[a + 1, b] - patch[a - 1, b]) / twice
    if j == 0:
        gx = (patch[a, b + 1] - patch[a, b]) / cell
    elif j == cols - 1:
        gx = (patch[a, b] - patch[a, b - 1]) / cell
    else:
        gx = (patch[a, b + 1] - patch[a, b - 1]) / twice
    return hypot32(gx, gy)


def within_surface(x: np.ndarray, y: np.ndarray, z: np.ndarray, surface: np.ndarray, spec: CellGridSpec, *,
                   threshold: float, slope_scalar: float) -> np.ndarray:
    """True where ``|z - surface| <= threshold + slope_scalar * slope`` at the point (a fixed
    tolerance when ``slope_scalar`` is 0)."""
    return SurfaceTest.over(surface, spec, threshold=threshold, slope_scalar=slope_scalar).test(x, y, z)
