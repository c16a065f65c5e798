"""Options shared by the ALDPAT data-preparation tasks, declared once and subclassed.

The ALDPAT 1.0 user manual (2007, "4. Description of Tasks") names the same two choices in several
tasks: "Fields" (XYZI or XYZ, tasks 2 and 7) and the column order of the 9-column tapes
(task 1: "t, x2, y2, z2, i2, x1, y1, z1, i1" by default, "t, x1, y1, z1, i1, x2, y2, z2, i2"
when REALM exported it the other way). Grid tasks share the cell-grid origin.
A module whose name starts with "_" is not imported as a task.
"""

from __future__ import annotations

from dataclasses import dataclass

from aldpat.params import merge_params, param


@dataclass(frozen=True)
class FieldsOption:
    fields: str = param("xyzi", "columns written to text outputs: x y z and intensity, or x y z only",
                        choices=("xyzi", "xyz"), manual="Fields")


@dataclass(frozen=True)
class OrderOption:
    order: str = param("last-first", "column order of 9-column tapes: t x2 y2 z2 i2 x1 y1 z1 i1 (last return "
                       "first, the manual's) or t x1 y1 z1 i1 x2 y2 z2 i2", choices=("last-first", "first-last"))


@dataclass(frozen=True)
class OriginOption:
    origin: tuple[float, float] | None = param(
        None, "grid origin X Y (default: cells aligned to whole multiples of the cell size)", unit="m",
        metavar="X Y",
    )


def with_shared(own: type, *shared: type) -> type:
    """A params class with the task's own fields first and the shared options after them (so
    ``--help`` lists the task's parameters first), named and placed like ``own`` minus its
    leading underscore, so that it pickles for ``-j N`` workers."""
    name = own.__name__.lstrip("_")
    cls = merge_params(own, *shared, name=name)
    cls.__module__ = own.__module__
    cls.__qualname__ = name
    cls.__doc__ = own.__doc__
    return cls


def kept_names(reader, out) -> tuple[str, ...]:
    """Columns a task that keeps whole points writes: every column, except that LAS/LAZ going to
    text keeps x y z and intensity (as ``convert`` does), not the LAS flags."""
    if reader.format == "las" and str(out).lower().endswith((".las", ".laz")):
        return reader.names
    if reader.format == "las":
        return point_names(reader, "xyzi")
    return reader.names


def point_names(reader, fields: str) -> tuple[str, ...]:
    """Columns a point output carries: x y z, plus intensity when asked for and present."""
    names = ("x", "y", "z")
    if fields == "xyzi" and "intensity" in reader.names:
        names += ("intensity",)
    return names

