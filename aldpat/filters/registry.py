"""The filter registry: every ground filter registers itself by name in :data:`FILTERS`.

A grid filter is a function ``fn(z, empty, params) -> marks`` (:mod:`aldpat.filters.driver` says
what it gets and gives); a point filter, registered with ``on_points=True``, is ``fn(x, y, z,
grid, params) -> point marks``.
"""

from __future__ import annotations

import difflib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np

from aldpat.core.lowest_grid import LowestGrid
from aldpat.errors import ParamError
from aldpat.filters.options import GroundParams, PointFilterParams

FilterFn = Callable[[np.ndarray, np.ndarray, object], np.ndarray]
#: A point filter: ``fn(x, y, z, grid, params) -> point marks`` (int32, 0 for ground); ``grid`` is
#: the lowest-point grid of the filter's own cells (:func:`cell_grid`).
PointFilterFn = Callable[[np.ndarray, np.ndarray, np.ndarray, LowestGrid, object], np.ndarray]
#: The function a filter registers (returned unchanged by :func:`register_filter`).
Registered = TypeVar("Registered", bound=Callable[..., np.ndarray])


def _needs_no_more(params: Any) -> str | None:
    """A filter that takes its points as they come (chunk by chunk, streamed): no reason to see them all."""
    return None


@dataclass(frozen=True)
class FilterSpec:
    """A registered filter: a grid filter (``fn`` on a mark matrix) or, when ``on_points``, a
    point filter (``fn(x, y, z, grid, params)`` returning every point's mark)."""

    name: str
    summary: str
    params: type
    fn: Callable[..., np.ndarray]  # a FilterFn, or a PointFilterFn when on_points
    #: params -> rotation angles in degrees (the manual's Rotate Angle / Rotate Times);
    #: ``None``: the data are filtered once, unrotated.
    rotations: Callable[[Any], Sequence[float]] | None = None
    on_points: bool = False
    #: ``noise(result, z, params)``: per point -1 low noise, +1 high noise, 0 neither, for a
    #: filter that finds noise rather than ground (``outlier``); ``None``: it finds none.
    noise: Callable[..., np.ndarray] | None = None
    #: ``reach(params) -> cells``: how far from a cell the cells its mark depends on may lie
    #: (the windows of the morphological steps, each opening reaching twice its half window);
    #: ``--chunk-buffer auto`` is this many cells. ``None``: the filter does not know.
    reach: Callable[[Any], int] | None = None
    #: ``buffer(params) -> metres``: for a filter without a bounded reach (a point filter whose
    #: steps spread without a limit), the chunk buffer ``--chunk-buffer auto`` gives it: measured,
    #: not proven (``bench/bench_chunks.py agree``).
    buffer: Callable[[Any], float] | None = None
    #: ``fn(codes, empty, params, in_place=..., decode=...)`` takes the filled grid as height
    #: codes (:mod:`aldpat.core.height_codes`; ``decode`` gives their heights), and may overwrite
    #: them when ``in_place``: the filter's working surface at the codes' size, no float64 copy.
    takes_codes: bool = False
    #: ``needs_every_point(params) -> why | None``: why the filter with these params must see
    #: every point of a file at once before it runs (gapm's ``--auto`` derives its cell and
    #: windows from them), None when it need not. Such a run is neither streamed nor chunked, and
    #: :attr:`with_points` completes its params first.
    needs_every_point: Callable[[Any], str | None] = _needs_no_more
    #: ``with_points(params, x, y, z) -> (params, note)``: the params derived from every point
    #: where :attr:`needs_every_point` says so, and what the job's log says of them.
    with_points: Callable[..., tuple[Any, str]] | None = None

    def check_chunks(self, params: Any) -> None:
        """Refuse (:class:`ParamError`) ``--chunk`` with params that make the filter need every
        point at once (:attr:`needs_every_point`): a chunk holds only some. The command checks
        it when its parameters are resolved, :func:`~aldpat.filters.driver.ground_filter` when
        it is called, in the same words."""
        why = self.needs_every_point(params) if params.chunk is not None else None
        if why is not None:
            raise ParamError(f"chunk: a chunk holds only some of the points, and {why}; run the file whole, or run it "
                             "once whole and pass what its log says was derived")


#: Every registered grid filter by name (filled by importing :mod:`aldpat.filters`).
FILTERS: dict[str, FilterSpec] = {}


def register_filter(name: str, *, params: type, summary: str,
                    rotations: Callable[[Any], Sequence[float]] | None = None, on_points: bool = False,
                    noise: Callable[..., np.ndarray] | None = None, reach: Callable[[Any], int] | None = None,
                    buffer: Callable[[Any], float] | None = None, takes_codes: bool = False,
                    needs_every_point: Callable[[Any], str | None] | None = None,
                    with_points: Callable[..., tuple[Any, str]] | None = None
                    ) -> Callable[[Registered], Registered]:
    """Decorator registering ``fn(z, empty, params) -> marks`` as the grid filter ``name``, or
    with ``on_points`` ``fn(x, y, z, grid, params) -> point marks`` as the point filter ``name``."""
    base = PointFilterParams if on_points else GroundParams
    if not (isinstance(params, type) and issubclass(params, base)):
        raise TypeError(f"filter {name!r}: params must subclass {base.__name__}")
    if (needs_every_point is None) != (with_points is None):
        raise TypeError(f"filter {name!r}: needs_every_point and with_points go together")

    def deco(fn: Registered) -> Registered:
        if name in FILTERS and FILTERS[name].fn is not fn:
            raise ValueError(f"filter {name!r} is registered twice")
        FILTERS[name] = FilterSpec(name=name, summary=summary, params=params, fn=fn, rotations=rotations,
                                   on_points=on_points, noise=noise, reach=reach,
                                   buffer=buffer, takes_codes=takes_codes,
                                   needs_every_point=needs_every_point or _needs_no_more, with_points=with_points)
        return fn

    return deco


def get_filter(name: str) -> FilterSpec:
    """The registered filter ``name``; a :class:`ParamError` with a suggestion otherwise."""
    spec = FILTERS.get(name)
    if spec is None:
        hint = difflib.get_close_matches(name, list(FILTERS), n=1)
        did = f"; did you mean {hint[0]!r}?" if hint else ""
        raise ParamError(f"unknown filter {name!r} (known: {', '.join(sorted(FILTERS))}){did}")
    return spec
