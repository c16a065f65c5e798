"""First and last returns of a 9-column ALTM strip: UTM zone prefixes and the stop gap.

ALDPAT 1.0 user manual (2007), Task 2 "Separate First and Last Return Measurements from a 9 Column
Strip File":

* UTM Zone: "UTM zone number may be included for x and y coordinates in the 9 column data ...
  The program automatically determines whether the UTM zone number is included in the x and y
  coordinates in terms of number of digits." A UTM easting has 6 integer digits (100000 to
  999999) and a northing at most 7 (below 10 000 000), so a zone prefixed to them shows as
  x >= 1 000 000 and y >= 10 000 000: zone = x div 10^6 = y div 10^7.
* Stop Gap: "If the elevation difference between the first and last return measurements is less
  than 5 meters, the last return measurement is replaced by the first return measurement"
  (the 10 ns pulse width makes closer last returns unreliable).
"""

from __future__ import annotations

import numpy as np

from aldpat.core.precision import below

X_PREFIX = 1_000_000.0
Y_PREFIX = 10_000_000.0


def zone_prefix(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The zone number each x and y carries in front of its integer digits (0 = none)."""
    zx = np.floor(np.abs(np.asarray(x, np.float64)) / X_PREFIX).astype(np.int64)
    zy = np.floor(np.abs(np.asarray(y, np.float64)) / Y_PREFIX).astype(np.int64)
    return zx, zy


def strip_zone(x: np.ndarray, y: np.ndarray, zone: int) -> tuple[np.ndarray, np.ndarray]:
    """x and y with zone ``zone`` removed from their leading digits."""
    return np.asarray(x, np.float64) - zone * X_PREFIX, np.asarray(y, np.float64) - zone * Y_PREFIX


def stop_gap_mask(z_first: np.ndarray, z_last: np.ndarray, stop_gap: float,
                  decimals: int | None = None) -> np.ndarray:
    """True where the last return is not trusted: first z minus last z below ``stop_gap``.

    With ``decimals`` (the elevations' decimals in the file) the difference is decided at that
    precision, so a difference of exactly the stop gap is never "below" it by rounding noise.
    """
    return below(z_first, z_last, stop_gap, decimals)
