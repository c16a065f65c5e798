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


def aldpat_batch(cases: list[dict], *, total: float = 600) -> list[dict]:
    """Run many command lines, each ``{"args": [...], "cwd": ..., "limit": seconds, "env": {...}}``,
    in one fresh process (:mod:`tests.cli.batch`); return each one's ``status`` (an exit status,
    ``"hang"`` or ``"escaped"``), ``stdout``, ``stderr`` and ``seconds``. A case stuck where its
    own time limit cannot reach is ``"hang"`` too: the process is ended and the cases after it run
    in a new one. ``total`` bounds the whole batch."""
    import json
    import tempfile
    import time

    results: list[dict] = []
    deadline = time.monotonic() + total
    with tempfile.TemporaryDirectory(prefix="aldpat-batch-") as scratch:
        while len(results) < len(cases):
            todo = [dict(c, args=[str(a) for a in c["args"]], cwd=str(c["cwd"])) for c in cases[len(results):]]
            spec, got = Path(scratch) / "cases.json", Path(scratch) / "results.json"
            spec.write_text(json.dumps(todo), encoding="utf-8")
            got.unlink(missing_ok=True)
            env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
            env.pop("COLUMNS", None)
            proc = subprocess.Popen([sys.executable, "-m", "tests.cli.batch", str(spec), str(got)], cwd=REPO, env=env,
                                    stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True)
            # the slowest case's own limit, and a margin for start-up, past the batch's deadline
            budget = max(deadline - time.monotonic(), max(c.get("limit", 30.0) for c in todo) + 30)
            try:
                proc.communicate(timeout=budget)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.communicate()
            done = json.loads(got.read_text(encoding="utf-8")) if got.exists() else []
            results += done
            if len(results) < len(cases):  # the process died or was ended in the middle of a case
                stuck = todo[len(done)]
                results.append({"args": stuck["args"], "status": "hang" if proc.returncode in (-9, None) else
                                f"died ({proc.returncode})", "stdout": "", "stderr": "", "seconds": budget})
    return results
