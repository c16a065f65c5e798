"""Generalized adaptive progressive morphological filter (``gapm``).

``AdaptiveMorphFilter`` of the GAPM dissertation (Cui 2013, ch. 6 §6.2.4), with the
cluster analysis of §6.2.1 (:mod:`aldpat.core.clusters`) and the trend analysis and threshold
estimation of §6.2.2-6.2.3 (:mod:`aldpat.core.trend`). Rows and columns have their own window
series (parameter set 01, Table 6-8: rows up to 20, columns up to 16). By default they run as
the printed algorithm does, rows then columns at every window on one surface and one mark
matrix; ``directions="separate"`` filters them apart and removes a cell that either removed,
the combination of two mark matrices §6.2.5 describes. On the ISPRS samples the printed
order is the better one (bench/bench_gapm.py).

Reading of the garbled lines 13-17 of the printed pseudo-code: below ``init_thresh_bin`` every cell uses
the constant threshold of that window, otherwise its adaptive threshold; then a cell is
removed where its height above the opened surface exceeds the threshold. In set 01 the
"cluster threshold" of the half windows 1 and 2 (0.3, 0.5) is that constant threshold
(Table 6-3), so one series serves both.

``--auto`` (:func:`with_auto`) replaces the cell and the series by those derived from the data
(:mod:`aldpat.core.auto_windows`).
"""

from __future__ import annotations

import dataclasses
import functools
import logging
import math
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from aldpat.core import line_pass, morphology, rise
from aldpat.core.auto_windows import SET01_CELL, auto_windows
from aldpat.core.height_codes import Decode
from aldpat.core.progressive import mark_dtype
from aldpat.core.threads import thread_budget
from aldpat.core.trend import candidate_thresholds, line_thresholds
from aldpat.errors import ParamError
from aldpat.filters.grid_stage import low_outlier_reach
from aldpat.filters.options import GroundParams, check_series
from aldpat.filters.registry import register_filter
from aldpat.params import default_of, param

log = logging.getLogger(__name__)

#: Rows of a direction pass processed together: bounds temporaries, keeps them in cache.
BLOCK_ROWS = 32
#: Columns of a column pass processed together: the block's transposed copy stays in cache.
BLOCK_COLUMNS = 32


@dataclass(frozen=True)
class GapmParams(GroundParams):
    # The defaults are parameter set 01 (dissertation Table 6-8: windows, thresholds, 0.75 m
    # cells) followed by the raised-segment test (with spans) and SMRF's final surface test, whose
    # constants were chosen by leave-one-out over the ISPRS samples (bench/bench_auto.py sweep)
    # among the settings that pass the known-answer scenes of tests/filters/terrain_scenes.py.
    # The low-outlier test's window is 3 cells (2.25 m) here: at the shared 2 its clumps reach
    # 3 m across on gapm's 0.75 m cells, and a multipath clump 4 m across is taken for ground.
    cell: float = default_of(GroundParams, "cell", SET01_CELL)
    low_outlier_window: int = default_of(GroundParams, "low_outlier_window", 3)
    object_step: float = default_of(GroundParams, "object_step", 2.0)
    object_share: float = default_of(GroundParams, "object_share", 0.55)
    object_span: float = default_of(GroundParams, "object_span", 40.0)
    surface_threshold: float | None = default_of(GroundParams, "surface_threshold", 0.3)
    surface_slope: float = default_of(GroundParams, "surface_slope", 1.5)
    window_series: tuple[int, ...] = param(
        (1, 2, 4, 8, 12, 16, 20), "half window sizes, ascending (full window 2k+1)", unit="cells", ge=1,
        level="internal",
    )
    cluster_thresholds: tuple[float, ...] = param(
        (0.3, 0.5, 1.0, 1.0, 1.0, 2.0, 2.0),
        "one per window: the cluster threshold (height change per cell) and the floor of the "
        "adaptive threshold; below init_thresh_bin the constant filtering threshold",
        unit="m", gt=0, level="internal",
    )
    row_windows: tuple[int, ...] | None = param(
        (1, 2, 4, 8, 12, 16, 20), "windows of window_series used along rows (x); none: no row filtering",
        unit="cells", ge=1, level="internal",
    )
    column_windows: tuple[int, ...] | None = param(
        (1, 2, 4, 8, 12, 16), "windows of window_series used along columns (y); none: no column filtering",
        unit="cells", ge=1, level="internal",
    )
    init_thresh_bin: int = param(
        4, "smallest half window that uses the adaptive (cluster + trend) threshold [initThreshBin]",
        unit="cells", ge=0, level="internal",
    )
    max_threshold_divisor: float = param(
        4.0, "the adaptive threshold is capped at cluster threshold x half window / this", gt=0, level="internal",
    )
    use_cluster_diff: bool = param(
        False, "also cap the threshold across clusters by the jump to the neighbouring cluster "
        "(§6.2.3 steps 1 and 5; the printed CalThreshArray leaves it out)", level="internal",
    )
    auto: bool = param(
        False, "derive the cell from the point density and the largest window from the largest "
        "object in the data (cell, window_series, cluster_thresholds, row_windows and "
        "column_windows are replaced; the job log says what was chosen)",
    )
    edges: str = param(
        "trend",
        "what a window reaching past the edge of the data sees there: trend (each row or column "
        "continued along the trend of its lowest cells, so a slope rising to the edge is not cut "
        "as a bump) or nearest (the edge cell repeated, as the dissertation's filter does)",
        choices=("trend", "nearest"), level="advanced",
    )
    directions: str = param(
        "sequential",
        "sequential: at every window rows then columns open one surface and share one mark "
        "matrix (AdaptiveMorphFilter lines 2-21); separate: rows and columns are filtered apart "
        "and a cell removed by either is non-ground (the two mark matrices of §6.2.5)",
        choices=("sequential", "separate"), level="internal",
    )

    def check(self) -> None:
        super().check()
        # series that do not fit together are a usage error, reported before any file is read
        check_series(self.window_series, self.cluster_thresholds, ("window_series", "cluster_thresholds"))
        if not passes(self):
            raise ParamError("row_windows and column_windows are both none: nothing to filter")


class Pass(NamedTuple):
    """One pass of ``AdaptiveMorphFilter`` (§6.2.4): a half window, its cluster threshold, and the
    direction it opens along (``"row"``: along x, ``"column"``: along y)."""

    window: int
    threshold: float
    direction: str


def passes(p: GapmParams) -> list[Pass]:
    """The passes of gapm's series in the order the printed algorithm runs them: at every window
    of ``window_series``, the row pass if it is a row window, then the column pass if it is a
    column window, each with the window's cluster threshold. A ``row_windows`` or
    ``column_windows`` entry missing from ``window_series`` is a :class:`ParamError` naming it."""
    chosen = {}
    for direction, windows in (("row", p.row_windows), ("column", p.column_windows)):
        missing = [w for w in windows or () if w not in p.window_series]
        if missing:
            raise ParamError(f"{direction}_windows: {missing} not in window_series {p.window_series}")
        chosen[direction] = set(windows or ())
    return [Pass(k, ct, direction) for k, ct in zip(p.window_series, p.cluster_thresholds, strict=False)
            for direction in ("row", "column") if k in chosen[direction]]


class StepRules(NamedTuple):
    """How a pass decides which cells it removes (§6.2.4 lines 13-17, CalThreshArray §6.2.3):
    the smallest half window with an adaptive threshold, the cap's divisor, whether the jump to
    the neighbouring cluster caps the threshold too, and what a window sees past the data's edge."""

    init_thresh_bin: int = 4
    max_threshold_divisor: float = 4.0
    use_cluster_diff: bool = False
    edges: str = "nearest"

    @classmethod
    def of(cls, p: GapmParams) -> StepRules:
        return cls(p.init_thresh_bin, p.max_threshold_divisor, p.use_cluster_diff, p.edges)


def adaptive_rows(
    z: np.ndarray,
    windows: tuple[int, ...],
    cluster_thresholds: tuple[float, ...],
    *,
    init_thresh_bin: int = 4,
    max_threshold_divisor: float = 4.0,
    use_cluster_diff: bool = False,
    edges: str = "nearest",
    axis: int = 1,
) -> np.ndarray:
    """``AdaptiveMorphFilter`` along the rows (``axis=1``) or columns (``axis=0``) of ``z``.

    Returns the mark matrix. Progressive: each window opens the surface left by the previous
    one (line 19) and a cell keeps the first (smallest) window that removed it. Rows never
    interact, so blocks of rows (or of columns, transposed one block at a time) run through
    all the windows at once and the whole grid is never copied.
    """
    z = np.asarray(z, dtype=np.float64)
    rules = StepRules(init_thresh_bin, max_threshold_divisor, use_cluster_diff, edges)
    marks = np.zeros(z.shape, np.int32)
    lines = z.shape[0] if axis == 1 else z.shape[1]
    for a in range(0, lines, BLOCK_ROWS):
        b = min(a + BLOCK_ROWS, lines)
        block = z[a:b] if axis == 1 else np.ascontiguousarray(z[:, a:b].T)
        m = _adaptive_block(block, windows, cluster_thresholds, rules)
        if axis == 1:
            marks[a:b] = m
        else:
            marks[:, a:b] = m.T
    return marks


def _adaptive_block(z: np.ndarray, windows: tuple[int, ...], cts: tuple[float, ...], rules: StepRules) -> np.ndarray:
    zc = z.copy()
    mark = np.zeros(z.shape, np.int32)
    for k, ct in zip(windows, cts, strict=False):
        removed, zc = adaptive_step(zc, mark == 0, k, ct, rules)
        mark[removed] = k
    return mark


def adaptive_step(zc: np.ndarray, unfiltered: np.ndarray, k: int, ct: float, rules: StepRules, axis: int = 1,
                  decode: Decode | None = None) -> tuple[np.ndarray, np.ndarray]:
    """One window of ``AdaptiveMorphFilter`` along rows (``axis=1``) or columns (``axis=0``): half
    window ``k``, cluster threshold ``ct``, decided by ``rules``.

    Returns (cells removed, opened surface). ``decode``: ``zc`` holds height codes
    (:mod:`aldpat.core.height_codes`) and the opened surface is returned as codes; an opening
    only moves values, so it is the same opening of the heights. ``edges="trend"``: the lines
    are continued past their ends along their trend (:func:`opened_along_trend`). Columns are
    the rows of the transposed grid (the filter hands its column passes blocks transposed).
    """
    if axis == 0:
        removed, zo = adaptive_step(np.ascontiguousarray(zc.T), np.ascontiguousarray(unfiltered.T), k, ct, rules,
                                    decode=decode)
        return removed.T, zo.T
    if rules.edges == "trend":
        zo, diff, zc = opened_along_trend(zc, k, decode)
    else:
        zo = morphology.opening(zc, k, window="line", axis=1)
        zc, diff = rise.heights_and_rise(zc, zo, decode)
    removed, band = rise.removed_and_band(diff, unfiltered, *decision_band(k, ct, rules))
    if band.size:
        removed.ravel()[band[diff.ravel()[band] > adaptive_thresholds(zc, unfiltered, band, k, ct, rules)]] = True
    return removed, zo


def decision_band(k: int, ct: float, rules: StepRules) -> tuple[float, float]:
    """``(cap, floor)`` of a pass: an unfiltered cell rising more than ``cap`` above the opening is
    removed; one rising more than ``floor`` (and not ``cap``) is left to the adaptive threshold.
    Below ``init_thresh_bin`` the constant threshold ``ct`` decides alone (``floor`` infinite).
    The adaptive threshold lies between min(ct, cap) and cap (CalThreshArray lines 16-20): beyond
    that band the answer is known without the analysis, so clusters and minima are evaluated
    only for the cells inside it."""
    if k < rules.init_thresh_bin:
        return ct, math.inf
    cap = ct * k / rules.max_threshold_divisor
    return cap, min(ct, cap)


def adaptive_thresholds(heights: np.ndarray, unfiltered: np.ndarray, band: np.ndarray, k: int, ct: float,
                        rules: StepRules) -> np.ndarray:
    """The adaptive threshold (CalThreshArray, §6.2.3) of the cells ``band`` (flat indices into the
    lines of ``heights``, taken as rows)."""
    if rules.use_cluster_diff:
        return candidate_thresholds(heights, unfiltered, band, k, ct, max_divisor=rules.max_threshold_divisor,
                                    use_cluster_diff=True)
    return line_thresholds(heights, unfiltered, band, k, ct, max_divisor=rules.max_threshold_divisor)


def opened_along_trend(zc: np.ndarray, k: int, decode: Decode | None = None
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The opening of every row of ``zc`` with a line window of half size ``k``, the rows continued
    past their ends along their trend (:func:`aldpat.core.morphology.opening_along_trend`): the
    opened surface, as ``zc`` holds it (height codes when ``decode`` is given), every cell's
    height above the trend's opening, and the heights of ``zc`` (both float64).

    The surface the next window opens must hold the grid's own values, so that codes and float64
    heights give the same classes bit for bit: the opening is the trend's except near the ends of
    a row, where it may take a value of the continuation. There each cell takes the highest of
    the row's own heights near the end that is not above it (the lowest, if all are): the trend's
    opening brought down to a height the grid holds.

    The rows are opened once, as ``zc`` holds them; only the ``4 k`` cells at each end are opened
    again along the trend (:func:`aldpat.core.morphology.trend_opening_at_ends`). Away from the
    ends the trend's opening of the heights is the heights of that opening, value for value: an
    opening only picks values, and decoding keeps their order.
    """
    zo = morphology.opening(zc, k, window="line", axis=1)
    heights, diff = rise.heights_and_rise(zc, zo, decode)
    rows, n = heights.shape
    if k == 0 or n < 4:
        return zo, diff, heights
    reach = min(2 * k, n)  # the cells the continuation can reach
    pool = min(4 * k, n)  # the heights near an end a cell there may take
    first, last = morphology.trend_opening_at_ends(heights, k)
    line = np.arange(rows)[:, None]
    for ends, near, trend in ((slice(n - reach, n), slice(n - pool, n), last), (slice(0, reach), slice(0, pool), first)):
        diff[:, ends] = heights[:, ends] - trend
        own = heights[:, near][:, None, :]  # (rows, 1, pool)
        target = trend[:, :, None]  # (rows, reach, 1)
        below = own <= target
        pick = np.where(below, own, -np.inf).argmax(axis=2)
        lowest = np.broadcast_to(own.argmin(axis=2), pick.shape)
        pick = np.where(below.any(axis=2), pick, lowest)
        zo[:, ends] = zc[:, near][line, pick]
    return zo, diff, heights


def adaptive_sequential(z: np.ndarray, p: GapmParams, *, workers: int | None = None, in_place: bool = False,
                        decode: Decode | None = None) -> np.ndarray:
    """``AdaptiveMorphFilter`` as printed (§6.2.4 lines 2-21): at every window of the series the
    rows (if the window is a row window) and then the columns (if a column window) are opened,
    each on the surface the previous pass left, marking into one mark matrix.

    Within a pass the rows (columns) are independent: blocks of them run on ``workers``
    threads, and each block writes its opened surface back over its own cells, which no other
    block reads. One surface grid therefore serves all passes and no pass allocates a grid
    (fresh pages cost more than the filtering itself on large grids). ``in_place``: ``z``
    (C-contiguous) is that surface grid, overwritten, instead of a copy of it. ``decode``: ``z``
    holds height codes (:mod:`aldpat.core.height_codes`), and so does the surface: 4 bytes a cell
    instead of 8, each block's heights decoded as it is filtered.

    A block is filtered by one compiled loop (:func:`aldpat.core.line_pass.filter_lines`: opening,
    rise, decisions and adaptive thresholds, a column block read where it lies) that holds no
    lock, so the threads share the cores. Codes of another decoding, float heights with NaN and
    ``use_cluster_diff`` take :func:`adaptive_step` instead (numpy and scipy; a column block
    copied into a transposed array and back), which gives the same marks.
    """
    dtype = z.dtype if decode is not None else np.dtype(np.float64)
    usable = in_place and z.dtype == dtype and z.flags.c_contiguous and z.flags.writeable
    zc = z if usable else np.array(z, dtype=dtype, copy=True)
    mark = np.zeros(zc.shape, mark_dtype(max(p.window_series)))  # int16 unless a window is huge
    rules = StepRules.of(p)
    nr, nc = zc.shape
    linear = rise.scale_and_offset(decode)
    compiled = not rules.use_cluster_diff and (linear is not None or (decode is None and not np.isnan(zc).any()))

    def block(a: int, k: int, ct: float, axis: int) -> None:
        b = min(a + (BLOCK_ROWS if axis == 1 else BLOCK_COLUMNS), nr if axis == 1 else nc)
        if compiled:
            adaptive = (ct, rules.max_threshold_divisor) if k >= rules.init_thresh_bin else None
            line_pass.filter_lines(zc, mark, a, b, axis, k, k, *decision_band(k, ct, rules), adaptive,
                                   rules.edges == "trend", linear)
        elif axis == 1:
            m = mark[a:b]
            removed, zo = adaptive_step(zc[a:b], m == 0, k, ct, rules, decode=decode)
            zc[a:b] = zo
            np.copyto(m, k, where=removed)
        else:
            m = mark[:, a:b]
            zt = np.ascontiguousarray(zc[:, a:b].T)
            removed, zo = adaptive_step(zt, np.ascontiguousarray((m == 0).T), k, ct, rules, decode=decode)
            zc[:, a:b] = zo.T
            np.copyto(m, k, where=removed.T)

    with ThreadPoolExecutor(max_workers=max(1, workers or thread_budget())) as pool:
        for k, ct, direction in passes(p):
            axis, lines, step = (1, nr, BLOCK_ROWS) if direction == "row" else (0, nc, BLOCK_COLUMNS)
            list(pool.map(lambda a, k=k, ct=ct, axis=axis: block(a, k, ct, axis), range(0, lines, step)))
    return mark


def combine_directions(row_marks: np.ndarray | None, column_marks: np.ndarray | None) -> np.ndarray:
    """Non-ground when either direction removed the cell (§6.2.5); the row's window wins."""
    if row_marks is None:
        assert column_marks is not None, "one direction at least"
        return column_marks
    if column_marks is None:
        return row_marks
    np.copyto(row_marks, column_marks, where=row_marks == 0)
    return row_marks


def run_directions(z: np.ndarray, row_fn: Callable[[np.ndarray], np.ndarray] | None,
                   column_fn: Callable[[np.ndarray], np.ndarray] | None) -> np.ndarray:
    """Filter rows and columns independently (two threads: numpy and scipy release the GIL)."""
    jobs = []
    with ThreadPoolExecutor(max_workers=min(2, thread_budget())) as pool:
        if row_fn is not None:
            jobs.append(("row", pool.submit(row_fn, z)))
        if column_fn is not None:
            jobs.append(("column", pool.submit(column_fn, z)))
        done = {name: fut.result() for name, fut in jobs}
    return combine_directions(done.get("row"), done.get("column"))


def gapm_reach(p: GapmParams) -> int:
    """The progressive 2-D openings, then the row and column passes on their result, and the
    raised spans (a span and the cells bounding it); the raised-segment and surface tests after
    them are not bounded (a segment may be any size)."""
    rows = sum(2 * k for k in (p.row_windows or ()))
    columns = sum(2 * k for k in (p.column_windows or ()))
    spans = math.ceil(p.object_span / p.cell) + 1 if p.object_step > 0 and p.object_span > 0 else 0
    return sum(2 * k for k in p.window_series) + max(rows, columns) + spans + low_outlier_reach(p)


def gapm_needs_every_point(p: GapmParams) -> str | None:
    """Why gapm must see every point at once: ``--auto`` derives its cell and windows from them."""
    return "--auto derives the cell and windows from all the points at once" if p.auto else None


def gapm_with_points(p: GapmParams, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> tuple[GapmParams, str]:
    """``--auto`` applied to the points (:func:`with_auto`), and what the job's log says of it."""
    p = with_auto(p, x, y, z)
    return p, (f"--auto: cell = {p.cell:g} m, window_series = {list(p.window_series)}, "
               f"row_windows = {list(p.row_windows or ())}, column_windows = {list(p.column_windows or ())}")


@register_filter("gapm", params=GapmParams, reach=gapm_reach, takes_codes=True,
                 needs_every_point=gapm_needs_every_point, with_points=gapm_with_points,
                 summary="generalized adaptive morphological filter with cluster and trend analysis "
                         "(dissertation ch. 6)")
def gapm(z: np.ndarray, empty: np.ndarray, params: GapmParams, *, in_place: bool = False,
         decode: Decode | None = None) -> np.ndarray:
    """Mark matrix of the generalized adaptive morphological filter (dissertation ch. 6).

    Empty cells take part as interpolated ground candidates (mark -7777 of Table 5-1); the
    driver marks them interpolated afterwards. ``in_place``: ``z`` may be overwritten.
    ``decode``: ``z`` holds height codes that it turns into heights.
    """
    p = params  # series checked when the params were made (GapmParams.check)
    if p.directions == "sequential":
        marks = adaptive_sequential(z, p, in_place=in_place, decode=decode)
        log.debug("gapm: %d of %d cells removed", int((marks > 0).sum()), marks.size)
        return marks
    if decode is not None:
        z = decode(z)
    opts: dict[str, Any] = StepRules.of(p)._asdict()
    fns = []
    for direction, axis in (("row", 1), ("column", 0)):
        mine = [(k, ct) for k, ct, d in passes(p) if d == direction]
        fns.append(functools.partial(adaptive_rows, windows=tuple(k for k, _ in mine),
                                     cluster_thresholds=tuple(ct for _, ct in mine), axis=axis, **opts)
                   if mine else None)
    marks = run_directions(z, *fns)
    log.debug("gapm: %d of %d cells removed", int((marks > 0).sum()), marks.size)
    return marks.astype(np.int32, copy=False)


def with_auto(params: GapmParams, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> GapmParams:
    """``params`` with the cell and windows derived from the data (``aldpat filter gapm --auto``,
    :func:`aldpat.core.auto_windows.auto_windows`, the raised-segment test's step and share
    choosing the largest object: gapm's default step where the test is turned off). Every other
    parameter is kept as given."""
    chosen = auto_windows(x, y, z, step=params.object_step or GapmParams().object_step,
                          share=params.object_share, origin=params.origin)
    return dataclasses.replace(
        params, cell=chosen.cell, window_series=tuple(chosen.rows), cluster_thresholds=tuple(chosen.rows.values()),
        row_windows=tuple(chosen.rows), column_windows=tuple(chosen.columns), auto=False)


def auto_params(x: np.ndarray, y: np.ndarray, z: np.ndarray, **values: Any) -> GapmParams:
    """``GapmParams(**values)`` with ``--auto`` applied to the points."""
    return with_auto(GapmParams(**values), x, y, z)
