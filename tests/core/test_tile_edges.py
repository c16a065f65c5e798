"""Tile grids: nodes of one lattice in each core; shared edge nodes from a canonical point set."""

import numpy as np
import pytest

from aldpat.core.interpolate import interpolate
from aldpat.core.tile_edges import canonical_points, core_nodes, grid_tile, shared_nodes


def test_core_nodes_are_the_lattice_nodes_inside_the_core():
    spec = core_nodes((500.0, 1000.0, 200.0, 700.0), 1.0)
    assert (spec.xmin, spec.ymin, spec.nx, spec.ny) == (500.0, 200.0, 501, 501)
    # 500 m tiles and 3 m cells: the first node at or after each edge, none shared
    west, east = core_nodes((0.0, 500.0, 0.0, 500.0), 3.0), core_nodes((500.0, 1000.0, 0.0, 500.0), 3.0)
    assert (west.xmin, west.xmax, east.xmin, east.xmax) == (0.0, 498.0, 501.0, 999.0)
    moved = core_nodes((0.0, 10.0, 0.0, 10.0), 2.0, origin=(0.5, 0.0))
    assert (moved.xmin, moved.nx) == (0.5, 5)
    assert core_nodes((0.1, 0.9, 0.0, 1.0), 1.0) is None  # no node in a sliver


def test_shared_nodes_are_the_edges_and_corners_on_the_lattice():
    spec = core_nodes((0.0, 30.0, 0.0, 20.0), 2.0)
    parts = list(shared_nodes(spec, (0.0, 30.0, 0.0, 20.0), (0.0, 0.0), 5.0))
    assert len(parts) == 4 + 4
    west = parts[0]
    assert (west.spec.xmin, west.spec.nx, west.spec.ny, west.box) == (0.0, 1, 11, (-5.0, 5.0, -5.0, 25.0))
    corner = parts[-1]
    assert (corner.spec.xmin, corner.spec.ymin, corner.box) == (30.0, 20.0, (25.0, 35.0, 15.0, 25.0))
    # an edge off the lattice has no nodes to share
    spec = core_nodes((0.0, 31.0, 0.0, 20.0), 2.0)
    assert len(list(shared_nodes(spec, (0.0, 31.0, 0.0, 20.0), (0.0, 0.0), 5.0))) == 3 + 2


def test_canonical_points_ignore_order_and_far_points():
    rng = np.random.default_rng(2)
    x, y, z = rng.uniform(0, 10, (3, 500))
    box = (2.0, 4.0, 0.0, 10.0)
    a = canonical_points(x, y, z, box)
    order = rng.permutation(500)
    far = rng.uniform(20, 30, (3, 100))
    b = canonical_points(np.r_[x[order], far[0]], np.r_[y[order], far[1]], np.r_[z[order], far[2]], box)
    for u, v in zip(a, b):
        assert u.tobytes() == v.tobytes()


@pytest.mark.parametrize("method", ["linear", "nearest", "idw", "mean"])
def test_two_tiles_give_their_shared_column_bit_for_bit(method):
    """Two tiles, each with its own points and the other's within 6 m, points on an exact lattice
    (a TIN's choice of triangles is free there) and at random, handed over in different orders."""
    rng = np.random.default_rng(4)
    gx, gy = np.meshgrid(np.arange(0.35, 40.5, 0.7), np.arange(0.35, 20.5, 0.7))  # nodes between points
    x = np.r_[gx.ravel(), rng.uniform(0, 40, 300)]
    y = np.r_[gy.ravel(), rng.uniform(0, 20, 300)]
    z = np.sin(x / 3) + np.cos(y / 4) + 0.001 * x * y
    reach = 6.0
    grids, plain = [], []

    def grid(px, py, pz, part):
        return interpolate(px, py, pz, part, method=method)

    for core in ((0.0, 20.0, 0.0, 20.0), (20.0, 40.0, 0.0, 20.0)):
        near = (x >= core[0] - reach) & (x <= core[1] + reach)
        idx = rng.permutation(np.flatnonzero(near))
        spec = core_nodes(core, 1.0)
        grids.append(grid_tile(x[idx], y[idx], z[idx], spec, core, (0.0, 0.0), reach, grid))
        plain.append(grid(x[idx], y[idx], z[idx], spec))
    west, east = grids
    assert west[:, -1].tobytes() == east[:, 0].tobytes()
    assert np.isfinite(west[1:-1, -1]).all()
    if method in ("linear", "idw", "mean"):  # each tile on its own points differs in the last bits
        assert plain[0][:, -1].tobytes() != plain[1][:, 0].tobytes()
