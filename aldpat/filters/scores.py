"""How accurate each ground filter measured, with its defaults: what ``aldpat filter --help``
tells a user choosing one.

The figures are the mean total error (%) over the seven ISPRS filter-test reference samples
(Sithole & Vosselman 2004) that ``python bench/bench_filters.py isprs`` scores, as tabled in
``bench/README.md`` ("Ground filters: ISPRS accuracy"); the held-out figure, where measured, is
the mean over samples left out of the choice of the filter's constants (leave-one-out:
``bench/bench_auto.py sweep`` for gapm, ``bench/bench_point_filters.py sweep`` for the point
filters). This is their one place in the code: when a filter's defaults change and the benchmark
runs again, change them here (``tests/cli/test_help.py`` checks them against the README).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class IsprsScore:
    """Mean total error (%) on the seven samples, and on samples held out (``None``: not measured)."""

    total: float
    held_out: float | None = None
    note: str = ""  # what the figure means for this filter, when it is not a ground filter's

    def text(self) -> str:
        held = f" (held out: {self.held_out:.2f} %)" if self.held_out is not None else ""
        return f"{self.total:.2f} %{held}" + (f", {self.note}" if self.note else "")


#: each filter's score with its defaults, best first
ISPRS_SCORES: dict[str, IsprsScore] = {
    "gapm": IsprsScore(2.60, held_out=2.84),
    "atin": IsprsScore(3.46, held_out=5.69),
    "pm": IsprsScore(3.88),
    "pmcircle": IsprsScore(4.02),
    "pm2d": IsprsScore(4.29),
    "ipf": IsprsScore(5.16, held_out=5.73),
    "poly2": IsprsScore(5.83, held_out=5.83),
    "slope": IsprsScore(6.03, held_out=7.05),
    "cluster-pm": IsprsScore(6.05),
    "multipass": IsprsScore(7.61),
    "etew": IsprsScore(10.76),
    "outlier": IsprsScore(24.61, note="noise only, a step before a ground filter"),
}

#: the filter to start with: the lowest error with its defaults
START_WITH = min(ISPRS_SCORES, key=lambda name: ISPRS_SCORES[name].total)
