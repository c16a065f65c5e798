"""Spilling points into chunks with buffers: the compiled placement against the plain rule."""

from __future__ import annotations

import numpy as np
import pytest

from aldpat.io.chunks import RECORD, ChunkLattice, spill_chunks
from aldpat.io.table import PointTable


def spill_by_the_rule(x: np.ndarray, y: np.ndarray, lattice: ChunkLattice) -> dict[tuple[int, int], list[int]]:
    """Each chunk's rows as the rule states it, point by point: a point goes to its own chunk
    and to every chunk whose square grown by the buffer holds it (left and bottom edges in,
    right and top edges out), in input order."""
    ox, oy = lattice.origin
    size, b = lattice.size, lattice.buffer
    col, row = lattice.index(x, y)
    reach = int(np.ceil(b / size)) if b > 0 else 0
    out: dict[tuple[int, int], list[int]] = {}
    for i in range(len(x)):
        for dc in range(-reach, reach + 1):
            for dr in range(-reach, reach + 1):
                c, r = int(col[i] + dc), int(row[i] + dr)
                x0, y0 = ox + c * size, oy + r * size
                inside = x0 - b <= x[i] < x0 + size + b and y0 - b <= y[i] < y0 + size + b
                if (dc == 0 and dr == 0) or inside:
                    out.setdefault((c, r), []).append(i)
    return out


@pytest.mark.parametrize("size, buffer, origin", [(10.0, 1.0, (0.0, 0.0)), (10.0, 0.0, (0.0, 0.0)),
                                                  (7.5, 16.0, (-3.25, 2.0)), (99.75, 10.5, (0.375, 0.0))])
def test_every_chunk_holds_what_the_rule_puts_in_it_in_input_order(size, buffer, origin, tmp_path):
    rng = np.random.default_rng(7)
    n = 4000
    x = rng.uniform(-60, 260, n)
    y = rng.uniform(-40, 180, n)
    # points on the chunks' edges and on their buffers' edges, where a rounding would show
    edges = np.arange(-5, 25) * size
    x[:300] = origin[0] + rng.choice(np.concatenate([edges, edges - buffer, edges + buffer]), 300)
    y[300:600] = origin[1] + rng.choice(np.concatenate([edges, edges - buffer, edges + buffer]), 300)
    z = rng.uniform(0, 10, n)
    lattice = ChunkLattice(size, buffer, origin)
    table = PointTable({"x": x, "y": y, "z": z})
    expected = spill_by_the_rule(x, y, lattice)
    parts = [table.take(slice(0, 1500)), table.take(slice(1500, 1501)), table.take(slice(1501, n))]
    with spill_chunks(parts, lattice, tmpdir=tmp_path) as spilled:
        col, row = lattice.index(x, y)
        assert spilled.chunks == sorted(set(zip(col.tolist(), row.tolist(), strict=True)), key=lambda cr: (cr[1], cr[0]))
        found = {tuple(int(v) for v in p.stem.split("_")[1:]): p for p in spilled.folder.glob("chunk_*.bin")}
        assert set(found) == set(expected)
        assert spilled.spilled == sum(len(rows) for rows in expected.values())  # each copy counted once
        for (c, r), rows in expected.items():
            got = spilled.read(c, r)
            assert got["row"].tolist() == rows
            assert np.array_equal(got["x"], x[rows]) and np.array_equal(got["z"], z[rows])
            assert got.dtype == RECORD


def test_buffers_far_wider_than_the_chunks_are_placed_a_bounded_slice_at_a_time(tmp_path, monkeypatch):
    """The copies one step gathers stay under SPILL_COPIES however many chunks hold each point
    (a 7.5 m chunk with 16 m buffers: 27.7 copies of every point on average, up to 36), and the
    chunks hold what the rule puts in them, in input order, as when placed in one step."""
    from aldpat.io import chunks

    rng = np.random.default_rng(11)
    n = 3000
    x, y, z = rng.uniform(0, 120, n), rng.uniform(0, 90, n), rng.uniform(0, 10, n)
    lattice = ChunkLattice(7.5, 16.0)
    assert lattice.copies > 27 and lattice.most_copies_of_a_point == 36
    steps: list[int] = []
    place = chunks._append_by_chunk

    def counted(*args, **kwargs):
        copies = place(*args, **kwargs)
        steps.append(copies)
        return copies

    monkeypatch.setattr(chunks, "SPILL_COPIES", 1000)
    monkeypatch.setattr(chunks, "_append_by_chunk", counted)
    expected = spill_by_the_rule(x, y, lattice)
    with spill_chunks([PointTable({"x": x, "y": y, "z": z})], lattice, tmpdir=tmp_path) as spilled:
        assert len(steps) == -(-n // (1000 // 36)) and max(steps) <= 1000
        assert spilled.spilled == sum(steps) == sum(len(rows) for rows in expected.values())
        for (c, r), rows in expected.items():
            assert spilled.read(c, r)["row"].tolist() == rows


def test_each_chunks_result_is_let_go_of_once_handed_on():
    """A chunk's result lives as long as its caller keeps it, not until the last chunk is done
    (the futures kept every result: memory grew with the file)."""
    import gc
    import weakref
    from concurrent.futures import Future

    from aldpat.io.chunks import _each_once

    futures = []
    for k in range(3):
        fut: Future = Future()
        fut.set_result(np.full(10, k))
        futures.append(fut)
    results = _each_once(futures)
    first = weakref.ref(next(results))
    gc.collect()
    assert first() is None  # handed on and dropped by this caller: gone
    assert [int(r[0]) for r in results] == [1, 2]
