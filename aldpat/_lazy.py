"""Import heavy libraries when first used, not when ``aldpat`` starts.

Every command imports every task module to build its command line; the scientific libraries
those modules compute with (scipy, pyproj) would otherwise add most of a second to each
``aldpat`` invocation, even ``aldpat info`` on one small file.

:func:`lazy_import` returns a stand-in whose first attribute access runs an ordinary
``importlib.import_module``. That matters under threads: ``importlib.util.LazyLoader`` puts a
module into ``sys.modules`` *before* it has executed, so when several threads of a pool touch
it at once the others see a half-loaded module (``scipy.spatial`` without ``QhullError``). The
ordinary import machinery holds a per-module lock until the module has finished loading and
makes every other importing thread wait for it, so nothing is ever seen half-built. The
stand-in itself never enters ``sys.modules``.
"""

from __future__ import annotations

import importlib
import importlib.util
import threading
from types import ModuleType
from typing import Any

_lock = threading.Lock()


class LazyModule(ModuleType):
    """Forwards attribute access to module ``name``, importing it on first use (thread-safe)."""

    def __init__(self, name: str):
        super().__init__(name)
        self._lazy_target: ModuleType | None = None

    def _lazy_load(self) -> ModuleType:
        target = self._lazy_target
        if target is None:
            # import_module waits for a module another thread is still loading; the lock only
            # keeps two threads from both storing the result
            module = importlib.import_module(self.__name__)
            with _lock:
                if self._lazy_target is None:
                    self._lazy_target = module
                target = self._lazy_target
        return target

    def __getattr__(self, attr: str) -> Any:
        # only called for names not found on the stand-in itself
        if attr.startswith("_lazy_"):
            raise AttributeError(attr)
        return getattr(self._lazy_load(), attr)

    def __dir__(self) -> list[str]:
        return dir(self._lazy_load())

    def __repr__(self) -> str:
        state = "loaded" if self._lazy_target is not None else "not loaded yet"
        return f"<lazy module {self.__name__!r} ({state})>"


def lazy_import(name: str) -> ModuleType:
    """``name`` as a module that is imported when an attribute of it is first used.

    A module that does not exist is reported now, not at first use.
    """
    if importlib.util.find_spec(name) is None:
        raise ModuleNotFoundError(f"No module named {name!r}", name=name)
    return LazyModule(name)
