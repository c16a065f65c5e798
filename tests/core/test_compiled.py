"""Compiled loops keep working where numba cannot keep a cache."""

from aldpat.core.compiled import compiled


def test_a_function_whose_cache_cannot_be_kept_is_compiled_all_the_same():
    # a function from exec'd source has no file beside which, nor in whose name, numba could
    # cache: plain njit(cache=True) raises "no locator available" when it is defined
    namespace: dict = {}
    exec(compile("def twice(x):\n    return 2 * x\n", "<string>", "exec"), namespace)  # noqa: S102 (no source file)
    twice = compiled()(namespace["twice"])
    assert twice(21) == 42
    assert twice.signatures  # it was compiled, not left as Python


def test_a_module_function_is_cached():
    from aldpat.filters.slope_search import steep_search

    assert steep_search._cache is not None and type(steep_search._cache).__name__ == "FunctionCache"


def test_the_compiler_is_loaded_once_on_a_thread_of_its_own():
    # in a fresh process: the first compiled call of a run is made on a thread, once, and a
    # compiled call made meanwhile works (it waits on numba's lock)
    import subprocess
    import sys

    code = (
        "import threading\n"
        "from aldpat.core import compiled\n"
        "compiled.load_compiler_in_background()\n"
        "compiled.load_compiler_in_background()\n"
        "loaders = [t for t in threading.enumerate() if t.name == 'aldpat-load-compiler']\n"
        "assert len(loaders) <= 1, loaders\n"
        "from aldpat.core.nearest_fill import flat_cells\n"
        "import numpy as np\n"
        "assert flat_cells(np.array([2.5]), np.array([1.5]), 0.0, 0.0, 1.0, 0, 0, 3, 4).tolist() == [6]\n"
        "for t in loaders:\n"
        "    t.join(60)\n"
        "assert compiled._nothing.signatures\n"
        "print('ok')\n"
    )
    done = subprocess.run([sys.executable, "-c", code], check=False, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "ok"
