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
    proc = subprocess.run([sys.executable, "-c", wrapper], capture_output=True, text=True, cwd=cwd)
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr)
    line = next(ln for ln in proc.stdout.splitlines() if ln.startswith("@@"))
    return json.loads(line[2:])


def mib(n: float) -> str:
    return f"{n / 2**20:,.0f} MiB"
