"""Accuracy of a ground classification against reference labels.

The measures of the ISPRS filter test (Sithole & Vosselman 2004), as the dissertation reports
them (ch. 6, Tables 6-9 ff.): Type I = bare earth rejected / all bare earth, Type II = objects
accepted as ground / all objects, total = all misclassified / all points, and Cohen's kappa.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from aldpat.errors import DataError


@dataclass(frozen=True)
class Accuracy:
    ground_as_ground: int  # a
    ground_as_object: int  # b  (Type I errors)
    object_as_ground: int  # c  (Type II errors)
    object_as_object: int  # d

    @property
    def n(self) -> int:
        return self.ground_as_ground + self.ground_as_object + self.object_as_ground + self.object_as_object

    @property
    def type1(self) -> float:
        g = self.ground_as_ground + self.ground_as_object
        return 100.0 * self.ground_as_object / g if g else 0.0

    @property
    def type2(self) -> float:
        o = self.object_as_ground + self.object_as_object
        return 100.0 * self.object_as_ground / o if o else 0.0

    @property
    def total(self) -> float:
        return 100.0 * (self.ground_as_object + self.object_as_ground) / self.n if self.n else 0.0

    @property
    def kappa(self) -> float:
        a, b, c, d = self.ground_as_ground, self.ground_as_object, self.object_as_ground, self.object_as_object
        n = self.n
        if n == 0:
            return 0.0
        observed = (a + d) / n
        expected = ((a + b) * (a + c) + (c + d) * (b + d)) / (n * n)
        return (observed - expected) / (1.0 - expected) if expected != 1.0 else 1.0

    def as_dict(self) -> dict:
        out = {"type1": round(self.type1, 4), "type2": round(self.type2, 4), "total": round(self.total, 4),
               "kappa": round(self.kappa, 6), "points": self.n}
        out.update(asdict(self))
        return out


def accuracy(reference_ground: np.ndarray, predicted_ground: np.ndarray) -> Accuracy:
    """Confusion counts of two aligned boolean arrays (True = ground)."""
    ref = np.asarray(reference_ground, dtype=bool)
    pred = np.asarray(predicted_ground, dtype=bool)
    return Accuracy(int(np.sum(ref & pred)), int(np.sum(ref & ~pred)),
                    int(np.sum(~ref & pred)), int(np.sum(~ref & ~pred)))


#: The largest key int64 holds, with room (2**63 is 9.22e18): past it the keys wrapped -- at
#: ``--tolerance 1e-300`` every point got the same key, and every point of a result "matched"
#: every point of any reference. (Past 2**53 keys are no longer every whole number, but equal coordinates still
#: get equal keys: a tolerance below the coordinates' precision matches them exactly.)
MOST_KEY = 9e18


def coordinate_keys(x: np.ndarray, y: np.ndarray, z: np.ndarray, tolerance: float) -> np.ndarray:
    """Integer keys of coordinates snapped to ``tolerance`` (n x 3 int64); a :class:`DataError`
    when a coordinate is more steps of ``tolerance`` from 0 than keys hold."""
    steps = [np.round(np.asarray(v, dtype=np.float64) / tolerance) for v in (x, y, z)]
    for axis, s in zip("xyz", steps, strict=False):
        far = float(np.max(np.abs(s), initial=0.0))
        if not far < MOST_KEY:
            raise DataError(f"{axis} is {far:.3g} steps of the tolerance {tolerance:g} m from 0, more than coordinates "
                            f"can be matched at ({MOST_KEY:.3g}); use a larger --tolerance")
    return np.stack(steps, axis=1).astype(np.int64)


def _key_counts(ref_keys: np.ndarray, ref_ground: np.ndarray, res_keys: np.ndarray, res_ground: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each reference point's key number, and per key: reference points, ground-labelled ones,
    result points, result points called ground."""
    both = np.concatenate([ref_keys, res_keys])
    _, group = np.unique(both, axis=0, return_inverse=True)
    group = group.ravel()
    g_ref, g_res = group[: len(ref_keys)], group[len(ref_keys):]
    m = int(group.max()) + 1 if len(group) else 0
    ref_total = np.bincount(g_ref, minlength=m)
    ref_g = np.bincount(g_ref, weights=np.asarray(ref_ground, dtype=float), minlength=m).astype(np.int64)
    res_total = np.bincount(g_res, minlength=m)
    res_g = np.bincount(g_res, weights=np.asarray(res_ground, dtype=float), minlength=m).astype(np.int64)
    return g_ref, ref_total, ref_g, res_total, res_g


def match_accuracy(ref_keys: np.ndarray, ref_ground: np.ndarray, res_keys: np.ndarray,
                   res_ground: np.ndarray) -> tuple[Accuracy, int]:
    """Accuracy of result points matched to reference points by coordinate key.

    Duplicates count as many times as they occur: a key seen r times in the reference is called
    ground as often as the result holds it as ground (at most r times); ground labels are served
    first. Reference points absent from the result count as rejected (object). Returns the
    accuracy and the number of result points that match no reference point.
    """
    _, ref_total, ref_g, res_total, res_g = _key_counts(ref_keys, ref_ground, res_keys, res_ground)
    called_ground = np.minimum(res_g, ref_total)
    a = np.minimum(called_ground, ref_g)
    c = called_ground - a
    b = ref_g - a
    d = (ref_total - ref_g) - c
    unmatched = int(np.sum(np.maximum(res_total - ref_total, 0)))
    return Accuracy(int(a.sum()), int(b.sum()), int(c.sum()), int(d.sum())), unmatched


def reference_calls(ref_keys: np.ndarray, ref_ground: np.ndarray, res_keys: np.ndarray,
                    res_ground: np.ndarray) -> np.ndarray:
    """Whether the result calls each reference point ground, served as :func:`match_accuracy`
    counts them: of the r reference points of one key, the result's ground calls go to the
    ground-labelled ones first, in input order. ``accuracy(ref_ground, reference_calls(...))``
    equals the accuracy :func:`match_accuracy` returns."""
    ref_ground = np.asarray(ref_ground, dtype=bool)
    g_ref, ref_total, ref_g, _, res_g = _key_counts(ref_keys, ref_ground, res_keys, res_ground)
    called_ground = np.minimum(res_g, ref_total)
    ground_quota = np.minimum(called_ground, ref_g)  # ground points called ground, per key
    object_quota = called_ground - ground_quota  # object points called ground, per key
    # rank of each reference point among those of its key with its label, in input order
    slot = g_ref * 2 + ~ref_ground
    order = np.argsort(slot, kind="stable")
    first = np.searchsorted(slot[order], slot[order], side="left")
    rank = np.empty(len(slot), np.int64)
    rank[order] = np.arange(len(slot)) - first
    return rank < np.where(ref_ground, ground_quota[g_ref], object_quota[g_ref])
