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
    for u, v in zip(a, b, strict=False):
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


def test_only_the_edges_and_corners_another_tile_holds_are_computed_again():
    core = (0.0, 30.0, 0.0, 20.0)
    spec = core_nodes(core, 2.0)

    def parts(others):
        return [(p.spec.xmin, p.spec.ymin, p.spec.nx, p.spec.ny)
                for p in shared_nodes(spec, core, (0.0, 0.0), 5.0, others)]

    # the tile to the east holds the east column, corners included
    assert parts([(30.0, 60.0, 0.0, 20.0)]) == [(30.0, 0.0, 1, 11), (30.0, 0.0, 1, 1), (30.0, 20.0, 1, 1)]
    assert parts([(30.0, 60.0, 20.0, 40.0)]) == [(30.0, 20.0, 1, 1)]  # a diagonal tile: its corner
    assert parts([]) == []  # a tile alone
    assert len(parts(None)) == 4 + 4  # not told: every edge and corner on the lattice


def test_on_the_projects_outer_edge_the_tiles_own_interpolation_stands():
    """IDW reaches any distance; an edge no other tile holds keeps the tile's own values instead
    of being computed again from the points near it (none here: it would be blank)."""
    rng = np.random.default_rng(5)
    x, y = rng.uniform(10, 30, (2, 400))  # no point within 5 m of any edge
    z = x + 2 * y

    def grid(px, py, pz, part):
        return interpolate(px, py, pz, part, method="idw")

    core = (0.0, 40.0, 0.0, 40.0)
    spec = core_nodes(core, 1.0)
    plain = grid(x, y, z, spec)
    alone = grid_tile(x, y, z, spec, core, (0.0, 0.0), 5.0, grid, others=[])
    assert alone.tobytes() == plain.tobytes() and np.isfinite(alone).all()
    beside = grid_tile(x, y, z, spec, core, (0.0, 0.0), 5.0, grid, others=[(40.0, 80.0, 0.0, 40.0)])
    assert beside[:, :-1].tobytes() == plain[:, :-1].tobytes()
    assert np.isnan(beside[:, -1]).all()  # the shared column: from the points within 5 m of it
