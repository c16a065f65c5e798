"""Polygon shapefiles through pyshp: rings oriented as the ESRI specification requires, a
``.prj`` from a CRS (pyproj, ESRI WKT1) and a ``.cpg`` naming the attribute encoding.

ESRI Shapefile Technical Description (1998), "Polygon": "The order of vertices or orientation
for a ring indicates which side of the ring is the interior of the polygon ... vertices of
outer rings are in clockwise order, holes in counterclockwise order", and every ring is closed
(first vertex repeated last). ALDPAT 1.0 user manual (2007), Task 6 "Create Shape File": one polygon per
strip; ALDPAT wrote no .prj ("Use ArcCatalog to define the projection") -- here ``crs`` writes it.

All files of the set are written under temporary names and renamed together
(:func:`aldpat.io.atomic.atomic_outputs`).
"""

from __future__ import annotations

import itertools
import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import shapefile

from aldpat.core.crs import prj_wkt
from aldpat.core.polygon import clean_ring, oriented, signed_area
from aldpat.errors import InputFormatError, InputMissingError, UsageError, one_line
from aldpat.io.atomic import atomic_outputs

log = logging.getLogger(__name__)

#: pyshp field types: name -> (type, size, decimals)
Field = tuple[str, str, int, int]


@dataclass
class Polygon:
    """One polygon: its rings (outer rings and holes, (n, 2) arrays) and attribute values."""

    rings: list[np.ndarray]
    attributes: tuple = ()


def shapefile_rings(rings: list[np.ndarray]) -> list[list[list[float]]]:
    """Rings as the shapefile stores them: outer rings clockwise, holes counter-clockwise, closed.

    A ring is a hole when it lies inside another ring of the same polygon (tested on its first
    vertex), an outer ring otherwise.
    """
    from aldpat.core.polygon import points_in_polygons

    rings = [clean_ring(r) for r in rings]
    rings = [r for r in rings if len(r) >= 3 and signed_area(r) != 0.0]
    out = []
    for k, ring in enumerate(rings):
        others = [[r] for m, r in enumerate(rings) if m != k]
        depth = sum(bool(points_in_polygons(ring[:1, 0], ring[:1, 1], [o])[0]) for o in others)
        ring = oriented(ring, clockwise=depth % 2 == 0)
        closed = np.vstack([ring, ring[:1]])
        out.append(closed.tolist())
    return out


#: the files of a polygon shapefile (a ``.prj`` beside them when the CRS is known)
PARTS = (".shp", ".shx", ".dbf", ".cpg")


def write_polygons(path: str | Path, polygons: list[Polygon], fields: list[Field], *, crs: Any = None,
                   overwrite: bool = False) -> list[Path]:
    """Write a polygon shapefile (.shp .shx .dbf .cpg and .prj when ``crs``); return the files."""
    path = Path(path)
    if path.suffix.lower() != ".shp":
        path = path.with_suffix(".shp")
    files = [path.with_suffix(s) for s in PARTS]
    if crs is not None:
        files.append(path.with_suffix(".prj"))
    # every polygon's rings before the writer opens: a refusal must not leave it half-written (its
    # finaliser then failed on the closed files with a traceback)
    shapes = [shapefile_rings(poly.rings) for poly in polygons]
    for poly, rings in zip(polygons, shapes, strict=True):
        if not rings:
            raise UsageError(f"polygon {' '.join(map(str, poly.attributes))} encloses no area (fewer than three "
                             "distinct vertices, or a boundary crossing itself to nothing)", path=path)
    with atomic_outputs(files, overwrite=overwrite) as tmps:
        with open(tmps[0], "wb") as shp, open(tmps[1], "wb") as shx, open(tmps[2], "wb") as dbf:
            w = shapefile.Writer(shp=shp, shx=shx, dbf=dbf, shapeType=shapefile.POLYGON, encoding="utf-8")
            for name, kind, size, decimal in fields:
                w.field(name, kind, size=size, decimal=decimal)
            for poly, rings in zip(polygons, shapes, strict=True):
                w.poly(rings)
                w.record(*poly.attributes)
            w.close()
        tmps[3].write_text("UTF-8\n", encoding="ascii")
        if crs is not None:
            tmps[4].write_text(prj_wkt(crs), encoding="ascii")
    return files


def read_polygons(path: str | Path) -> list[list[np.ndarray]]:
    """Every polygon of a polygon shapefile as a list of rings ((n, 2) arrays, outer and holes)."""
    path = Path(path)
    if not path.exists():
        raise InputMissingError("no such file", path=path)
    try:
        reader = shapefile.Reader(str(path))
    except Exception as exc:  # noqa: BLE001  (pyshp raises several types for damaged sets)
        raise InputFormatError(f"cannot read the shapefile ({exc})", path=path) from None
    with reader:
        if reader.shapeType not in (shapefile.POLYGON, shapefile.POLYGONZ, shapefile.POLYGONM, shapefile.NULL):
            raise InputFormatError(f"not a polygon shapefile (shape type {reader.shapeTypeName})", path=path)
        polygons: list[list[np.ndarray]] = []
        shapes = reader.iterShapes()
        while True:
            try:
                shape = next(shapes, None)
            except Exception as exc:  # noqa: BLE001  (a record claiming more points or parts than it holds)
                raise InputFormatError(f"shape {len(polygons) + 1} is damaged: {one_line(exc)}", path=path) from None
            if shape is None:
                break
            if shape.shapeType == shapefile.NULL or not shape.points:
                continue
            pts = np.asarray(shape.points, dtype=np.float64)[:, :2]
            if not np.isfinite(pts).all():
                raise InputFormatError(f"a vertex of shape {len(polygons) + 1} is not a number (NaN or infinite)",
                                       path=path)
            bounds = list(shape.parts) + [len(pts)]
            polygons.append([pts[a:b] for a, b in itertools.pairwise(bounds)])
    if not polygons:
        raise InputFormatError("the shapefile holds no polygon", path=path)
    return polygons
