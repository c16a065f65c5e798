"""Cell heights stored compactly, read back as the exact float64 values the points carry.

A grid filter keeps the lowest height of every cell for the whole run (dissertation ch. 3,
"Resampling Data"): on 1 m cells over a 10 M-point survey that is some 32 M cells, and float64
heights alone take 256 MB. LAS/LAZ heights are integers times the file's z scale plus its offset
(the LAS 1.4 specification, "Point Data Records"), so a cell can keep the integer instead, in
four bytes, and give back on demand exactly the float64 a reader computes from it -- the same
``integer * scale + offset`` laspy uses -- so every comparison and threshold downstream sees the
same numbers as if float64 had been kept. Taking the lowest integer is taking the lowest height
(the scale is positive), and an opening or a nearest-neighbour fill only moves values, so both
work on the codes directly.

:class:`FloatHeights` is the same interface over plain float64 heights (text input, or heights
given as arrays).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

#: The code of an empty cell in :class:`ScaledHeights` (larger than any point's: a running
#: minimum starts from it).
EMPTY_CODE = np.iinfo(np.int32).max

#: A grid's codes -> their float64 heights (the ``decode`` of :class:`FloatHeights` or
#: :class:`ScaledHeights`).
Decode = Callable[[np.ndarray], np.ndarray]


class FloatHeights:
    """Heights kept as float64; NaN marks an empty cell."""

    def decode(self, codes: np.ndarray) -> np.ndarray:
        """The heights (the array itself: no copy)."""
        return codes

    def is_empty(self, codes: np.ndarray) -> np.ndarray:
        return np.isnan(codes)


@dataclass(frozen=True)
class LinearDecode:
    """The decoding of :class:`ScaledHeights`: height = code * scale + offset (a multiplication,
    then an addition, never fused), a :data:`Decode` whose scale and offset a compiled loop reads
    plainly (:func:`aldpat.core.rise.scale_and_offset`)."""

    scale: float
    offset: float

    def __call__(self, codes: np.ndarray) -> np.ndarray:
        """float64 heights, bit for bit those of ``laspy``'s scaled z."""
        return (codes * self.scale) + self.offset


@dataclass(frozen=True)
class ScaledHeights:
    """Heights kept as the LAS integers: height = code * scale + offset, exactly as laspy reads it."""

    scale: float
    offset: float
    dtype = np.dtype(np.int32)
    empty = EMPTY_CODE  # a running minimum's start

    def __post_init__(self) -> None:
        if not self.scale > 0:
            raise ValueError(f"a z scale must be positive to keep the order of heights, got {self.scale!r}")

    @property
    def decode(self) -> LinearDecode:
        """Codes -> float64 heights, bit for bit those of ``laspy``'s scaled z."""
        return LinearDecode(self.scale, self.offset)

    def is_empty(self, codes: np.ndarray) -> np.ndarray:
        return codes == EMPTY_CODE


Heights = FloatHeights | ScaledHeights
