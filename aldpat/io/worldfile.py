"""World files: where a picture lies on the ground (ESRI's six-line ``.pgw`` beside a PNG).

The six numbers are the affine transform from pixel to map coordinates, in the order the format
fixes: the pixel's width ``A``, two rotation terms ``D`` and ``B`` (0 for a north-up picture),
its height ``E`` (negative: rows go south), and the map x ``C`` and y ``F`` of the *centre* of
the upper-left pixel. GDAL, QGIS and ArcGIS place the PNG from it; aldpat's run report draws the
scale bar and corner coordinates from it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from aldpat.errors import InputFormatError


@dataclass(frozen=True)
class NorthUp:
    """A north-up picture's place: the outer corner of its upper-left pixel and the pixel size."""

    west: float
    north: float
    dx: float  # pixel width
    dy: float  # pixel height (positive)

    def world_lines(self) -> str:
        return "\n".join(repr(float(v)) for v in (self.dx, 0.0, 0.0, -self.dy, self.west + self.dx / 2,
                                                   self.north - self.dy / 2)) + "\n"

    def scaled(self, factor: int) -> NorthUp:
        """The same place with each pixel repeated ``factor`` times each way."""
        return NorthUp(self.west, self.north, self.dx / factor, self.dy / factor)


def world_path(picture: Path) -> Path:
    """``x.png`` -> ``x.pgw`` (the extension's first and last letters and a w)."""
    ext = picture.suffix
    return picture.with_suffix(f".{ext[1]}{ext[-1]}w" if len(ext) >= 3 else ".wld")


def read_world_file(path: Path) -> NorthUp:
    """The place of a north-up picture from its world file; a rotated one is refused."""
    try:
        values = [float(v) for v in Path(path).read_text(encoding="ascii").split()[:7]]
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise InputFormatError(f"not a world file ({exc})", path=path) from None
    if len(values) != 6 or not all(map(math.isfinite, values)):
        raise InputFormatError("a world file holds six numbers", path=path)
    a, d, b, e, c, f = values
    if d or b or a <= 0 or e >= 0:
        raise InputFormatError("not a north-up picture (rotation terms or signs)", path=path)
    return NorthUp(c - a / 2, f - e / 2, a, -e)
