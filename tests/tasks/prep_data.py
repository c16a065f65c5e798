"""Synthetic 9-column ALTM tapes with known strips and returns, shared by the preparation tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np

FMT = "%.2f %.2f %.2f %.2f %d %.2f %.2f %.2f %d"


def tape_rows(times: np.ndarray, seed: int = 0) -> np.ndarray:
    """Rows t x2 y2 z2 i2 x1 y1 z1 i1 (last-first order): first return 0-9 m above the last."""
    rng = np.random.default_rng(seed)
    n = len(times)
    x = np.round(rng.uniform(500000, 500100, n), 2)
    y = np.round(rng.uniform(2800000, 2800100, n), 2)
    z2 = np.round(rng.uniform(1, 3, n), 2)
    z1 = np.round(z2 + rng.uniform(0, 9, n), 2)
    return np.column_stack([times, x, y, z2, rng.integers(1, 255, n), x + 0.01, y + 0.01, z1,
                            rng.integers(1, 255, n)])


def write_tape(path: Path, rows: np.ndarray, order: str = "last-first") -> Path:
    if order == "first-last":
        rows = rows[:, [0, 5, 6, 7, 8, 1, 2, 3, 4]]
    np.savetxt(path, rows, fmt=FMT)
    return path
