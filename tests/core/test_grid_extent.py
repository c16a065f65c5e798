"""Grid extents: node positions from a tile row (adjacent tiles share a row/column, manual
task 9 Fig. 7), from bounds, from data snapped to the cell size; tile_parameter.txt parsing."""

from __future__ import annotations

import numpy as np
import pytest

from aldpat.core.grid_extent import GridSpec, from_bounds, from_data
from aldpat.errors import DataError, InputFormatError, InputMissingError
from aldpat.io.tile_parameters import read_tile_parameters, tile_row_for

TILES = (
    "tiles/tile_500000_4000000.txt 500000 502000 4000000 4002000 2000 2000 50\n"
    "tiles/tile_502000_4000000.txt 502000 504000 4000000 4002000 2000 2000 50\n"
    "tiles/tile_500000_4002000.txt 500000 502000 4002000 4004000 2000 2000 50\n"
)


def test_bounds_put_nodes_on_the_limits():
    spec = from_bounds(10.0, 20.0, 14.0, 23.0, 1.0)
    assert (spec.nx, spec.ny) == (5, 4)
    np.testing.assert_array_equal(spec.x_nodes(), [10, 11, 12, 13, 14])
    np.testing.assert_array_equal(spec.y_nodes(), [20, 21, 22, 23])
    assert spec.corner_transform() == (9.5, 1.0, 0.0, 23.5, 0.0, -1.0)


def test_range_not_whole_cells_is_extended():
    spec = from_bounds(0.0, 0.0, 10.5, 10.0, 2.0)
    assert spec.nx == 7 and spec.xmax == 12.0 and spec.ny == 6


def test_data_extent_snaps_to_cell_multiples():
    spec = from_data(np.array([3.2, 7.9]), np.array([-1.1, 4.0]), 2.0)
    assert (spec.xmin, spec.xmax, spec.ymin, spec.ymax) == (2.0, 8.0, -2.0, 4.0)
    moved = from_data(np.array([3.2, 7.9]), np.array([-1.1, 4.0]), 2.0, origin=(0.5, 0.5))
    assert (moved.xmin, moved.ymin) == (2.5, -1.5)
    one = from_data(np.array([5.0]), np.array([5.0]), 1.0)
    assert (one.nx, one.ny) == (2, 2)


def test_adjacent_tiles_share_last_and_first_row_and_column(tmp_path):
    (tmp_path / "tile_parameter.txt").write_text(TILES)
    rows = read_tile_parameters(tmp_path / "tile_parameter.txt")
    west, east, north = (r.grid(1.0) for r in rows)
    assert (west.nx, west.ny) == (2001, 2001)
    assert west.x_nodes()[-1] == east.x_nodes()[0] == 502000.0
    assert west.y_nodes()[-1] == north.y_nodes()[0] == 4002000.0
    assert rows[0].buffer == 50 and rows[0].path == tmp_path / "tiles" / "tile_500000_4000000.txt"


@pytest.mark.parametrize("layout", ["space", "comma", "tab"])
def test_row_found_by_path_name_or_filtered_stem(tmp_path, layout):
    text = "path minx maxx miny maxy width height buffer\n" + TILES.replace("tiles/", str(tmp_path / "my tiles") + "/")
    if layout != "space":
        sep = "," if layout == "comma" else "\t"
        text = "\n".join(line.rsplit(" ", 7)[0] + sep + sep.join(line.rsplit(" ", 7)[1:])
                         for line in text.splitlines()) + "\n"
    params = tmp_path / "tile_parameter.txt"
    params.write_text(text)
    assert tile_row_for(params, tmp_path / "my tiles" / "tile_502000_4000000.txt").minx == 502000
    assert tile_row_for(params, tmp_path / "elsewhere" / "tile_500000_4002000.txt").miny == 4002000
    assert tile_row_for(params, "ground/tile_502000_4000000_gapm.txt").minx == 502000
    with pytest.raises(DataError, match="tile_9_9.txt"):
        tile_row_for(params, "tile_9_9.txt")


def test_bad_rows_name_the_line(tmp_path):
    params = tmp_path / "tile_parameter.txt"
    params.write_text(TILES + "tiles/x.txt 1 2 3\n")
    with pytest.raises(InputFormatError) as err:
        read_tile_parameters(params)
    assert err.value.line == 4
    params.write_text("a.txt 5 1 0 1 1 1 0\n")
    with pytest.raises(InputFormatError, match="empty"):
        read_tile_parameters(params)
    with pytest.raises(InputMissingError):
        read_tile_parameters(tmp_path / "none.txt")


def test_nearest_node_cells_are_centred_on_nodes():
    spec = GridSpec(0.0, 0.0, 1.0, 1.0, 3, 3)
    col, _row, inside = spec.nearest_node(np.array([-0.5, -0.51, 0.49, 2.49, 2.5]), np.array([0.0, 0, 1, 2, 2]))
    np.testing.assert_array_equal(col, [0, -1, 0, 2, 3])
    np.testing.assert_array_equal(inside, [True, False, True, True, False])


def test_millimetre_cells_on_utm_coordinates_are_a_grid_of_the_data_alone():
    # 5,420,300 m from the origin is 2.7e9 cells of 2 mm, more than a grid holds a side; the
    # data span 0.45 x 0.28 m, 226 x 142 nodes, which a grid holds.
    spec = from_data(np.array([494200.05, 494200.5]), np.array([5420300.02, 5420300.3]), 0.002)
    assert (spec.nx, spec.ny) == (226, 142)
    assert spec.xmin <= 494200.05 < spec.xmin + spec.dx


def test_a_refused_cell_names_the_datas_extent():
    with pytest.raises(DataError, match=r"x 494200 \.\. 494800 at 1e-300 m cells"):
        from_data(np.array([494200.05, 494799.97]), np.array([5420300.0, 5420500.0]), 1e-300)
