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
