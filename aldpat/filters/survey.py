"""What a survey file already says about its points, and what a filter may change of it.

A LAS as a vendor delivers it holds noise already classed (ASPRS 7 low noise, 18 high noise),
withheld points and several returns per pulse. As lasground, PDAL's smrf and lidR's
``classify_ground`` do, the points a vendor set aside take no part in finding ground and keep
their class and flags (:func:`taking_part`), and the classes a filter writes change only what the
filter decided (:func:`survey_classes`): ground becomes 2, a former 2 that is not ground 1, an
unclassified 0 becomes 1 or 2, low outliers 7 and noise 7/18; every other class stays.

The ASPRS classes are those of the LAS 1.4 specification (R15, Table 17); in point formats 0-5
the withheld flag is a bit of the classification byte, in formats 6-10 one of the classification
flags -- laspy reads both as ``withheld``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aldpat.io.classified import GROUND, HIGH_NOISE, LOW_NOISE, UNCLASSIFIED, classes_of_table, withheld
from aldpat.io.table import PointTable
from aldpat.params import SharedOption, param

#: ASPRS "created, never classified"
NEVER_CLASSIFIED = 0
#: Which returns take part in the ground search, by name.
RETURNS = ("all", "last", "first")


@dataclass(frozen=True)
class ExistingClassesOption(SharedOption):
    """Which points of a classified LAS take part in finding ground (:func:`taking_part`)."""

    ignore_classes: tuple[int, ...] | None = param(
        (LOW_NOISE, HIGH_NOISE),
        "points of these LAS classes take no part in finding ground and keep their class (7 low "
        "noise, 18 high noise); withheld points never take part; none: every class takes part",
        ge=0, le=255, level="advanced",
    )
    returns: str = param(
        "all", "which returns take part in finding ground: all, last (last and only returns) or first "
        "(first and only returns); the others keep their class", choices=RETURNS, level="advanced",
    )


#: The LAS dimensions :func:`taking_part` reads (a reader may decode just these and x, y, z).
TAKING_PART_FIELDS = ("classification", "withheld", "return_number", "number_of_returns")


def taking_part(table: PointTable, params: object) -> np.ndarray | None:
    """Which points of ``table`` take part in finding ground: not withheld, not of a class in
    ``params.ignore_classes``, of the returns ``params.returns`` names. None when every point
    does (the common case costs no mask)."""
    part = np.ones(len(table), bool)
    held = withheld(table)
    if held is not None:
        part &= ~held
    classes = classes_of_table(table)
    ignore = getattr(params, "ignore_classes", None)
    if classes is not None and ignore:
        part &= ~np.isin(classes, np.asarray(ignore, dtype=np.int64))
    returns = getattr(params, "returns", "all")
    if returns != "all" and "return_number" in table.columns:
        number = np.asarray(table.columns["return_number"]).astype(np.int16)
        # a return numbered 0 (a file that never said) counts as the pulse's only return
        if returns == "first":
            part &= number <= 1
        else:
            of = np.asarray(table.columns.get("number_of_returns", number)).astype(np.int16)
            part &= (number >= of) | (number == 0) | (of == 0)
    return None if part.all() else part


def survey_classes(found: np.ndarray, existing: np.ndarray | None, part: np.ndarray | None, *,
                   noise_only: bool = False) -> np.ndarray:
    """The class of every point in classified output.

    ``found``: the filter's classes (2 ground, 1 not, 7 a low outlier or low noise, 18 high
    noise); ``existing``: the classes the input held (None: none, ``found`` is the answer);
    ``part``: which points took part (None: all). A point that took no part keeps its class.
    For the others: ground -> 2, a former 2 or 0 that is not ground -> 1, 7 and 18 as found,
    every other class kept. ``noise_only`` (a filter that finds noise, not ground): no point
    becomes 2; a kept point keeps its class (0 -> 1), a removed one is 7 or 18.
    """
    found = np.asarray(found, np.uint8)
    if existing is None:
        out = found.copy()
        if noise_only:
            out[out == GROUND] = UNCLASSIFIED
        return out
    out = np.asarray(existing).astype(np.uint8, copy=True)
    took = np.ones(len(out), bool) if part is None else part
    noise = took & np.isin(found, (LOW_NOISE, HIGH_NOISE))
    if noise_only:
        out[took & (out == NEVER_CLASSIFIED)] = UNCLASSIFIED
    else:
        ground = took & (found == GROUND)
        out[took & ~ground & np.isin(out, (NEVER_CLASSIFIED, GROUND))] = UNCLASSIFIED
        out[ground] = GROUND
    out[noise] = found[noise]
    return out


def ground_flags(found: np.ndarray, part: np.ndarray | None) -> np.ndarray:
    """Which points the filter found to be ground (a point that took no part is not)."""
    ground = np.asarray(found) == GROUND
    return ground if part is None else ground & part
