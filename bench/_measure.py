"""Run one measurement in a fresh process and report its wall time and peak memory.

Peak memory is the child's own high-water resident set size (``VmHWM`` of /proc/self/status:
unlike ``ru_maxrss`` it starts afresh at exec), so each figure is what that operation alone
needed, interpreter and imports included.
"""

from __future__ import annotations

import json
import subprocess
import sys


def measure(code: str, *, cwd: str | None = None) -> dict:
    """Execute ``code`` (which must set ``result`` to a dict) in a new interpreter."""
    wrapper = (
        "import json, time\n"
        "t0 = time.perf_counter()\n"
        f"{code}\n"
        "seconds = time.perf_counter() - t0\n"
        "peak = next(int(l.split()[1]) * 1024 for l in open('/proc/self/status') if l.startswith('VmHWM'))\n"
        "print('@@' + json.dumps(dict(result, seconds=seconds, peak_bytes=peak)))\n"
    )
    proc = subprocess.run([sys.executable, "-c", wrapper], check=False, capture_output=True, text=True, cwd=cwd)
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr)
    line = next(ln for ln in proc.stdout.splitlines() if ln.startswith("@@"))
    return json.loads(line[2:])


def mib(n: float) -> str:
    return f"{n / 2**20:,.0f} MiB"


def write_synthetic_points(path, n: int, x_range: tuple[float, float], y_range: tuple[float, float],
                           z_range: tuple[float, float] = (200.0, 400.0), seed: int = 0) -> None:
    """``n`` uniform random ``x y z i`` lines (2 decimals), made once: an existing file is kept.

    Written under a temporary name and renamed, so an interrupted run never leaves a short file
    that a later run would take for a complete one.
    """
    from pathlib import Path

    import numpy as np

    path = Path(path)
    if path.exists():
        return
    rng = np.random.default_rng(seed)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".part")
    with open(tmp, "w") as fh:
        for start in range(0, n, 1_000_000):
            m = min(1_000_000, n - start)
            block = np.column_stack([rng.uniform(*x_range, m), rng.uniform(*y_range, m),
                                     rng.uniform(*z_range, m), rng.integers(0, 255, m)])
            fh.write(("%.2f %.2f %.2f %d\n" * m) % tuple(block.ravel().tolist()))
    tmp.rename(path)
