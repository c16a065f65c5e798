"""``aldpat preview``: quick-look pictures (PNG) to see whether a run worked before opening
anything in a GIS -- what ALDPAT's GUI views gave.

* a grid (Surfer ``.grd``, ArcGIS ``.flt`` / ``.asc``, GeoTIFF ``.tif``, the ``.vrt`` mosaic of
  ``aldpat grid --mosaic``) -> ``<stem>_hillshade.png``:
  its hillshade (:mod:`aldpat.core.hillshade`), one pixel per node (a GeoTIFF or a mosaic
  longer than :data:`GRID_LONGEST` nodes: every k-th node), north up, blank nodes transparent, with its world file ``<stem>_hillshade.pgw`` (:mod:`aldpat.io.worldfile`);
* a point file -> ``<stem>_plan.png``: a plan view, north up, at most ``size`` pixels on its
  longer side and pixels no finer than twice the mean point spacing, each pixel coloured by the highest point in it (``--color-by elevation``, low blue to high
  brown) or by its class (``--color-by class``: green where a ground point falls -- LAS class 2,
  or 2 in the class column ``aldpat filter --result classified`` writes
  (:mod:`aldpat.io.classified`) -- grey where only other points do); pixels without points are
  transparent; with its world file ``<stem>_plan.pgw``.

PNGs are written with Pillow, an optional extra (``pip install 'aldpat[preview]'``).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from aldpat.core.grid_extent import GridSpec
from aldpat.core.hillshade import hillshade
from aldpat.core.lowest_grid import fill_nearest
from aldpat.errors import DataError, UsageError
from aldpat.io.atomic import atomic_outputs
from aldpat.io.classified import ground_of
from aldpat.io.esri_grid import read_ascii_grid, read_float_grid
from aldpat.io.geotiff import read_geotiff
from aldpat.io.surfer import read_surfer
from aldpat.io.worldfile import NorthUp, world_path
from aldpat.jobs.context import JobContext
from aldpat.jobs.registry import register_task
from aldpat.jobs.task import Planned, Task
from aldpat.params import param

GRID_EXTENSIONS = (".grd", ".flt", ".asc", ".tif", ".tiff", ".vrt")
#: the longer side of a GeoTIFF's or a mosaic's hillshade at most (pixels): one pixel per node up
#: to it, every k-th node beyond (a county's 1 m mosaic is tens of thousands of nodes a side)
GRID_LONGEST = 4000
#: elevation colours, low to high (blue, green, yellow, brown, white)
RAMP = np.array([[40, 80, 200], [60, 160, 80], [230, 220, 110], [150, 100, 60], [250, 250, 250]], float)
GROUND_RGB = (60, 160, 60)
OTHER_RGB = (160, 160, 160)


@dataclass(frozen=True)
class PreviewParams:
    azimuth: float = param(315.0, "direction the light of a hillshade comes from, clockwise from north",
                           unit="degrees", ge=0, lt=360, level="advanced")
    altitude: float = param(45.0, "height of that light above the horizon", unit="degrees", gt=0, le=90,
                            level="advanced")
    z_factor: float = param(1.0, "vertical exaggeration of a hillshade", gt=0)
    color_by: str = param("elevation", "colour of a point plan view: the highest point's elevation, or "
                          "ground (green) / other (grey)", choices=("elevation", "class"))
    size: int = param(1000, "longer side of a point plan view at most (pixels are never finer than twice "
                      "the mean point spacing)", unit="pixels", ge=16, le=20000)


def _pillow() -> Any:
    try:
        return importlib.import_module("PIL.Image")
    except ImportError:
        raise UsageError("previews need the optional image library Pillow: pip install 'aldpat[preview]'") from None


def read_grid(path: Path) -> tuple[np.ndarray, GridSpec]:
    """Any grid aldpat writes, rows from the south, NaN for blank nodes (GeoTIFF and the VRT
    mosaic through GDAL)."""
    ext = path.suffix.lower()
    if ext == ".grd":
        return read_surfer(path)
    if ext == ".flt":
        return read_float_grid(path)
    if ext == ".asc":
        return read_ascii_grid(path)
    return read_geotiff(path, longest=GRID_LONGEST)


def save_png(rgba: np.ndarray, out: Path, overwrite: bool, place: NorthUp | None = None) -> list[Path]:
    """Write the picture, and with ``place`` its world file beside it (GIS programs place the
    picture from it; the run report draws a scale bar and coordinates): both, or neither."""
    image = _pillow()
    paths = [out] if place is None else [out, world_path(out)]
    with atomic_outputs(paths, overwrite=overwrite) as tmps:
        image.fromarray(np.ascontiguousarray(rgba)).save(tmps[0], format="PNG")  # (h, w, 4) uint8: RGBA
        if place is not None:
            tmps[1].write_text(place.world_lines(), encoding="ascii")
    return paths


def grid_place(spec: GridSpec) -> NorthUp:
    """Where a grid's picture lies: one pixel per node, centred on it."""
    return NorthUp(spec.xmin - spec.dx / 2, spec.ymax + spec.dy / 2, spec.dx, spec.dy)


def hillshade_rgba(values: np.ndarray, spec: GridSpec, params: PreviewParams) -> np.ndarray:
    """The hillshade as an RGBA image (north up), blank nodes transparent."""
    blank = ~np.isfinite(values[::-1])
    # blank nodes take their nearest node's height for the shading of their neighbours only
    north_up = fill_nearest(values[::-1], blank)
    shade = hillshade(north_up, spec.dx, spec.dy, azimuth=params.azimuth, altitude=params.altitude,
                      z_factor=params.z_factor)
    gray = np.where(blank, 0, np.rint(shade)).astype(np.uint8)
    return np.dstack([gray, gray, gray, np.where(blank, 0, 255).astype(np.uint8)])


def plan_place(x: np.ndarray, y: np.ndarray, size: int, spacings: float = 2.0) -> tuple[NorthUp, int, int]:
    """Where a plan view of the points lies, and its rows and columns: at most ``size`` pixels on
    its longer side, pixels no finer than ``spacings`` mean point spacings."""
    x0, x1, y0, y1 = float(x.min()), float(x.max()), float(y.min()), float(y.max())
    spacing = np.sqrt(max((x1 - x0) * (y1 - y0), 1e-12) / len(x))
    pixel = max(max(x1 - x0, y1 - y0) / (size - 1), spacings * spacing) or 1.0
    cols, rows = int((x1 - x0) / pixel) + 1, int((y1 - y0) / pixel) + 1
    return NorthUp(x0, y1, pixel, pixel), rows, cols


def plan_pixels(x: np.ndarray, y: np.ndarray, size: int, spacings: float = 2.0) -> tuple[np.ndarray, int, int]:
    """Each point's pixel (flat index, row 0 the north) in the plan view of :func:`plan_place`;
    and the rows and columns."""
    place, rows, cols = plan_place(x, y, size, spacings)
    c = np.minimum(((x - place.west) / place.dx).astype(np.int64), cols - 1)
    r = np.minimum(((place.north - y) / place.dy).astype(np.int64), rows - 1)
    return r * cols + c, rows, cols


def plan_rgba(x: np.ndarray, y: np.ndarray, z: np.ndarray, ground: np.ndarray | None, size: int) -> np.ndarray:
    """Plan view of points (north up, at most ``size`` pixels on the longer side, pixels no finer
    than twice the mean point spacing)."""
    # no finer than twice the mean point spacing: about four points a pixel, so that the picture
    # shows a surface (98 % of pixels hold a point where the points are spread evenly), not dots
    flat, rows, cols = plan_pixels(x, y, size)
    rgba = np.zeros((rows * cols, 4), np.uint8)
    if ground is None:
        top = np.full(rows * cols, -np.inf)
        np.maximum.at(top, flat, z)
        has = np.isfinite(top)
        t = (top[has] - z.min()) / (np.ptp(z) or 1.0) * (len(RAMP) - 1)
        k = np.minimum(t.astype(np.int64), len(RAMP) - 2)
        frac = (t - k)[:, None]
        rgba[has, :3] = np.rint(RAMP[k] * (1 - frac) + RAMP[k + 1] * frac).astype(np.uint8)
    else:
        has = np.zeros(rows * cols, bool)
        has[flat] = True
        is_ground = np.zeros(rows * cols, bool)
        is_ground[flat[ground]] = True
        rgba[has, :3] = OTHER_RGB
        rgba[is_ground, :3] = GROUND_RGB
    rgba[has, 3] = 255
    return rgba.reshape(rows, cols, 4)


#: colours of :func:`calls_rgba`, by call: right object, right ground, object accepted (Type II),
#: bare earth rejected (Type I) -- a pixel shows the last of these any of its points has
CALL_RGB = np.array([[175, 175, 175], [120, 185, 110], [40, 90, 230], [225, 40, 40]], np.uint8)
OBJECT_RIGHT, GROUND_RIGHT, TYPE_II, TYPE_I = range(4)


def calls_rgba(x: np.ndarray, y: np.ndarray, reference_ground: np.ndarray, called_ground: np.ndarray,
               size: int) -> np.ndarray:
    """Map of a classification's right and wrong calls (north up), one pixel about a point
    spacing (errors must not hide among four right calls), enlarged to at least ``MAP_MIN`` pixels
    on its longer side so that a sample of a few thousand points is not a thumbnail."""
    call = np.where(reference_ground, np.where(called_ground, GROUND_RIGHT, TYPE_I),
                    np.where(called_ground, TYPE_II, OBJECT_RIGHT))
    flat, rows, cols = plan_pixels(x, y, size, spacings=1.0)
    worst_flat = np.full(rows * cols, -1)
    np.maximum.at(worst_flat, flat, call)
    worst = worst_flat.reshape(rows, cols)
    # scan lines leave pixels between points empty: they take their nearest call up to two
    # pixels away, so that the map reads as areas; farther (outside the data) stays transparent
    empty = worst < 0
    if empty.any() and not empty.all():
        from scipy import ndimage

        distance, (nr, nc) = ndimage.distance_transform_edt(empty, return_indices=True)
        near = empty & (distance <= 2.0)
        worst[near] = worst[nr[near], nc[near]]
    rgba = np.zeros((rows, cols, 4), np.uint8)
    has = worst >= 0
    rgba[has, :3] = CALL_RGB[worst[has]]
    rgba[has, 3] = 255
    zoom = map_zoom(rows, cols)
    return np.repeat(np.repeat(rgba, zoom, axis=0), zoom, axis=1)


def calls_place(x: np.ndarray, y: np.ndarray, size: int) -> NorthUp:
    """Where the map of :func:`calls_rgba` of the same points lies."""
    place, rows, cols = plan_place(x, y, size, spacings=1.0)
    return place.scaled(map_zoom(rows, cols))


#: a map of calls is enlarged (each pixel repeated) to at least this many pixels on its longer side
MAP_MIN = 600


def map_zoom(rows: int, cols: int) -> int:
    """How many times a map of calls repeats each pixel each way (:data:`MAP_MIN`)."""
    return max(1, -(-MAP_MIN // max(rows, cols)))


def _ground_of(reader, table, source: Path) -> np.ndarray:
    ground = ground_of(reader, table)
    if ground is not None:
        return ground
    raise DataError("--color-by class needs classes: LAS classification or a text 'class' column "
                    "(aldpat filter --result classified writes them)", path=source)


def preview_outputs(source: Path, params: PreviewParams, ctx: JobContext) -> list[Planned]:
    """``<stem>_hillshade.png`` of a grid, ``<stem>_plan.png`` of points, each with its world file."""
    grid = source.suffix.lower() in GRID_EXTENSIONS
    out = ctx.output_path(source, "_hillshade" if grid else "_plan", ".png")
    return [Planned(out, source), Planned(world_path(out), source)]


def preview_one(source: Path, params: PreviewParams, ctx: JobContext) -> None:
    out = ctx.outputs_for(source)[0].path
    if source.suffix.lower() in GRID_EXTENSIONS:
        values, spec = read_grid(source)
        if not np.isfinite(values).any():
            raise DataError("every node is blank: nothing to shade", path=source)
        rgba = hillshade_rgba(values, spec, params)
        place = grid_place(spec)
    else:
        reader = ctx.open_input(source)
        table = reader.read()
        if len(table) == 0:
            raise DataError("no points to draw", path=source)
        ground = _ground_of(reader, table, source) if params.color_by == "class" else None
        x, y = np.asarray(table.x), np.asarray(table.y)
        rgba = plan_rgba(x, y, np.asarray(table.z), ground, params.size)
        place = plan_place(x, y, params.size)[0]
    for path in save_png(rgba, out, ctx.overwrite, place):
        ctx.wrote(path)


register_task(Task(
    name="preview",
    summary="Quick-look PNGs: the hillshade of a grid, or a plan view of points by elevation or by class.",
    params=PreviewParams,
    run_one=preview_one,
    writes_points=False,
    other_inputs=GRID_EXTENSIONS,
    examples=(
        ("aldpat preview dtm/*.tif",
         "a hillshade PNG of each grid"),
        ("aldpat preview dtm.vrt --z-factor 3",
         "the relief of gentle terrain exaggerated three times"),
        ("aldpat preview ground/site_gapm.laz --color-by class",
         "a plan view of points by class"),
    ),
    outputs=preview_outputs,
))
