"""Raised spans: a bridge deck across its width, not a ramp, a ridge or a terrace."""

from __future__ import annotations

import numpy as np

from aldpat.core.spans import raised_spans


def flyover(rows=80, cols=200):
    """A deck 12 cells wide at 7 m from column 80 to 120, joined to earth ramps rising to it
    from columns 20 and 180 (sides sloping 1:1.5), over ground at 0."""
    r, c = np.mgrid[0:rows, 0:cols].astype(float)
    crest = np.interp(c, [20, 80, 120, 180], [0, 7, 7, 0])
    off = np.abs(r - 40)
    ramp = np.clip(crest - np.clip(off - 6, 0, None) / 1.5, 0, None)
    deck = (c >= 80) & (c < 120) & (off < 6)
    z = np.where((c >= 80) & (c < 120), 0.0, ramp)
    z[deck] = 7.0
    return z, deck


def test_a_deck_is_a_span_and_its_ramps_are_not():
    z, deck = flyover()
    spans = raised_spans(z, 2.0, 40)
    np.testing.assert_array_equal(spans, deck)
    assert not raised_spans(z, 2.0, 8).any()  # wider than the longest span allowed


def test_a_ridge_and_terraces_are_not_spans():
    """A ridge between two flanks that drop in steps rises and falls across its crest (not
    level); a terrace steps down on one side only; a wall-bounded level strip is a span."""
    _, c = np.mgrid[0:30, 0:120].astype(float)
    ridge = 10.0 - 0.8 * np.abs(c - 60)
    ridge[:, :55] -= 3.0
    ridge[:, 66:] -= 3.0
    assert not raised_spans(ridge, 2.0, 40).any()
    terraces = 3.0 * (c // 30)
    assert not raised_spans(terraces, 2.0, 40).any()
    strip = np.where((c >= 50) & (c < 70), 5.0, 0.0)
    assert raised_spans(strip, 2.0, 40)[:, 50:70].all()


def test_codes_and_blocks_give_the_heights_result(monkeypatch):
    """Height codes (decoded block by block) and any block size: the same spans."""
    from aldpat.core import spans as module

    z, deck = flyover()
    codes = np.rint(z * 100).astype(np.int32)
    assert np.array_equal(raised_spans(codes, 2.0, 40, decode=lambda a: a * 0.01), deck)
    monkeypatch.setattr(module, "BLOCK_LINES", 7)
    assert np.array_equal(raised_spans(z, 2.0, 40), deck)


def test_enclosed_spans_are_flats_stepping_down_on_every_side():
    """``enclosed``: a flat roof piece standing on the ground (steps down along its rows and its
    columns) is one; a deck (steps down across it, ramps along it), a level strip running out
    of the grid and a flat on a step of a slope are not."""
    r, c = np.mgrid[0:80, 0:200].astype(float)
    roof = np.where((r >= 30) & (r < 50) & (c >= 40) & (c < 70), 5.0, 0.0)
    np.testing.assert_array_equal(raised_spans(roof, 2.0, 40, enclosed=True), roof > 0)
    z, _ = flyover()
    assert not raised_spans(z, 2.0, 40, enclosed=True).any()
    strip = np.where((c >= 50) & (c < 70), 5.0, 0.0)
    assert raised_spans(strip, 2.0, 40).any() and not raised_spans(strip, 2.0, 40, enclosed=True).any()
    slope = 0.3 * r + np.where((r >= 30) & (r < 50) & (c >= 40) & (c < 70), 3.0, 0.0)  # rises along its columns
    assert not raised_spans(slope, 2.0, 40, enclosed=True).any()


def _reference_spans(z, spacing, step, max_cells, cell, level):
    """One block of lines in the former vectorised form."""
    from aldpat.core.segments import step_limits

    lines, n = z.shape
    rise = np.diff(z, axis=1)
    apart = None if spacing is None else spacing[:, 1:].astype(np.uint16) + spacing[:, :-1]
    cut = np.abs(rise) > step_limits(apart, step, cell)
    starts = np.zeros((lines, n), bool)
    starts[:, 0] = True
    starts[:, 1:] = cut
    first = np.flatnonzero(starts.ravel())
    last = np.append(first[1:], lines * n) - 1
    flat = z.ravel()
    length = last - first + 1
    down_before = (first % n > 0) & (flat[np.maximum(first - 1, 0)] < flat[first])
    down_after = (last % n < n - 1) & (flat[np.minimum(last + 1, flat.size - 1)] < flat[last])
    keep = down_before & down_after & (length <= max_cells)
    if keep.any():
        keep &= np.maximum.reduceat(flat, first) - np.minimum.reduceat(flat, first) <= level
    return np.repeat(keep, length).reshape(lines, n)


def test_compiled_line_scans_equal_the_vectorised_form():
    """Runs, their steps (with and without the points' spacing), ends and levelness: the cells of
    the former vectorised form exactly, along rows (a line at a time) and along columns (a block
    of them side by side, a row at a time)."""
    from aldpat.core.segments import SPACING_REACH, SPACING_SLOPE
    from aldpat.core.spans import _SET, _column_spans, _limits, _line_spans

    def scan(fn, z, spacing, step, max_cells, cell, level):
        out = np.ones(z.shape, bool)
        lines = z.shape[1] if fn is _column_spans else z.shape[0]
        limits = _limits(np.float32(step), np.float32(cell), np.float32(SPACING_SLOPE), np.float32(SPACING_REACH))
        fn(z, np.zeros((1, 1), np.uint8) if spacing is None else spacing, spacing is not None, False, 1.0, 0.0, 0,
           lines, step, limits, max_cells, level, _SET, out)
        return out

    rng = np.random.default_rng(4)
    for case in range(40):
        lines, n = (int(k) for k in rng.integers(1, 30, 2))
        z = np.round(rng.choice([0.0, 3.0, 6.0, 0.3, 2.0], (lines, n)) + rng.normal(0, 0.3, (lines, n)), 2)
        spacing = rng.integers(0, 5, (lines, n)).astype(np.uint8) if case % 2 else None
        step, max_cells = float(rng.choice([0.3, 1.5, 2.0])), int(rng.integers(0, 12))
        level, cell = float(rng.choice([0.5, 2.0])), float(rng.choice([0.5, 1.0]))
        expected = _reference_spans(z, spacing, step, max_cells, cell, level)
        assert np.array_equal(scan(_line_spans, z, spacing, step, max_cells, cell, level), expected)
        transposed = None if spacing is None else np.ascontiguousarray(spacing.T)
        along_columns = scan(_column_spans, np.ascontiguousarray(z.T), transposed, step, max_cells, cell, level)
        assert np.array_equal(along_columns.T, expected)


def test_enclosed_spans_made_within_a_mask_keep_only_its_cells():
    """``within`` (given up) holds the enclosed spans inside it: the result of ANDing them with it."""
    from aldpat.core.spans import raised_spans

    rng = np.random.default_rng(9)
    z = np.round(rng.choice([0.0, 3.0, 3.2, 6.0], (40, 50)) + rng.normal(0, 0.1, (40, 50)), 2)
    mask = rng.random(z.shape) < 0.7
    expected = raised_spans(z, 1.0, 8, enclosed=True, level=1.0) & mask
    assert expected.any()
    given = mask.copy()
    made = raised_spans(z, 1.0, 8, enclosed=True, level=1.0, within=given)
    assert made is given and np.array_equal(made, expected)


def test_blocks_on_threads_give_the_one_thread_result(monkeypatch):
    """The blocks of each direction run on threads at once: the spans, enclosed or not and within
    a mask or not, are those of one thread taking the blocks in turn."""
    from aldpat.core import spans as module

    rng = np.random.default_rng(4)
    z = np.round(rng.choice([0.0, 3.0, 3.2, 6.0], (90, 70)) + rng.normal(0, 0.1, (90, 70)), 2)
    mask = rng.random(z.shape) < 0.7
    monkeypatch.setattr(module, "BLOCK_LINES", 5)
    results = {}
    for threads in ("1", "4"):
        monkeypatch.setenv("ALDPAT_THREADS", threads)
        results[threads] = (raised_spans(z, 1.0, 8), raised_spans(z, 1.0, 8, enclosed=True, level=1.0),
                            raised_spans(z, 1.0, 8, enclosed=True, level=1.0, within=mask.copy()))
    assert all(r.any() for r in results["1"])
    for one, many in zip(results["1"], results["4"], strict=True):
        assert np.array_equal(one, many)
