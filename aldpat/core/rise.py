"""Every cell's height above its opened surface, and the cells a threshold removes, in one pass.

A pass of a morphological filter (dissertation §6.2.4, ``AdaptiveMorphFilter`` lines 13-17)
opens a block of lines, takes every cell's height above the opened surface and removes the
unfiltered cells rising more than a threshold; between a lower and an upper threshold the
adaptive threshold decides, so those cells are listed for it. In numpy that is a dozen passes
over the block with a temporary for each (two decodings of height codes, a subtraction, six
comparisons and masks, ``nonzero``); here it is two compiled loops over the block.

The values are numpy's to the bit: a height is ``code * scale + offset`` as
:class:`aldpat.core.height_codes.ScaledHeights` decodes it (a multiplication and an addition,
never fused), and the rise the difference of two such heights.
"""

from __future__ import annotations

import numpy as np

from aldpat.core.compiled import compiled
from aldpat.core.height_codes import Decode, FloatHeights, LinearDecode


def scale_and_offset(decode: Decode | None) -> tuple[float, float] | None:
    """``(scale, offset)`` when ``decode`` is a linear decoding (:class:`LinearDecode`, that of
    :class:`~aldpat.core.height_codes.ScaledHeights`); else ``None``."""
    return (decode.scale, decode.offset) if isinstance(decode, LinearDecode) else None


def compiled_decoding(decode: Decode) -> tuple[bool, float, float]:
    """How a compiled loop reads a grid's heights: ``(True, scale, offset)`` of scaled codes
    (``code * scale + offset``, unfused), ``(False, 1, 0)`` of float heights, read as they are."""
    linear = scale_and_offset(decode)
    if linear is None and not isinstance(getattr(decode, "__self__", None), FloatHeights):
        raise TypeError(f"heights decoded by {decode!r}: neither scaled codes nor float heights")
    return (True, *linear) if linear is not None else (False, 1.0, 0.0)


def heights_and_rise(z: np.ndarray, opened: np.ndarray, decode: Decode | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
    """The heights of ``z`` and their rise above ``opened`` (both float64, the shape of ``z``):
    ``decode(z)`` and ``decode(z) - decode(opened)`` (``z`` itself and ``z - opened`` when
    ``decode`` is None: ``z`` holds float64 heights)."""
    if decode is None:
        heights = np.asarray(z, dtype=np.float64)
        return heights, np.subtract(heights, opened)
    linear = scale_and_offset(decode)
    if linear is None or z.ndim != 2:
        heights = decode(z)
        return heights, np.subtract(heights, decode(opened))
    heights = np.empty(z.shape)
    rise = np.empty(z.shape)
    _decoded_rise(np.ascontiguousarray(z), np.ascontiguousarray(opened), linear[0], linear[1], heights, rise)
    return heights, rise


def removed_and_band(rise: np.ndarray, unfiltered: np.ndarray, cap: float, floor: float
                     ) -> tuple[np.ndarray, np.ndarray]:
    """The unfiltered cells rising more than ``cap`` (bool, the shape of ``rise``) and the flat
    indices, ascending, of the other unfiltered cells rising more than ``floor`` (the band where
    an adaptive threshold decides; ``floor`` infinite: none). NaN rises neither."""
    rise = np.ascontiguousarray(rise, dtype=np.float64)
    removed = np.empty(rise.shape, bool)
    band = np.empty(rise.size, np.int64)
    count = _removed_and_band(rise.ravel(), np.ascontiguousarray(unfiltered, dtype=bool).ravel(), float(cap),
                              float(floor), removed.ravel(), band)
    return removed, band[:count].copy()


@compiled(nogil=True)
def _decoded_rise(z: np.ndarray, opened: np.ndarray, scale: float, offset: float, heights: np.ndarray,
                  rise: np.ndarray) -> None:  # pragma: no cover - compiled
    rows, cols = z.shape
    for i in range(rows):
        for j in range(cols):
            h = z[i, j] * scale
            h = h + offset
            o = opened[i, j] * scale
            o = o + offset
            heights[i, j] = h
            rise[i, j] = h - o


@compiled(nogil=True)
def _removed_and_band(rise: np.ndarray, unfiltered: np.ndarray, cap: float, floor: float, removed: np.ndarray,
                      band: np.ndarray) -> int:  # pragma: no cover - compiled
    count = 0
    for i in range(rise.size):
        out = False
        if unfiltered[i]:
            d = rise[i]
            if d > cap:
                out = True
            elif d > floor:
                band[count] = i
                count += 1
        removed[i] = out
    return count
