"""World files beside pictures: written as GDAL reads them, read back as written."""

from __future__ import annotations

import numpy as np
import pytest

from aldpat.errors import InputFormatError
from aldpat.io.worldfile import NorthUp, read_world_file, world_path
from aldpat.tasks.preview import save_png


def test_the_world_file_is_named_after_the_picture(tmp_path):
    assert world_path(tmp_path / "a_hillshade.png").name == "a_hillshade.pgw"
    assert world_path(tmp_path / "x.tif").name == "x.tfw"


def test_gdal_places_a_png_where_its_world_file_says(tmp_path):
    """rasterio (GDAL) opens the PNG with the world file beside it at the place written."""
    rasterio = pytest.importorskip("rasterio")
    place = NorthUp(west=513748.0, north=5403197.5, dx=2.0, dy=0.5)
    rgba = np.zeros((40, 30, 4), np.uint8)
    written = save_png(rgba, tmp_path / "p.png", overwrite=False, place=place)
    assert [p.name for p in written] == ["p.png", "p.pgw"]
    assert read_world_file(tmp_path / "p.pgw") == place
    with rasterio.open(tmp_path / "p.png") as png:
        assert png.bounds == pytest.approx((513748.0, 5403197.5 - 40 * 0.5, 513748.0 + 30 * 2.0, 5403197.5))


@pytest.mark.parametrize("text, why", [
    ("1\n0.5\n0\n-1\n10\n20\n", "rotation"),
    ("1\n0\n0\n-1\n10\n", "six numbers"),
    ("1\n0\n0\n1\n10\n20\n", "north-up"),
    ("one\n", "not a world file"),
])
def test_a_world_file_that_is_not_a_north_up_picture_is_refused(tmp_path, text, why):
    path = tmp_path / "bad.pgw"
    path.write_text(text)
    with pytest.raises(InputFormatError, match=why):
        read_world_file(path)
