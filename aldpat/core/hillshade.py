"""Hillshade of a grid: the standard formula (Horn's slope and aspect, the Lambertian shade of a
sun at ``azimuth`` and ``altitude``), as GIS tools compute it.

Slope and aspect come from Horn's 3 x 3 finite differences (Horn 1981), the grid's edges repeated
outward; the shade is ``255 * (cos(zenith) cos(slope) + sin(zenith) sin(slope) cos(azimuth -
aspect))``, clipped at 0 (ESRI's hillshade; GDAL's ``gdaldem hillshade``). Blank (NaN) nodes
stay NaN.
"""

from __future__ import annotations

import numpy as np


def hillshade(z: np.ndarray, dx: float, dy: float, *, azimuth: float = 315.0, altitude: float = 45.0,
              z_factor: float = 1.0) -> np.ndarray:
    """Shade (0..255, float) of ``z`` (rows from the *north*, columns from the west)."""
    z = np.asarray(z, dtype=np.float64)
    p = np.pad(z, 1, mode="edge")
    a, b, c = p[:-2, :-2], p[:-2, 1:-1], p[:-2, 2:]
    d, f = p[1:-1, :-2], p[1:-1, 2:]
    g, h, i = p[2:, :-2], p[2:, 1:-1], p[2:, 2:]
    dzdx = ((c + 2 * f + i) - (a + 2 * d + g)) / (8.0 * dx)  # rises to the east
    dzdy = ((g + 2 * h + i) - (a + 2 * b + c)) / (8.0 * dy)  # rises to the south (rows run south)
    slope = np.arctan(z_factor * np.hypot(dzdx, dzdy))
    aspect = np.arctan2(dzdy, -dzdx)
    zenith = np.radians(90.0 - altitude)
    sun = np.radians((360.0 - azimuth + 90.0) % 360.0)
    shade = 255.0 * (np.cos(zenith) * np.cos(slope) + np.sin(zenith) * np.sin(slope) * np.cos(sun - aspect))
    return np.clip(shade, 0.0, 255.0)
