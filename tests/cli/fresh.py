"""Run the real ``aldpat`` console script in a fresh process, as a user does.

A fresh process per command matters: a module another test already imported in the same process
hides import-time and lazy-import faults (a crash of ``aldpat grid``'s default method was missed
that way), and only a real process shows the exit status, stderr and signals a user sees.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "jobs" / "data"
TEST_DATA = REPO / "tests" / "data"


def aldpat_command() -> list[str]:
    """The installed console script beside this interpreter (``python -m aldpat`` otherwise)."""
    script = Path(sys.executable).with_name("aldpat")
    if script.exists():
        return [str(script)]
    found = shutil.which("aldpat")
    return [found] if found else [sys.executable, "-m", "aldpat"]


@dataclass
class Done:
    args: list[str]
    returncode: int
    stdout: str
    stderr: str

    def ok(self) -> Done:
        assert self.returncode == 0, f"aldpat {' '.join(self.args)} -> {self.returncode}\n{self.stderr}"
        return self


def aldpat(*args, cwd: Path | None = None, env: dict | None = None, timeout: float = 300) -> Done:
    """Run ``aldpat ARGS`` in a new process; never a traceback on stdout or stderr."""
    words = [str(a) for a in args]
    full_env = dict(os.environ, **(env or {}))
    full_env.pop("COLUMNS", None)
    proc = subprocess.run(aldpat_command() + words, check=False, capture_output=True, text=True, cwd=cwd, env=full_env,
                          timeout=timeout, stdin=subprocess.DEVNULL)
    for stream in (proc.stdout, proc.stderr):
        assert "Traceback" not in stream, f"aldpat {' '.join(words)}:\n{proc.stderr}"
        assert "internal error" not in stream, f"aldpat {' '.join(words)}:\n{proc.stderr}"
    return Done(words, proc.returncode, proc.stdout, proc.stderr)


def count_points(path: Path) -> int:
    """Points in a LAS/LAZ file (its header, read by laspy) or data lines in a text file."""
    path = Path(path)
    if path.suffix.lower() in (".las", ".laz"):
        import laspy

        with laspy.open(path) as fh:
            return int(fh.header.point_count)
    return sum(1 for line in path.read_text(encoding="utf-8-sig").splitlines() if line.strip())


def leftovers(folder: Path) -> list[str]:
    """Temporary files anywhere under ``folder`` (there must never be any after a command)."""
    return sorted(str(p) for p in Path(folder).rglob("*.aldpat-tmp*"))
