"""Thresholds on values read from text, decided at the precision the data were written with.

A tape gives elevations to the centimetre; ``5.27 - 0.27`` is ``4.999999999999999`` in binary
floating point, so a plain ``z1 - z2 < 5`` calls that shot "below 5 m" while ``10.00 - 5.00``
is not, although both differences are exactly 5.00 m in the file. Comparing whole units of the
data's last decimal (``527 - 27 = 500`` hundredths) gives every such pair the same answer.
"""

from __future__ import annotations

import numpy as np

#: Scaled values must stay integers a float64 holds exactly.
_EXACT = 2.0 ** 52


def _scale(decimals: int | None, *values: np.ndarray) -> float | None:
    if decimals is None or decimals < 0:
        return None
    scale = 10.0 ** decimals
    largest = max((float(np.max(np.abs(v))) for v in values if np.size(v)), default=0.0)
    return scale if largest * scale < _EXACT else None


def difference_in_units(a: np.ndarray, b: np.ndarray, decimals: int | None) -> tuple[np.ndarray, float]:
    """``a - b`` in whole units of the last decimal, and the size of that unit.

    Falls back to the plain difference (unit 1) when the precision is unknown or too fine for
    the values to be held exactly.
    """
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    scale = _scale(decimals, a, b)
    if scale is None:
        return a - b, 1.0
    return np.rint(a * scale) - np.rint(b * scale), scale


def threshold_in_units(threshold: float, scale: float) -> float:
    """A threshold in the same units; rounded far below one unit so that 5.0 is 500, not 499.99..."""
    return round(float(threshold) * scale, 6)


def below(a: np.ndarray, b: np.ndarray, threshold: float, decimals: int | None) -> np.ndarray:
    """``a - b < threshold``, decided at ``decimals`` decimals."""
    diff, scale = difference_in_units(a, b, decimals)
    return diff < threshold_in_units(threshold, scale)


def above(a: np.ndarray, b: np.ndarray, threshold: float, decimals: int | None) -> np.ndarray:
    """``a - b > threshold``, decided at ``decimals`` decimals."""
    diff, scale = difference_in_units(a, b, decimals)
    return diff > threshold_in_units(threshold, scale)
