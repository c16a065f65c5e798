"""What every ground filter takes: the options shared by all filters (what ``aldpat filter`` writes,
the low-outlier test, the raised-segment test) and the two parameter bases, :class:`GroundParams`
for the grid filters and :class:`PointFilterParams` for the point filters; each filter's params
class subclasses one of them.
"""

from __future__ import annotations

import dataclasses
import itertools
from dataclasses import dataclass
from typing import TYPE_CHECKING, Self

from aldpat.errors import ParamError, shown
from aldpat.filters.survey import ExistingClassesOption
from aldpat.options import ChunkOption, CrsOption, OriginOption
from aldpat.params import Checked, SharedOption, param


@dataclass(frozen=True)
class FilterOutputOption(SharedOption):
    """What ``aldpat filter`` writes (the filter functions ignore these)."""

    result: str | None = param(
        None, "what to write: terrain points, non-terrain points, both files, or every point classified "
        "(in input order with every attribute: ground LAS class 2, a former 2 or 0 that is not ground 1, low "
        "outliers 7, other classes kept; text: a column class); terrain and non-terrain hold those points "
        "and classes split at class 2; default: classified for a LAS/LAZ output, terrain for text", choices=("terrain", "nonterrain", "both", "classified"), manual="Result Mode")
    data_mode: str = param(
        "real",
        "output points at their own x, y (real) or one point per cell at the cell centre (center)",
        choices=("real", "center"),
        manual="Data Mode", level="advanced",
    )
    marks: bool = param(False, "add each point's mark: 0 for ground, else the half window (cells) "
                        "at which it was removed (column / LAS extra byte 'mark')", level="advanced")


@dataclass(frozen=True)
class LowOutlierOption(SharedOption):
    """The low-outlier test (:mod:`aldpat.core.low_points`), taken by every ground filter."""

    low_outliers: float | None = param(
        2.0,
        "low outliers (multipath, a pulse through a window) take no part in finding ground and are "
        "not ground (class 7 in classified output): points this far below every point around them "
        "and below the floor of the terrain within low_outlier_reach (further where the heights "
        "there spread more; after dissertation §4.1.1); none: off",
        unit="m", gt=0,
    )
    low_outlier_window: int = param(
        2, "a clump of low points at most twice this many cells (or point spacings, where the "
        "points are sparser than the cells) across is a low outlier; a wider hollow is terrain",
        unit="cells", ge=1, level="advanced",
    )
    low_outlier_reach: float = param(
        20.0, "the terrain a low outlier must lie below: a plane through the points within this "
        "distance, raised to the height a tenth of them reach",
        unit="m", gt=0, level="advanced",
    )


@dataclass(frozen=True)
class RaisedSegmentOption(SharedOption):
    """The raised-segment test (:mod:`aldpat.core.segments`), taken by the grid filters and
    ``atin``: objects larger than any window or seed square, found by the steps around them."""

    object_step: float = param(
        0.0,
        "raised-segment test: cells whose heights differ by more than this split the grid into "
        "segments, and a segment standing above its surroundings is an object whatever its size "
        "(buildings larger than the filter's largest window or seed square); 0: off",
        unit="m", ge=0, level="advanced",
    )
    object_share: float = param(
        0.6, "share of a segment's perimeter steps that must go down from it for it to be an object",
        ge=0, le=1, level="advanced",
    )
    object_span: float = param(
        0.0,
        "with the raised-segment test: a level run of cells along a row or column, bounded at both "
        "ends by steps down from it and at most this long, is an object (a bridge deck across its "
        "width, joined to the ramps at its ends); 0: off",
        unit="m", ge=0, level="advanced",
    )


@dataclass(frozen=True)
class GroundParams(RaisedSegmentOption, LowOutlierOption, ExistingClassesOption, FilterOutputOption, ChunkOption,
                   OriginOption, CrsOption, Checked):
    """Parameters every grid filter shares; each filter's params class subclasses it."""

    cell: float = param(1.0, "grid cell size", unit="m", gt=0, manual="Cell size")
    ground_tolerance: float = param(
        0.3,
        "a non-lowest point of a cell is ground within this height of the final ground surface",
        unit="m",
        ge=0, level="advanced",
    )
    surface_threshold: float | None = param(
        None,
        "final test (SMRF): every point within this height of the interpolated ground surface, plus "
        "surface_slope x its local slope, is ground and every other point is not; none: off (the "
        "lowest point of a cell takes the cell's class, the others ground_tolerance)",
        unit="m", ge=0, level="advanced",
    )
    surface_slope: float = param(
        1.0, "slope scalar of the final test: metres of tolerance per unit of terrain slope", ge=0, level="advanced",
    )

    def chunk_lattice(self) -> tuple[float, tuple[float, float]]:
        """The cell a file's chunks are whole multiples of, and the point they start from: the
        filter's grid (its cell, its origin or (0, 0)), so that a chunk's cells are the file's."""
        return self.cell, self.origin or (0.0, 0.0)

    def on_lattice(self, origin: tuple[float, float]) -> Self:
        """These params with the grid starting at ``origin`` (the chunks' lattice): a chunk's
        grid is then the whole file's, not one aligned to the chunk's own points."""
        return dataclasses.replace(self, origin=origin)


@dataclass(frozen=True)
class PointFilterParams(LowOutlierOption, ExistingClassesOption, FilterOutputOption, ChunkOption, CrsOption, Checked):
    """Parameters every point filter shares (``slope``, ``ipf``, ``poly2``, ``atin``): filters that
    test points against their neighbours or a fitted surface rather than a mark matrix.

    Subclasses say which cells ``--data-mode center`` and the reported mark matrix use
    (:meth:`cell_shape`): the filter's own cells.
    """

    def cell_shape(self) -> tuple[float, float]:
        """Width and height of the filter's cells."""
        raise NotImplementedError

    def chunk_lattice(self) -> tuple[float, tuple[float, float]]:
        """The cell a file's chunks are whole multiples of, and the point they start from: the
        filter's cell width from (0, 0), where its cells start (:func:`~aldpat.filters.driver.cell_grid`)."""
        return self.cell, (0.0, 0.0)

    def on_lattice(self, origin: tuple[float, float]) -> Self:
        """These params for a chunk on the lattice from ``origin``: unchanged, the filter's cells
        start from (0, 0) wherever its points lie."""
        return self

    if TYPE_CHECKING:  # declared, with its default and help, by each point filter (its own cells)
        @property
        def cell(self) -> float: ...


def check_series(windows: tuple[int, ...], values: tuple[float, ...], names: tuple[str, str]) -> None:
    """Windows ascending and one value per window, or a :class:`ParamError` naming both keys."""
    if len(windows) != len(values):
        raise ParamError(f"{names[1]}: expected one value per window of {names[0]} "
                         f"({len(windows)}), got {len(values)}")
    if any(b <= a for a, b in itertools.pairwise(windows)):
        raise ParamError(f"{names[0]}: half windows must be strictly ascending, got {shown(windows, quoted=False)}")
