"""Load the ISPRS filter-test samples and score a ground classification.

The seven reference samples (Sithole & Vosselman 2004) in the folder ``data_paths.ISPRS_SAMPLES``:
``x y z label`` per line, label 0 = bare earth, 1 = object. The files are stored ground-first,
so nothing here relies on their order. Measures as the dissertation reports them (ch. 6,
Tables 6-9 ff.): Type I = bare earth rejected / all bare earth, Type II = objects accepted as
ground / all objects, total = misclassified / all points, and Cohen's kappa.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from data_paths import ISPRS_SAMPLES

from aldpat.core.accuracy import Accuracy, accuracy

DATA = ISPRS_SAMPLES
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

#: GAPM with parameter set 02, dissertation Table 6-11 (%): total, type I, type II.
PUBLISHED_GAPM_SET02 = {
    "samp12": (3.27, 2.66, 3.99),
    "samp21": (1.96, 1.17, 4.84),
    "samp24": (8.56, 9.22, 6.86),
    "samp42": (4.74, 0.86, 6.63),
    "samp51": (2.85, 1.05, 9.37),
    "samp53": (9.59, 9.69, 7.00),
    "samp61": (3.63, 3.62, 3.80),
}

#: GAPM with parameter set 03, dissertation Table 6-14 (%): total, type I, type II.
PUBLISHED_GAPM_SET03 = {
    "samp12": (3.33, 2.80, 3.96),
    "samp21": (1.98, 1.17, 4.95),
    "samp24": (13.19, 15.80, 6.38),
    "samp42": (4.78, 0.86, 6.70),
    "samp51": (2.84, 1.05, 9.34),
    "samp53": (9.98, 10.10, 7.00),
    "samp61": (4.21, 4.23, 3.71),
}

#: The three sets by their number, as the parameter files are named.
PUBLISHED_GAPM = {"01": PUBLISHED_GAPM_SET01, "02": PUBLISHED_GAPM_SET02, "03": PUBLISHED_GAPM_SET03}


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


#: The scores are the package's own (Type I, Type II, total, kappa), as ``aldpat evaluate`` prints.
Score = Accuracy


def score(reference_ground: np.ndarray, predicted_ground: np.ndarray) -> Accuracy:
    """Score aligned boolean arrays (True = ground) with :func:`aldpat.core.accuracy.accuracy`."""
    r = np.asarray(reference_ground, dtype=bool)
    p = np.asarray(predicted_ground, dtype=bool)
    if r.shape != p.shape:
        raise ValueError(f"reference has {r.size} points, prediction {p.size}")
    return accuracy(r, p)
