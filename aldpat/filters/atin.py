"""Adaptive TIN densification (``atin``).

ALDPAT 1.0 user manual (2007), task 8 "Adaptive TIN (ATIN)" for the parameters (Cell Size, Z Difference,
Angle Threshold, Init TriGrid Size, Tile X Width, Tile Y Height, Tile Buffer) and Appendix
"Adaptive TIN (ATIN) Filter" (Fig. 16), after Axelsson (2000):

1. the lowest point of each cell of ``cell`` is a candidate (the manual's parsing grid), but
   for cells of a raised segment of that grid (:mod:`aldpat.core.segments`, ``object_step``):
   objects larger than the seed squares, whose points are non-ground;
2. the lowest candidate of each square of ``init_trigrid_size`` -- larger than the largest
   object -- is a seed; the seeds are triangulated (Delaunay);
3. a candidate is added to the ground set when its distance to the plane of the triangle below
   it is under ``z_difference`` and, when ``angle_threshold`` > 0, the largest of the angles
   between that plane and the lines from the candidate to the triangle's three vertices is under
   ``angle_threshold`` (a vertex nearer than ``angle_min_distance`` counted at that distance); a
   candidate failing the test is also added when its *mirror point* -- the candidate reflected
   through the triangle's vertex nearest to it (in x, y and z) -- lies within ``z_difference``
   (in height) of the triangle below the mirror point (steep terrain, Fig. 16): a point level
   with a ground vertex at the top of a cliff mirrors onto the plateau behind that vertex. Only
   candidates within ``z_difference`` of their nearest vertex's height are mirrored (the manual
   does not say which are; mirroring every candidate lets roofs in through any triangle spanning
   a slope at the right height);
4. the TIN is rebuilt from the ground set and step 3 repeated until no candidate is added.

The TIN of step 4 is not built anew: the points a round adds are inserted into it (Lawson's
incremental Delaunay insertion, :mod:`aldpat.core.delaunay`), and a candidate that failed is
tested again only when the triangle below it or below its mirror point has changed
(:mod:`aldpat.filters.atin_densify`); the classes are those of a TIN rebuilt every round.

The data are processed in rectangles of ``tile_x_width`` x ``tile_y_height`` (the manual's
sub-rectangles), each with ``tile_buffer`` of its surroundings, so time and memory stay bounded
on any file; only the points inside the rectangle are classified from each run. Seed squares
are aligned to whole multiples of ``init_trigrid_size``, so every rectangle starts from the same
seeds; with a buffer of a few seed squares the classes do not depend on the rectangle size.

Choices where the manual is silent:

* by default every candidate that passes is added in the same round; Axelsson adds only the
  best point of each triangle per round (``best_per_triangle``, an option);
* the angle test measures the angle to a vertex nearer than ``angle_min_distance`` as if the
  vertex were that far: on dense data a candidate a few decimetres from a vertex makes a large
  angle with a few centimetres of noise, and would be dropped whatever the terrain;
* step 1's raised segments: the manual asks for seed squares larger than the largest object,
  but one size does not fit every site -- a square that lies wholly on a station roof or a
  platform canopy seeds the roof, and the TIN grows over it round after round (mirror points
  pass along any flat roof level with a vertex on it). The segment test the grid filters use
  finds such objects whatever their size. Its share stays at 0.6 (a share of 0.4 takes the plateau
  of a synthetic cliff, whose jagged edge is all down-steps, for a roof);
* the defaults (z difference 0.75 m, angle 15 degrees taken at 1.5 m at least, 30 m seed
  squares, every passing point, segments split at steps of 1.5 m) are the setting best on the
  seven ISPRS samples of bench/README.md among those tried there, and the one five of the seven
  leave-one-out folds choose;
* the TIN's corners are held by four virtual points at the corners of the buffered rectangle,
  each at the height of the ground point nearest to it in that round, so candidates outside the
  ground set's hull have a triangle too; virtual points are never output;
* a point that is not the lowest of its cell is ground when it passes the same distance and
  angle test against the final TIN (nothing is added for it).

Marks: 0 ground, 1 non-ground.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from aldpat._lazy import lazy_import
from aldpat.core.grid_extent import steps_between
from aldpat.core.lowest_grid import LowestGrid, fill_nearest, lowest_grid
from aldpat.core.tiles import MOST_COPIES, copies_with_buffer, least_square_for
from aldpat.errors import DataError, ParamError
from aldpat.filters.grid_stage import raised_cells
from aldpat.filters.marks import MARK_GROUND, MARK_NON_GROUND
from aldpat.filters.options import PointFilterParams, RaisedSegmentOption
from aldpat.filters.registry import register_filter
from aldpat.params import default_of, param

tin_densify = lazy_import("aldpat.filters.atin_densify")

log = logging.getLogger(__name__)

#: Rounds of densification at most (each adds every passing candidate; a round adding nothing ends).
MAX_ROUNDS = 50


@dataclass(frozen=True)
class AtinParams(RaisedSegmentOption, PointFilterParams):
    cell: float = param(1.0, "parsing grid: the lowest point of each cell is a candidate", unit="m",
                             gt=0, manual="Cell Size")
    z_difference: float = param(0.75, "a candidate closer than this to the plane of the triangle below it "
                                     "is added", unit="m", gt=0, manual="Z difference", level="internal")
    angle_threshold: float = param(15.0, "largest angle between the triangle and the lines to its vertices "
                                        "(0: no angle test)", unit="degrees", ge=0, le=90,
                                   manual="Angle Threshold", level="internal")
    angle_min_distance: float = param(1.5, "the angle test takes a vertex nearer than this as if it were this "
                                           "far (on short edges a little noise is a large angle)", unit="m",
                                      ge=0, level="internal")
    init_trigrid_size: float = param(30.0, "seed squares: the lowest point of each is a seed; larger than "
                                           "the largest object", unit="m", gt=0, manual="Init TriGrid Size",
                                           level="internal")
    tile_x_width: float = param(1000.0, "width of the rectangles processed one at a time", unit="m", gt=0,
                                manual="Tile X Width", level="advanced")
    tile_y_height: float = param(1000.0, "height of the rectangles processed one at a time", unit="m", gt=0,
                                 manual="Tile Y Height", level="advanced")
    tile_buffer: float = param(100.0, "surroundings added to each rectangle so its edge points see the "
                                     "same TIN", unit="m", ge=0, manual="Tile Buffer", level="advanced")
    best_per_triangle: bool = param(
        False, "each round adds only the passing point nearest its triangle in each triangle "
              "(Axelsson); off: every passing point at once", level="internal")
    mirror: bool = param(True, "also add a candidate whose mirror point through the nearest vertex "
                               "passes (steep terrain, manual Fig. 16)", level="internal")

    object_step: float = default_of(RaisedSegmentOption, "object_step", 1.5)

    def check(self) -> None:
        super().check()
        # every rectangle triangulates its buffer's candidates again: rectangles of 1 m with the
        # default 100 m buffer triangulated each candidate 40,401 times (7,492 points: 27 s)
        copies = copies_with_buffer(self.tile_x_width, self.tile_y_height, self.tile_buffer)
        if not copies <= MOST_COPIES:
            raise ParamError(f"tile_buffer: rectangles of {self.tile_x_width:g} x {self.tile_y_height:g} m with a "
                             f"{self.tile_buffer:g} m buffer triangulate each point {copies:,.0f} times (at most "
                             f"{MOST_COPIES}); use a --tile-x-width and --tile-y-height of at least "
                             f"{least_square_for(self.tile_buffer):.4g} m or a smaller --tile-buffer")

    def cell_shape(self) -> tuple[float, float]:
        return self.cell, self.cell


def _seeds(x: np.ndarray, y: np.ndarray, z: np.ndarray, size: float) -> np.ndarray:
    """Flags of the lowest point of each ``size`` square (squares aligned to multiples of size)."""
    g = lowest_grid(x, y, z, size)
    flags = np.zeros(len(z), bool)
    flags[g.lowest[~g.empty]] = True
    return flags


class _Buckets:
    """Indices of points grouped by the rectangle of ``w`` x ``h`` (aligned to whole multiples)
    they fall in, so that each rectangle and its buffer are gathered without scanning every point."""

    def __init__(self, x: np.ndarray, y: np.ndarray, w: float, h: float, c0: int, r0: int, cols: int,
                 rows: int):
        col = np.clip(np.floor(x / w).astype(np.int64) - c0, 0, cols - 1)
        row = np.clip(np.floor(y / h).astype(np.int64) - r0, 0, rows - 1)
        key = row * cols + col
        self.order = np.argsort(key, kind="stable")
        self.starts = np.searchsorted(key[self.order], np.arange(rows * cols + 1))
        self.cols, self.rows = cols, rows

    def take(self, r_lo: int, r_hi: int, c_lo: int, c_hi: int) -> np.ndarray:
        """Points of rectangles rows r_lo..r_hi, columns c_lo..c_hi (clipped to the grid)."""
        parts = []
        for r in range(max(r_lo, 0), min(r_hi, self.rows - 1) + 1):
            a = self.starts[r * self.cols + max(c_lo, 0)]
            b = self.starts[r * self.cols + min(c_hi, self.cols - 1) + 1]
            parts.append(self.order[a:b])
        return np.concatenate(parts) if parts else np.zeros(0, np.int64)


#: the most rectangles the data are cut into (each a triangulation of its own): a million
#: rectangles of the default 1 km cover a continent
MOST_RECTANGLES = 1_000_000


def atin_buffer(params: AtinParams) -> float:
    """A chunk's buffer: the manual's own Tile Buffer, the surroundings each rectangle is filtered
    with (ground spreads from the seeds round after round, so no buffer is exact)."""
    return params.tile_buffer


@register_filter("atin", params=AtinParams, on_points=True, buffer=atin_buffer,
                 summary="adaptive TIN densification (manual appendix ATIN; Axelsson 2000)")
def atin(x: np.ndarray, y: np.ndarray, z: np.ndarray, grid: LowestGrid, params: AtinParams) -> np.ndarray:
    """Point marks of the adaptive TIN filter (manual appendix ATIN, Fig. 16); ``grid`` holds the
    lowest point of each ``cell`` (the candidates)."""
    p = params
    in_object = np.zeros(len(z), bool)
    if p.object_step > 0 and len(z):
        # the plain share of each segment's steps: following a building's levels inwards, or the
        # points' spacing, scored no better here (bench/README.md)
        raised = raised_cells(fill_nearest(grid.z, grid.empty), p, p.cell_shape()[0], levels=False)
        in_object = raised.ravel()[grid.cell_index]
        del raised
    cand = grid.lowest[~grid.empty]
    cand = cand[~in_object[cand]]
    cand = cand[np.argsort(grid.cell_index[cand], kind="stable")]  # row-major: each walk to a triangle starts near it
    cx, cy, cz = x[cand], y[cand], z[cand]
    is_cand = np.zeros(len(z), bool)
    is_cand[cand] = True
    others = np.flatnonzero(~is_cand & ~in_object)
    marks = np.full(len(z), MARK_NON_GROUND, np.int32)
    ground = np.zeros(len(cz), bool)  # one rectangle's ground candidates at a time
    if len(cand) == 0:
        return marks
    w, h, buf = p.tile_x_width, p.tile_y_height, p.tile_buffer
    c0 = math.floor(steps_between(0.0, float(x.min()), w, "x"))
    r0 = math.floor(steps_between(0.0, float(y.min()), h, "y"))
    cols = math.floor(steps_between(0.0, float(x.max()), w, "x")) - c0 + 1
    rows = math.floor(steps_between(0.0, float(y.max()), h, "y")) - r0 + 1
    if rows * cols > MOST_RECTANGLES:
        raise DataError(f"rectangles of {w:g} x {h:g} m cut the data into {rows * cols:,} (at most "
                        f"{MOST_RECTANGLES:,}); use a larger --tile-x-width and --tile-y-height")
    cand_buckets = _Buckets(cx, cy, w, h, c0, r0, cols, rows)
    other_buckets = _Buckets(x[others], y[others], w, h, c0, r0, cols, rows)
    kx, ky = math.ceil(buf / w), math.ceil(buf / h)
    for r in range(rows):
        for c in range(cols):
            rx0, ry0 = (c0 + c) * w, (r0 + r) * h
            rx1, ry1 = rx0 + w, ry0 + h
            inner_c = cand_buckets.take(r, r, c, c)
            if len(inner_c) == 0:
                continue
            near = cand_buckets.take(r - ky, r + ky, c - kx, c + kx)
            near = np.sort(near)  # back to row-major cell order
            keep = (cx[near] >= rx0 - buf) & (cx[near] < rx1 + buf) & (cy[near] >= ry0 - buf) & (cy[near] < ry1 + buf)
            sel = near[keep]
            ox, oy = rx0 - buf, ry0 - buf  # local coordinates: the tests keep their precision
            g, tin = tin_densify.densify(
                cx[sel] - ox, cy[sel] - oy, cz[sel], _seeds(cx[sel], cy[sel], cz[sel], p.init_trigrid_size),
                (0.0, 0.0, rx1 + buf - ox, ry1 + buf - oy), p.z_difference, p.angle_threshold,
                p.angle_min_distance, p.mirror, p.best_per_triangle, MAX_ROUNDS)
            ground[sel[g]] = True
            marks[cand[inner_c]] = np.where(ground[inner_c], MARK_GROUND, MARK_NON_GROUND)
            ground[sel] = False
            mine = others[other_buckets.take(r, r, c, c)]
            if len(mine):
                mine = mine[np.argsort(grid.cell_index[mine], kind="stable")]  # row-major: short walks
                ok = tin_densify.passes(tin, x[mine] - ox, y[mine] - oy, z[mine], p.z_difference,
                                        p.angle_threshold, p.angle_min_distance, p.mirror)
                marks[mine[ok]] = MARK_GROUND
    log.debug("atin: %d of %d points ground", int((marks == 0).sum()), len(z))
    return marks
