"""Where a terrain model has no data: nodes farther than a gap distance from every point.

A TIN stretches its triangles over any area without ground points -- a lake, a strip gap, a
building's footprint. Under a building there are points (the roof's), none of them ground, and
the TIN's bridge is what a DTM should show; over a lake or a gap between strips there is no point
of any class, and a bridge there is invented terrain. The two are told apart by every point of the
input, whatever its class: a node with no point within ``gap`` of it is blank.

The test is made on the DTM's own lattice: an occupancy grid (a node is occupied when a point lies
in its cell, half a cell either side) is filled chunk by chunk as points are read -- a bit a node,
whatever the point count, since it is held through the whole ground filter -- and a node is in a gap when no occupied node lies within ``gap`` of it
(exact Euclidean distance between node centres, rounded as ``scipy.ndimage.distance_transform_edt``
rounds it; a point lies at most half a cell diagonal from its node's centre).

The default gap is :data:`GAP_SPACINGS` mean point spacings (the spacing from the point count and
the area the points actually cover, :func:`mean_spacing`), and at least :data:`GAP_CELLS` cells.
The peers leave this to the user: LAStools' blast2dem rasterizes every triangle unless ``-kill``
names a longest edge in metres, WhiteboxTools' ``lidar_tin_gridding`` takes an optional
``max_triangle_edge_length``, and lidR's ``rasterize_terrain`` clips the ground TIN to the
convex (by default) or concave hull of the whole point cloud -- every class, as here -- which
blanks the outside of the survey but not a lake inside it. An edge-length test (``max_distance``)
blanks building footprints too; a distance to points of any class does not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from aldpat.core.compiled import compiled
from aldpat.core.grid_extent import GridSpec

#: The default gap in mean point spacings. In points spread at random with that mean spacing s,
#: a disc of radius 5 s is empty with probability exp(-25 pi), i.e. never by chance; scan lines
#: two or three spacings apart, dropouts on dark roofs and the occlusion beside a building (its
#: roof points on one side, ground on the other) stay well inside it.
GAP_SPACINGS = 5.0

#: The least default gap, in DTM cells: at a cell much larger than the spacing, a node whose own
#: cell and its neighbours' are empty is a gap.
GAP_CELLS = 2.0

#: Covered area is counted in blocks of this many mean spacings (from the bounding box): wide
#: enough that a block inside the survey is never empty by chance, narrow enough to see a lake.
COVER_BLOCK_SPACINGS = 3.0


@dataclass
class Occupancy:
    """Which nodes of ``spec`` have a point in their cell, and how many points were added.

    Kept as one bit a node (``bits``, row-major in ``numpy.packbits`` order): a DTM holds it from
    its first reading pass to its gaps, through the ground filter's fullest moments."""

    spec: GridSpec
    bits: np.ndarray = field(init=False)
    count: int = 0

    def __post_init__(self) -> None:
        self.bits = np.zeros(-(-self.spec.nx * self.spec.ny // 8), np.uint8)

    def add(self, x: np.ndarray, y: np.ndarray) -> None:
        """Mark the cells of points ``x``, ``y`` (points outside the lattice are counted, not marked)."""
        s = self.spec
        self.count += len(x)
        _occupy(self.bits, np.ascontiguousarray(x, np.float64), np.ascontiguousarray(y, np.float64), float(s.xmin),
                float(s.ymin), float(s.dx), float(s.dy), int(s.nx), int(s.ny))

    @property
    def cells(self) -> np.ndarray:
        """The occupied nodes as a bool grid of ``spec``'s shape (a new array each time)."""
        return np.unpackbits(self.bits, count=self.spec.nx * self.spec.ny).view(bool).reshape(self.spec.shape)

    def on(self, spec: GridSpec, cells: np.ndarray | None = None, outside: bool = False) -> np.ndarray:
        """``cells`` (default: the occupancy) at the nodes of ``spec``, a window of the same
        lattice (nodes outside this grid are ``outside``)."""
        cells = self.cells if cells is None else cells
        s = self.spec
        c0 = round((spec.xmin - s.xmin) / s.dx)
        r0 = round((spec.ymin - s.ymin) / s.dy)
        out = np.full(spec.shape, outside, bool)
        rs, re = max(r0, 0), min(r0 + spec.ny, s.ny)
        cs, ce = max(c0, 0), min(c0 + spec.nx, s.nx)
        if rs < re and cs < ce:
            out[rs - r0:re - r0, cs - c0:ce - c0] = cells[rs:re, cs:ce]
        return out


@compiled(nogil=True)
def _occupy(bits: np.ndarray, x: np.ndarray, y: np.ndarray, xmin: float, ymin: float, dx: float, dy: float,
            nx: int, ny: int) -> None:  # pragma: no cover - compiled
    """Set the bit of the node whose cell holds each point (``floor((x - xmin) / dx + 0.5)``,
    the same for rows; points off the lattice, NaN ones too, set none), in ``numpy.packbits``
    order: node ``k`` is bit ``0x80 >> (k % 8)`` of byte ``k // 8``. One pass, no scratch."""
    for i in range(len(x)):
        col = np.floor((x[i] - xmin) / dx + 0.5)
        row = np.floor((y[i] - ymin) / dy + 0.5)
        if col >= 0 and col < nx and row >= 0 and row < ny:
            k = int(row) * nx + int(col)
            bits[k >> 3] |= np.uint8(0x80 >> (k & 7))


def mean_spacing(occupancy: Occupancy) -> float | None:
    """The mean point spacing sqrt(covered area / points): the area is that of the blocks of
    :data:`COVER_BLOCK_SPACINGS` spacings (from the bounding box's density) holding a point, so a
    lake or a gap between strips does not thin the estimate. None without points."""
    s = occupancy.spec
    count = occupancy.count
    if count == 0:
        return None
    occupied = occupancy.cells
    rows = np.flatnonzero(occupied.any(axis=1))
    cols = np.flatnonzero(occupied.any(axis=0))
    if len(rows) == 0:
        return None
    box = (rows[-1] - rows[0] + 1) * (cols[-1] - cols[0] + 1) * s.dx * s.dy
    k = max(1, math.ceil(COVER_BLOCK_SPACINGS * math.sqrt(box / count) / s.dx))
    part = occupied[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1]
    ny, nx = -(-part.shape[0] // k), -(-part.shape[1] // k)
    padded = np.zeros((ny * k, nx * k), bool)
    padded[:part.shape[0], :part.shape[1]] = part
    blocks = int(padded.reshape(ny, k, nx, k).any(axis=(1, 3)).sum())
    return math.sqrt(blocks * (k * s.dx) * (k * s.dy) / count)


def default_gap(spacing: float | None, cell: float) -> float:
    """:data:`GAP_SPACINGS` mean spacings, at least :data:`GAP_CELLS` cells."""
    return max(GAP_SPACINGS * (spacing or 0.0), GAP_CELLS * cell)


def gap_nodes(occupied: np.ndarray, gap: float, cell: float) -> np.ndarray:
    """The nodes farther than ``gap`` (metres) from every occupied node of ``occupied`` (all of
    them when none is occupied).

    The distance between nodes ``dr`` rows and ``dc`` columns apart is taken as a Euclidean
    distance transform gives it (``scipy.ndimage.distance_transform_edt`` with ``sampling=cell``:
    ``sqrt((dr cell)^2 + (dc cell)^2)`` in float64, compared in float32), so a node is far
    exactly where the transform says so. It is found without the transform's distances and
    feature indices (33 bytes a node): for each row offset ``dr`` within the gap the widest
    column offset still inside it (:func:`_disc_widths`), then, row by row, every node's column
    distance to the nearest occupied node of each row around it (:func:`_far_rows`) -- a few
    rows of integers held, whatever the DTM's size. A gap wider than the grid's diagonal is the
    grid's diagonal: no node lies farther from another (and the disc stays as large as the grid)."""
    gap = min(gap, math.hypot(*occupied.shape) * cell + cell)
    widths = _disc_widths(gap, cell)
    far = np.empty(occupied.shape, bool)
    if occupied.size:
        _far_rows(np.ascontiguousarray(occupied), widths, far)
    return far


def _disc_widths(gap: float, cell: float) -> np.ndarray:
    """``widths[dr]``: the largest column offset ``dc`` whose node ``dr`` rows away lies within
    ``gap`` (-1: none) -- the distances computed as the transform computes them, so rounding
    decides alike at the disc's edge."""
    limit = np.float32(gap)
    reach = math.floor(gap / cell) + 2  # a node farther than this in rows or columns is out
    offsets = np.arange(reach + 1, dtype=np.float64) * cell
    squares = offsets * offsets
    inside = np.sqrt(squares[:, None] + squares[None, :]).astype(np.float32) <= limit
    widths = np.where(inside.any(axis=1), reach - np.argmax(inside[:, ::-1], axis=1), -1)
    return widths[: int(np.max(np.flatnonzero(widths >= 0), initial=0)) + 1].astype(np.int64)


@compiled(nogil=True)
def _far_rows(occupied: np.ndarray, widths: np.ndarray, far: np.ndarray) -> None:
    """``far[r, c]``: no occupied node at row offset ``dr`` (|dr| < len(widths)) and column offset
    at most ``widths[|dr|]`` from (r, c). Each row's column distance to its nearest occupied node
    is found once, kept in a ring of 2 len(widths) - 1 rows."""
    rows, cols = occupied.shape
    reach = len(widths) - 1
    ring = 2 * reach + 1
    span = np.empty((ring, cols), np.int64)
    none = cols + widths.max() + 1  # a row without an occupied node: farther than any width
    near = np.empty(cols, np.bool_)
    for r in range(-reach, rows):
        if r + reach < rows:  # the row entering the ring: r + reach
            rr = r + reach
            line = span[rr % ring]
            last = -none
            for c in range(cols):
                if occupied[rr, c]:
                    last = c
                line[c] = c - last
            last = cols - 1 + none
            for c in range(cols - 1, -1, -1):
                if occupied[rr, c]:
                    last = c
                line[c] = min(line[c], last - c)
        if r < 0:
            continue
        near[:] = False
        for dr in range(-reach, reach + 1):
            q = r + dr
            if 0 <= q < rows:
                width = widths[abs(dr)]
                line = span[q % ring]
                for c in range(cols):
                    near[c] |= line[c] <= width
        for c in range(cols):
            far[r, c] = not near[c]


def blank_gaps(values: np.ndarray, spec: GridSpec, occupancy: Occupancy, gap: float) -> int:
    """Set to NaN the nodes of ``values`` (on ``spec``, a window of the occupancy's lattice)
    farther than ``gap`` from every point of ``occupancy`` -- the distances taken over the whole
    occupancy grid, so that points beyond the window's edge count; the count of nodes it blanked
    that had a value."""
    # nodes outside the occupancy's grid are far too
    far = occupancy.on(spec, gap_nodes(occupancy.cells, gap, occupancy.spec.dx), outside=True)
    blanked = int((far & ~np.isnan(values)).sum())
    values[far] = np.nan
    return blanked
