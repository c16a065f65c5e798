"""Lazily imported modules are safe when many threads touch them first at the same instant."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from aldpat._lazy import LazyModule, lazy_import

# Runs in a fresh interpreter: scipy.spatial must not be imported yet when the threads start.
RACE = textwrap.dedent("""
    import sys, threading
    from aldpat._lazy import lazy_import
    assert "scipy.spatial" not in sys.modules
    spatial = lazy_import("scipy.spatial")
    barrier = threading.Barrier(16)
    errors = []
    def touch():
        barrier.wait()
        try:
            spatial.QhullError, spatial.Delaunay, spatial.cKDTree
        except Exception as exc:
            errors.append(repr(exc))
    threads = [threading.Thread(target=touch) for _ in range(16)]
    [t.start() for t in threads]
    [t.join() for t in threads]
    print(len(errors), errors[:1])
""")


@pytest.mark.parametrize("attempt", range(3))
def test_first_use_from_many_threads_at_once(attempt):
    proc = subprocess.run([sys.executable, "-c", RACE], check=False, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("0 "), proc.stdout


def test_loads_on_first_attribute_and_forwards():
    mod = lazy_import("json")
    assert isinstance(mod, LazyModule) and "not loaded" in repr(mod)
    assert mod.loads("[1]") == [1]
    assert "loaded" in repr(mod) and "dumps" in dir(mod)


def test_a_missing_module_is_reported_at_once():
    with pytest.raises(ModuleNotFoundError):
        lazy_import("no_such_module_here")
