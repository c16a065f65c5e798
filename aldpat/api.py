"""aldpat from Python: ground points and terrain models as values, not files.

The functions a notebook or a script calls (re-exported by :mod:`aldpat`; ``docs/api.md`` shows
them at work). They take points as a user has them -- a path, a laspy ``LasData``, an (N, 3)
array or an ``(x, y, z)`` tuple -- and return numpy values, with the parameters of the commands
checked when the call is made. They run the code the commands run (``aldpat filter`` and
``aldpat dtm`` call :func:`aldpat.tasks.filter.classify_points` and
:func:`aldpat.tasks.dtm.terrain_raster` too), so that a result here is the command's for the same
points and parameters; only reading and writing files is left to the commands.
"""

from __future__ import annotations

import dataclasses
import os
import sys
import types
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from aldpat.core.interpolate import BYTES_PER_NODE
from aldpat.core.paths import not_local
from aldpat.errors import ParamError, shown
from aldpat.filters.driver import refuse_not_finite
from aldpat.filters.options import FilterOutputOption
from aldpat.filters.registry import FILTERS
from aldpat.io.geotiff import Raster
from aldpat.io.las import las_table
from aldpat.io.registry import open_points
from aldpat.io.table import PointTable
from aldpat.io.toml import load_toml
from aldpat.options import ChunkOption
from aldpat.params import resolve, spec_map, unknown_key_error
from aldpat.tasks.dtm import (
    LOW_OUTLIER_KEYS,
    DtmParams,
    filtered_ground,
    occupancy_over,
    points_used,
    terrain_raster,
)
from aldpat.tasks.filter import classify_points
from aldpat.tasks.grid import grid_spec_for

__all__ = ["Raster", "dtm", "ground"]

#: Parameters of a filter that say what ``aldpat filter`` writes or how it splits a file (its
#: output options, ``--chunk``...), not how ground is found: a function returning every point's
#: class has no use for them.
COMMAND_ONLY = frozenset(
    {f.name for f in dataclasses.fields(FilterOutputOption)} | {f.name for f in dataclasses.fields(ChunkOption)}
)

#: ``aldpat dtm``'s own parameters a call takes (beside ``cell`` and ``algorithm``): the others
#: name files (tiles, a mosaic) or say how the command writes (``grid_format``: see
#: :meth:`Raster.write`), and ``buffer`` reaches into other inputs, of which a call has none.
DTM_KEYS = ("origin", "crs", "nodata", "max_distance", "max_gap", "auto", "filter_params")

Points = Any  # a path, a laspy.LasData, an (N, 3) array or an (x, y, z) tuple


def ground(points: Points, algorithm: str = "gapm", **params: Any) -> np.ndarray:
    """Which points are ground: a numpy bool array, one per point in the input's order.

    ``points`` is a path (LAS, LAZ or ASCII, as ``aldpat filter`` reads it), a laspy ``LasData``
    or its points (``las.points[keep]``), an (N, 3) array of x, y, z or an ``(x, y, z)`` tuple of
    arrays. ``algorithm`` is a filter of ``aldpat filter`` (``gapm`` by default: start with it) and ``params`` its parameters, named
    as its ``--params`` file names them (``cell=1.5``, ``auto=True``). True is what ``aldpat
    filter ALGO --result classified`` writes as class 2 for the same points and parameters.

    Raises :class:`aldpat.ParamError` (a ``ValueError``) naming the parameter when one is
    unknown or out of range, before any point is read.
    """
    spec_params = filter_params(algorithm, params, where="ground: ")
    table, _ = _table(points)
    _, classes = classify_points(table, algorithm, spec_params)
    return np.asarray(classes == 2)


def dtm(points: Points, cell: float = 1.0, algorithm: str = "gapm", **params: Any) -> Raster:
    """A bare-earth terrain model: the ground points of ``algorithm`` triangulated onto nodes
    ``cell`` metres apart, as ``aldpat dtm --cell CELL`` makes it from the same points.

    ``points`` as for :func:`ground`. ``params`` are ``aldpat dtm``'s ``origin``, ``crs``
    (default: a LAS input's own), ``nodata`` (-9999), ``max_distance``, ``max_gap`` (nodes with
    no point of any class within it are blank: ``"auto"``, the default, metres, or ``"none"``)
    and ``auto``, and the
    filter's own parameters, either as keywords (``slope_threshold=0.4``) or, for the filter's
    ``cell`` too, as ``filter_params`` -- a mapping or the TOML file ``aldpat dtm
    --filter-params`` takes. As in the command, a LAS's withheld points, those of
    ``ignore_classes`` (noise: 7 and 18) and, with ``returns``, the other returns take no part in
    finding ground; all of them count as data for ``max_gap``.

    Returns a :class:`Raster`: ``.array`` (float32, first row north, ``.nodata`` at blank
    nodes), ``.transform``, ``.crs``, ``.nodata`` and ``.write(path)``.
    """
    own: dict[str, Any] = {}
    rest: dict[str, Any] = {}
    for key, value in params.items():
        name = key.replace("-", "_")
        if name in spec_map(DtmParams) and name not in DTM_KEYS and name not in LOW_OUTLIER_KEYS:
            raise ParamError(f"dtm: {key}: an option of the command 'aldpat dtm' (tiles, its files); a call "
                             "returns one Raster")
        (own if name in DTM_KEYS else rest)[key] = value
    layers: dict[str, Any] = {"cell": cell, "algorithm": algorithm, **own}
    given = layers.pop("filter_params", None)
    dtm_params = resolve(DtmParams, [("call", layers)], where="dtm: ").values
    filter_layer: dict[str, Any] = {}
    if isinstance(given, Mapping):
        filter_layer.update(given)
    elif isinstance(given, (str, os.PathLike)):
        filter_layer.update(load_toml(_local_file(given, "dtm: filter_params")))
    elif given is not None:
        raise ParamError(f"dtm: filter_params: expected a mapping of the filter's parameters or the path of a TOML "
                         f"file, got {type(given).__name__}")
    filter_layer.update(rest)
    if dtm_params.auto:
        filter_layer["auto"] = True
    ground_params = filter_params(dtm_params.algorithm, filter_layer, where="dtm: ")
    table, crs = _table(points)
    spec = grid_spec_for(dtm_params, xy=(table.x, table.y))
    assert spec is not None  # from the points
    # as the command refuses it (before numpy's MemoryError for 37 GiB, or the machine swapping)
    spec.check_fits(BYTES_PER_NODE["linear"], change="use a larger cell")
    occupancy = occupancy_over(spec, 0.0)
    occupancy.add(table.x, table.y)  # every point, of any class: a node near noise is no data gap
    # as the command, the filter sees only the points taking part (a LAS's withheld points, its
    # ignore_classes and other returns stay out); x, y, z have no classes: all of them do
    used = table.take(points_used(dtm_params, ground_params)(table))
    ground = filtered_ground(used.x, used.y, used.z, dtm_params, ground_params)
    raster, _ = terrain_raster(used.x[ground], used.y[ground], used.z[ground], spec, dtm_params,
                               crs=dtm_params.crs or crs, occupancy=occupancy)
    return raster


def filter_params(algorithm: str, values: Mapping[str, Any], where: str = "") -> Any:
    """The parameters of filter ``algorithm``: its defaults with ``values`` (the method's own
    parameters, not the command's output options), checked."""
    if algorithm not in FILTERS:
        raise ParamError(f"{where}algorithm: no filter {algorithm!r}; the filters are {', '.join(sorted(FILTERS))}")
    cls = FILTERS[algorithm].params
    known = [name for name in spec_map(cls) if name not in COMMAND_ONLY]
    for key in values:
        if key.replace("-", "_") not in known:
            if key.replace("-", "_") in COMMAND_ONLY:
                raise ParamError(f"{where}{key}: an option of the command 'aldpat filter' (what it writes, how it "
                                 "splits a file); a call returns every point's class")
            raise unknown_key_error(key, known, where)
    return resolve(cls, [("call", values)], where=where).values


def _local_file(path: str | os.PathLike, what: str) -> Path:
    """``path`` as a local file's: a URL or a GDAL virtual file system path (``http://``,
    ``/vsicurl/``) is refused by name -- ``Path`` would make ``http:/host/x.laz`` of it and the
    error would name a file the caller never gave."""
    text = os.fspath(path)
    why = not_local(text) if isinstance(text, str) else "not a text path (bytes)"
    if why is not None:
        raise ParamError(f"{what}: {shown(text)} is {why}")
    return Path(text)


def _table(points: Points) -> tuple[PointTable, Any]:
    """``points`` as a table of x, y, z (and, from LAS, every attribute), with its CRS if it has one."""
    if isinstance(points, (str, os.PathLike)):
        reader = open_points(_local_file(points, "points"))
        return reader.read(), getattr(reader, "crs", None)
    if hasattr(points, "header") and hasattr(points, "points"):  # a laspy.LasData
        return las_table(points), _las_crs(points)
    if type(points).__name__ == "ScaleAwarePointRecord":  # las.points[keep]: no header, so no CRS
        return las_table(points), None
    if isinstance(points, tuple) and len(points) == 3:
        x, y, z = (_numbers(v, points) for v in points)
    else:
        xyz = _numbers(points, points)
        if xyz.ndim != 2 or xyz.shape[1] != 3:
            raise ParamError(f"points: expected a path, a laspy LasData, an (N, 3) array or an (x, y, z) tuple; "
                             f"got {type(points).__name__} of shape {xyz.shape}")
        x, y, z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    if not (x.ndim == y.ndim == z.ndim == 1 and len(x) == len(y) == len(z)):
        raise ParamError(f"points: x, y and z must be 1-D and of one length; got shapes {x.shape}, {y.shape}, "
                         f"{z.shape}")
    refuse_not_finite(x, y, z)  # before a grid is sized from them (dtm said "nan nodes a side")
    return PointTable({"x": x, "y": y, "z": z}), None


#: A coordinate's step, in metres, past which narrow floats are said to have lost the survey's
#: precision: a millimetre, what LAS files of airborne surveys keep.
FINEST_STEP = 0.001


def _numbers(values: Any, points: Points) -> np.ndarray:
    """``values`` (``points`` or one of its x, y, z) as float64: numpy's own error for text or a
    mapping names no argument, so the one raised names ``points``, as every other bad input does.

    Coordinates held in float32 (or float16) arrive rounded: at UTM northings (5.4e6 m) float32
    keeps steps of 0.5 m, and the filter then grids points that are not where the survey put
    them. Nothing can bring the digits back, so a warning says so and the points are filtered as
    given."""
    given = getattr(values, "dtype", None)
    if given is not None and np.dtype(given).kind == "c":  # numpy would drop the imaginary parts with a warning
        raise ParamError(f"points: expected real coordinates, got an array of {np.dtype(given).name}")
    try:
        out = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise ParamError(f"points: expected a path, a laspy LasData, an (N, 3) array or an (x, y, z) tuple of "
                         f"numbers; got {type(points).__name__}: {err}") from None
    if given is not None and np.dtype(given).kind == "f" and np.dtype(given).itemsize < 8 and out.size:
        largest = float(np.nanmax(np.abs(out))) if np.isfinite(out).any() else 0.0
        step = float(np.spacing(np.asarray(largest, dtype=given)))
        if step > FINEST_STEP:
            warnings.warn(f"points: {np.dtype(given).name} coordinates as large as {largest:.6g} hold steps of "
                          f"{step:g} m; they are filtered as given (pass float64 to keep the survey's precision)",
                          UserWarning, stacklevel=_callers_level())
    return out


def _callers_level() -> int:
    """The ``stacklevel`` of the first frame outside aldpat, seen from the function calling this
    one: where a warning about a call's arguments belongs."""
    package = os.path.dirname(os.path.abspath(__file__))
    level = 1
    frame: types.FrameType | None = sys._getframe(1)
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(package + os.sep):
        frame, level = frame.f_back, level + 1
    return level


def _las_crs(las: Any) -> Any:
    try:
        return las.header.parse_crs()
    except Exception:  # noqa: BLE001  (as LasReader: a CRS record PROJ cannot read leaves the points usable)
        return None
