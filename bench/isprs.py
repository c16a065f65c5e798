"""Load the ISPRS filter-test samples and score a ground classification.

The seven reference samples of ``../shared/data/isprs/`` (beside the repository) (Sithole & Vosselman 2004):
``x y z label`` per line, label 0 = bare earth, 1 = object. The files are stored ground-first,
so nothing here relies on their order. Measures as the dissertation reports them (ch. 6,
Tables 6-9 ff.): Type I = bare earth rejected / all bare earth, Type II = objects accepted as
ground / all objects, total = misclassified / all points, and Cohen's kappa.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

DATA = Path(os.environ.get("ALDPAT_ISPRS", Path(__file__).resolve().parents[2] / "shared" / "data" / "isprs"))
SAMPLES = ("samp12", "samp21", "samp24", "samp42", "samp51", "samp53", "samp61")

#: GAPM with parameter set 01, dissertation Table 6-9 (%): total, type I, type II.
PUBLISHED_GAPM_SET01 = {
    "samp12": (3.28, 2.65, 4.01),
    "samp21": (1.96, 1.17, 4.84),
    "samp24": (5.41, 4.71, 7.21),
    "samp42": (5.61, 0.86, 7.93),
    "samp51": (2.70, 0.89, 9.26),
    "samp53": (8.73, 8.81, 6.92),
    "samp61": (3.26, 3.25, 3.63),
}


@dataclass
class Sample:
    name: str
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    ground: np.ndarray  # reference: True = bare earth

    def __len__(self) -> int:
        return len(self.z)


def load_sample(name: str, data: Path = DATA) -> Sample:
    """One sample as arrays (all points, in file order)."""
    a = np.loadtxt(data / f"{name}.txt", dtype=np.float64, ndmin=2)
    return Sample(name, a[:, 0].copy(), a[:, 1].copy(), a[:, 2].copy(), a[:, 3] == 0)


def load_samples(names=SAMPLES, data: Path = DATA) -> list[Sample]:
    return [load_sample(n, data) for n in names]


@dataclass(frozen=True)
class Score:
    """Confusion counts and the ISPRS measures (percent)."""

    a: int  # ground called ground
    b: int  # ground called object (Type I)
    c: int  # object called ground (Type II)
    d: int  # object called object

    @property
    def n(self) -> int:
        return self.a + self.b + self.c + self.d

    @property
    def type1(self) -> float:
        return 100.0 * self.b / (self.a + self.b) if self.a + self.b else 0.0

    @property
    def type2(self) -> float:
        return 100.0 * self.c / (self.c + self.d) if self.c + self.d else 0.0

    @property
    def total(self) -> float:
        return 100.0 * (self.b + self.c) / self.n if self.n else 0.0

    @property
    def kappa(self) -> float:
        n = self.n
        if n == 0:
            return 0.0
        po = (self.a + self.d) / n
        pe = ((self.a + self.b) * (self.a + self.c) + (self.c + self.d) * (self.b + self.d)) / (n * n)
        return (po - pe) / (1.0 - pe) if pe != 1.0 else 1.0


def score(reference_ground: np.ndarray, predicted_ground: np.ndarray) -> Score:
    """Score aligned boolean arrays (True = ground)."""
    r = np.asarray(reference_ground, dtype=bool)
    p = np.asarray(predicted_ground, dtype=bool)
    if r.shape != p.shape:
        raise ValueError(f"reference has {r.size} points, prediction {p.size}")
    return Score(int(np.sum(r & p)), int(np.sum(r & ~p)), int(np.sum(~r & p)), int(np.sum(~r & ~p)))
