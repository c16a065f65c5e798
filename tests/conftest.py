"""Shared fixtures: small real data shipped in the repository, and a CLI runner."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

REPO = Path(__file__).resolve().parents[1]
SAMP24 = REPO / "jobs" / "data" / "samp24.txt"  # ISPRS filter-test sample 24: x y z label


@pytest.fixture
def samp24() -> Path:
    return SAMP24


@pytest.fixture
def runner() -> CliRunner:
    return CliRunner()


@pytest.fixture
def cli():
    from aldpat.cli.main import cli as root

    return root


def write_xyz(path: Path, xyz: np.ndarray, fmt: str = "%.2f", delimiter: str = " ", newline: str = "\n",
              header: str | None = None) -> Path:
    with open(path, "w", newline="") as fh:
        if header:
            fh.write(header + newline)
        fh.writelines(delimiter.join(fmt % v for v in row) + newline for row in xyz)
    return path
