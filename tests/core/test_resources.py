"""What the machine has to give: the memory check sees the process's own limit too."""

from __future__ import annotations

import resource
import subprocess
import sys

from tests.cli.fresh import DATA, aldpat_command

LIMIT = 3 << 30  # an address space of 3 GiB: a fresh aldpat runs in it, a 5.7 GB grid does not


def _limited() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (LIMIT, LIMIT))


def test_available_memory_stays_within_ulimit_v():
    """Under ``ulimit -v`` the check compared a step with the machine's free memory, so a grid
    the limit could never hold was started and failed at its allocation; what the process may
    still map is now the most it is told it has."""
    code = "from aldpat.core.resources import available_memory; print(available_memory())"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                          preexec_fn=_limited)
    assert 0 < int(done.stdout) < LIMIT


def test_a_grid_past_ulimit_v_is_refused_before_it_is_made(tmp_path):
    """In a fresh ``aldpat grid``: the refusal says what the grid needs and what the limit leaves."""
    done = subprocess.run([*aldpat_command(), "grid", str(DATA / "samp24.txt"), "--cell", "0.01", "--odir",
                           str(tmp_path / "g")], capture_output=True, text=True, check=False, preexec_fn=_limited,
                          stdin=subprocess.DEVNULL, timeout=300)
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert "grid (88.3 million nodes) of 0.01 m cells needs 5.7 GB of memory and" in done.stderr, done.stderr
    assert "out of memory" not in done.stderr
